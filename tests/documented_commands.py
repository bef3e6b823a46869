"""The command lines the README and ``docs/`` show, and a folder in which they run as written.

:func:`documented_commands` reads every ``studies ...`` command line from the
README and the pages of ``docs/``: the indented code lines (a leading
``NAME=value`` environment setting kept, a trailing ``# comment`` dropped)
and the inline code spans that are whole command lines. Templates are left
out: a span with a placeholder (``<paper>``, ``NAME``, ``URI``, ``[...]``,
``...``, ``[key=value ...]``), ending in ``=``, a shell variable (``$e``),
or a bare command name.

:func:`examples_folder` makes the folder a newcomer would have: the project
folder with the shared data folder beside it (``../shared/data``, a link to
the real one), and the files the README's examples name, as stand-ins made
by code that shares nothing with ``studies`` (:mod:`reference_mariner`) or
read from the shared records: ``my_zigzag.csv``, ``a.csv``, ``b.csv``,
``c.csv``, ``zz20.csv``, ``turn.csv``, ``zz10.csv`` and
``other_sim_zz10.csv`` (the Mariner, named by a sidecar ``<file>.yaml``),
``zz10.dat``, ``zz20.dat``, ``tc35.dat`` (MARIN's KVLCC2 runs),
``decay.csv``, ``decay1.csv``, ``decay2.csv``, ``test1.csv``,
``test2.csv`` (SSPA's KVLCC2 roll decays in the data contract, the ship
named by a sidecar ``<file>.yaml``) and ``fnpf.csv`` (the potential-flow decay).
"""

from __future__ import annotations

import os
import re
import shlex
from dataclasses import dataclass
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"

#: the pages whose command lines are read
PAGES = ("README.md", *sorted(str(p.relative_to(REPO)) for p in (REPO / "docs").glob("*.md")))

_PLACEHOLDER = re.compile(r"<[a-z ]+>|\bNAME\b|\bURI\b|\bPAPER\b|\[\.\.\.\]|\.\.\.|\[key=value|\[port=|"
                          r"\[simulator|\[seeds=|\[report\.|\[manoeuvre=|\$")
_ENV = re.compile(r"^(?:[A-Z_][A-Z0-9_]*=\S+\s+)+")


@dataclass(frozen=True)
class Documented:
    """One command line as a page shows it."""

    page: str
    line: int
    text: str           # the command line as written (environment settings first, no comment)

    @property
    def env(self) -> dict:
        """The ``NAME=value`` settings written before ``studies``."""
        prefix = _ENV.match(self.text)
        return dict(item.split("=", 1) for item in prefix.group(0).split()) if prefix else {}

    @property
    def argv(self) -> list[str]:
        """The words after ``studies``, as a shell splits them."""
        return shlex.split(_ENV.sub("", self.text))[1:]

    def __str__(self) -> str:
        return f"{self.page}:{self.line}: {self.text}"


#: the syntax rows of the README's table of commands (not commands to run)
TEMPLATES = {"studies run -m a=1,2 b=x,y"}


def _is_command(text: str) -> bool:
    if text in TEMPLATES:
        return False
    words = _ENV.sub("", text).split()
    return (len(words) >= 3 or (len(words) == 2 and words[1].startswith("-"))
            or words == ["studies", "run"] or words == ["studies", "ui"]) \
        and words[0] == "studies" and not _PLACEHOLDER.search(text) and not text.endswith("=")


def documented_commands() -> list[Documented]:
    """Every whole ``studies`` command line of the README and ``docs/``, in page order."""
    found, seen = [], set()
    for page in PAGES:
        for number, line in enumerate((REPO / page).read_text().splitlines(), start=1):
            candidates = []
            if line.startswith("    ") and re.match(r"(?:[A-Z_][A-Z0-9_]*=\S+\s+)*studies\b", line.strip()):
                candidates.append(re.split(r"\s{2,}#", line.strip())[0].strip())
            candidates += [span.strip() for span in re.findall(r"`((?:[A-Z_][A-Z0-9_]*=\S+\s+)*studies [^`]+)`",
                                                                line)]
            for text in candidates:
                if _is_command(text) and (page, text) not in seen:
                    seen.add((page, text))
                    found.append(Documented(page, number, text))
    return found


# ----------------------------------------------------------------------------- the folder


def _write(path: Path, record: dict) -> None:
    import reference_mariner as ref

    ref.write_csv(path, record)


def _marin_as_is(folder: Path) -> None:
    for stem, name in (("zz_10", "zz10.dat"), ("zz_20", "zz20.dat"), ("tc_35", "tc35.dat")):
        (folder / name).symlink_to(SHARED / "data" / "kvlcc2_free_running" / f"MARIN_FREE_KVLCC2_{stem}_m.dat")


def _roll_decay(source: Path, target: Path) -> None:
    """A roll decay of SSPA's tests in the data contract (``t`` [s], ``phi`` [rad])."""
    import csv

    with open(source, newline="") as fh:
        rows = list(csv.DictReader(fh))
    t = np.array([float(r["time"]) for r in rows])
    phi = np.array([float(r["phi"]) for r in rows])
    _write(target, {"t": t, "phi": phi})


def examples_folder(root: Path) -> Path:
    """``root/project`` with ``root/shared`` linked to the shared folder and the
    examples' files in it; returns the project folder."""
    import reference_mariner as ref

    project = root / "project"
    project.mkdir(parents=True)
    (root / "shared").symlink_to(SHARED)
    zigzag = ref.zigzag_record(20.0, 20.0, duration=600.0, dt=0.5)
    _write(project / "my_zigzag.csv", zigzag)
    _write(project / "a.csv", zigzag)
    _write(project / "zz20.csv", zigzag)
    turn = ref.turning_record(18.0, duration=600.0, dt=0.5)
    _write(project / "b.csv", turn)
    _write(project / "turn.csv", turn)
    zz10 = ref.zigzag_record(10.0, 10.0, duration=600.0, dt=0.5)
    _write(project / "c.csv", zz10)
    _write(project / "zz10.csv", zz10)
    # another simulator's zig-zag 10/10: the same program at a coarser step, as a
    # second code with its own integration would give
    _write(project / "other_sim_zz10.csv", ref.zigzag_record(10.0, 10.0, duration=600.0, dt=1.0))
    for name in ("my_zigzag.csv", "a.csv", "b.csv", "c.csv", "zz20.csv", "turn.csv", "zz10.csv",
                 "other_sim_zz10.csv"):
        (project / f"{name}.yaml").write_text("vessel: mariner\n")
    _marin_as_is(project)
    decays = SHARED / "data" / "kvlcc2_roll_decay"
    for source, targets in (("model_test_21337.csv", ("decay.csv", "decay1.csv", "test1.csv")),
                            ("model_test_21338.csv", ("decay2.csv", "test2.csv"))):
        for target in targets:
            _roll_decay(decays / source, project / target)
    for target in ("decay.csv", "decay1.csv", "decay2.csv", "test1.csv", "test2.csv"):
        (project / f"{target}.yaml").write_text("vessel: kvlcc2\n")
    (project / "fnpf.csv").symlink_to(decays / "fnpf_kvlcc2_rolldecay_0kn.csv")
    return project


def studies_env(extra: dict | None = None) -> dict:
    """The environment a user's shell gives ``studies`` (plus ``extra``)."""
    env = dict(os.environ)
    env["MLFLOW_DISABLE_TELEMETRY"] = "true"
    env.update(extra or {})
    return env


# ----------------------------------------------------------------------------- what runs where

#: presets checked, not run here: their own time on this machine's two cores
LONG_PRESETS = {
    "kvlcc2_cross_facility": "HSVA's 13 zig-zags -> MARIN, about 40 s (tests/test_cross_facility.py)",
    "kvlcc2_pooled": "16 records held out in turn, about 1 min",
    "kvlcc2_calibration": "16 records held out in turn with bands, about 13 min",
    "kvlcc2_roll_calibration": "8 Bayesian roll runs, about 7 min",
    "thesis_wind_speed": "the thesis' wind sweep (tests/test_thesis_reproduction.py runs a reduced one)",
    "svm_disturbance": "the SVM paper's trials (tests/test_svm_paper.py runs a reduced one)",
    "roll_methods": "9 roll runs, about 1 min (tests/test_roll_paper.py runs a reduced one)",
    "excitation": "the excitation sweep of Li et al. 2023",
    "my_sweep": "6 jobs of a user's preset (tests/test_user_conf.py runs a preset from conf/)",
}


def _tour() -> set[str]:
    """The command lines of the README's tour."""
    text = (REPO / "README.md").read_text().split("<!-- tour -->", 1)[1].split("<!-- /tour -->", 1)[0]
    return {re.split(r"\s{2,}#", line.strip())[0].strip() for line in text.splitlines() if line.strip()}


def not_run(command: Documented) -> str | None:
    """Why ``command`` is checked (its settings composed and validated, as the
    command line does before any job) instead of run here; None: it is run."""
    argv = command.argv
    if command.text in _tour():
        return "the README's tour: run step by step by tests/test_readme_tour.py"
    if argv[:1] == ["ui"]:
        return "a server: started and asked by tests/test_readme_tour.py and tests/test_sweeps_reports.py"
    if argv[:1] == ["bench"]:
        return "performance figures and discovery hit rates: minutes to hours, run by `studies bench`"
    presets = [a.split("=", 1)[1] for a in argv if a.startswith("experiment=")]
    if presets and presets[0] in LONG_PRESETS:
        return LONG_PRESETS[presets[0]]
    reported = [a.split("=", 1)[1] for a in argv if a.startswith(("report.experiment=", "report.compare="))]
    if argv[:1] == ["report"] and reported and reported[0] != "tour" and reported[0] != "studies":
        return f"needs the runs of a preset not run here ({reported[0]})"
    return None


def user_presets(project: Path) -> None:
    """The presets the docs show as a user's own (``conf/experiment/my_sweep.yaml`` of
    docs/methods.md), written into ``project/conf/`` from the page itself."""
    text = (REPO / "docs" / "methods.md").read_text()
    match = re.search(r"For example `conf/experiment/(\w+)\.yaml`:\n\n((?:    .*\n|\n)+?)\n(?=\S)", text)
    assert match, "docs/methods.md no longer shows conf/experiment/my_sweep.yaml"
    folder = project / "conf" / "experiment"
    folder.mkdir(parents=True, exist_ok=True)
    body = "\n".join(line[4:] for line in match.group(2).splitlines())
    (folder / f"{match.group(1)}.yaml").write_text(body + "\n")


def check(command: Documented, project: Path) -> None:
    """What the command line checks before it runs anything, in process: the
    settings of every job composed and validated (a Hydra command), the
    benchmark names or the discovery bench's settings (``studies bench``).
    Raises the one-line error the command would print."""
    argv = command.argv
    if argv[:1] == ["ui"] or argv[0].startswith("-") or "--help" in argv:
        return                      # nothing to check: the UI's options, the version, a help text
    if argv[:1] == ["bench"]:
        if argv[1:2] == ["discover"]:
            from studies.bench_discovery import DiscoveryBench

            DiscoveryBench.from_overrides(argv[2:])
        else:
            from studies.benchmarks import NAMES

            unknown = set(argv[1:]) - set(NAMES)
            assert not unknown, f"{command}: unknown benchmark {unknown}"
        return
    from studies.config_check import check_arguments

    config = {"run": "config", "discover": "discover", "report": "report", "simulate": "simulate",
              "simplify": "config"}[argv[0]]
    previous = dict(os.environ)
    os.environ.update({k: v.replace("../shared", str(project.parent / "shared")) for k, v in command.env.items()})
    here = Path.cwd()
    try:
        os.chdir(project)
        check_arguments(config, argv[1:], project, argv[0])
    finally:
        os.chdir(here)
        os.environ.clear()
        os.environ.update(previous)


#: what a library prints that a user cannot act on; none of it may reach the console
NOISE = ("Traceback (most recent call last)", "[HYDRA]", "Registry store URI", "Security middleware",
         "DeprecationWarning", "FutureWarning", "UserWarning", "RuntimeWarning")


def run_as_written(command: Documented, project: Path, timeout: float = 900):
    """Run ``command`` in ``project`` as a user's shell would; assert it ends with
    status 0 and prints nothing of :data:`NOISE`. Returns the finished process."""
    import subprocess
    import sys

    env = studies_env(command.env)
    proc = subprocess.run([sys.executable, "-m", "studies", *command.argv], cwd=project, env=env,
                          capture_output=True, text=True, timeout=timeout)
    output = proc.stdout + proc.stderr
    assert proc.returncode == 0, f"{command}\nexit {proc.returncode}:\n{output[-3000:]}"
    noise = [line for line in output.splitlines() if any(mark in line for mark in NOISE)]
    assert not noise, f"{command}\nprinted:\n" + "\n".join(noise[:10])
    return proc


def group(command: Documented) -> str:
    """Which test module runs ``command``: ``roll``, ``discover`` or ``runs``."""
    if "model=roll" in command.argv:
        return "roll"
    return "discover" if command.argv[:1] == ["discover"] else "runs"


def runnable(which: str) -> list[Documented]:
    """The documented commands of group ``which`` that are run, each text once, in page order."""
    seen, out = set(), []
    for command in documented_commands():
        if not_run(command) is None and group(command) == which and command.text not in seen:
            seen.add(command.text)
            out.append(command)
    return out
