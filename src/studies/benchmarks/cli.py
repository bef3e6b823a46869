"""What a user waits for: the commands of the README, timed as whole processes.

Every figure is the wall time [s] of ``python -m studies ...`` started
afresh in a new project folder, as a user runs it:

- ``cli_import_reference_s``: ``python -c "import numpy, pandas,
  scipy.optimize, matplotlib.pyplot, mlflow"``, what any such script pays
  before it does anything (the yardstick of the others: compare ratios);
- ``cli_run_first_s`` / ``cli_run_s``: ``studies run`` (the README's main
  job) in a new folder with an empty compile cache (the first run after an
  install: numba compiles, the store is created) and then in the same
  folder (median of the repeats);
  ``cli_run_ratio`` is ``cli_run_s / cli_import_reference_s``;
- ``cli_discover_marin_first_s`` / ``cli_discover_marin_s``: the tour's
  ``studies discover`` on MARIN's records, the same way (absent when the
  shared records are not there);
- ``cli_sweep_per_job_s``: a 10-job sweep (``-m wind.speed=0,...,9`` on the
  main job) divided by its jobs, and ``cli_sweep_beyond_identify_s`` that
  minus the jobs' mean identification time (their
  ``runtime/identify_s``): what a job costs beyond its work;
- ``cli_report_s``: ``studies report`` on that sweep's experiment.

The compile cache of the "first" runs is a fresh ``NUMBA_CACHE_DIR``; the
later runs use the one the first run filled, and its project folder. ``source`` (a ``src``
folder) times another checkout of `studies` with this bench.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from studies.benchmarks import shared_data

__all__ = ["run", "REFERENCE_IMPORTS"]

#: what a manoeuvring script imports before doing anything
REFERENCE_IMPORTS = "import numpy, pandas, scipy.optimize, matplotlib.pyplot, mlflow"
#: the tour's discovery: MARIN's two zig-zags, its turning circle held out
MARIN_TRAIN = ("MARIN_FREE_KVLCC2_zz_10_m.dat", "MARIN_FREE_KVLCC2_zz_20_m.dat")
MARIN_HELD_OUT = "MARIN_FREE_KVLCC2_tc_35_m.dat"
SWEEP_JOBS = 10


def _env(cache: Path, source: str | None) -> dict:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), MLFLOW_DISABLE_TELEMETRY="true")
    env.pop("MLFLOW_TRACKING_URI", None)
    if source:
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(source), env.get("PYTHONPATH")]))
    return env


def _timed(argv: list, cwd: Path, env: dict) -> float:
    t0 = time.perf_counter()
    proc = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True)
    elapsed = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(argv[2:])} failed ({proc.returncode}): {proc.stderr[-2000:]}")
    return elapsed


def _studies(*args) -> list:
    return [sys.executable, "-m", "studies", *args]


def _first_and_then(argv: list, root: Path, source: str | None, repeats: int, name: str) -> dict:
    """``{name}_first_s`` in a new project folder with an empty compile cache (the
    first run after an install: a new store, numba compiles), ``{name}_s`` the
    median of ``repeats`` runs after it in the same folder (the store and the
    cache the first left), as a user's later runs."""
    env = _env(root / f"cache_{name}", source)
    folder = Path(tempfile.mkdtemp(dir=root))
    first = _timed(argv, folder, env)
    then = [_timed(argv, folder, env) for _ in range(repeats)]
    return {f"{name}_first_s": first, f"{name}_s": statistics.median(then)}


def _sweep_and_report(root: Path, source: str | None, repeats: int) -> dict:
    folder = root / "sweep"
    folder.mkdir()
    env = _env(root / "cache_cli_run", source)
    speeds = ",".join(str(v) for v in range(SWEEP_JOBS))
    wall = _timed(_studies("run", "-m", f"wind.speed={speeds}", "tracking.experiment=bench_sweep"), folder, env)
    identify = []
    for metrics in folder.glob("multirun/*/*/*/metrics.json"):
        identify.append(float(json.loads(metrics.read_text()).get("runtime/identify_s", 0.0)))
    per_job = wall / SWEEP_JOBS
    out = {"cli_sweep_per_job_s": per_job}
    if identify:
        out["cli_sweep_beyond_identify_s"] = per_job - statistics.mean(identify)
    report = [_timed(_studies("report", "report.experiment=bench_sweep"), folder, env) for _ in range(repeats)]
    out["cli_report_s"] = statistics.median(report)
    return out


def run(repeats: int = 3, source: str | None = None) -> dict:
    """The figures above; ``repeats`` runs after each first one."""
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        env = _env(root / "cache_reference", source)
        out["cli_import_reference_s"] = statistics.median(
            _timed([sys.executable, "-c", REFERENCE_IMPORTS], root, env) for _ in range(repeats))
        out.update(_first_and_then(_studies("run"), root, source, repeats, "cli_run"))
        out["cli_run_ratio"] = out["cli_run_s"] / out["cli_import_reference_s"]
        folder = shared_data("kvlcc2_free_running")
        if all((folder / f).is_file() for f in (*MARIN_TRAIN, MARIN_HELD_OUT)):
            train = ",".join(str(folder / f) for f in MARIN_TRAIN)
            argv = _studies("discover", "model=mmg", f"data.path=[{train}]",
                            f"validate.path=[{folder / MARIN_HELD_OUT}]")
            out.update(_first_and_then(argv, root, source, repeats, "cli_discover_marin"))
        out.update(_sweep_and_report(root, source, repeats))
    return out


if __name__ == "__main__":      # python -m studies.benchmarks.cli [SRC]: another checkout's figures
    print(json.dumps(run(source=sys.argv[1] if len(sys.argv) > 1 else None), indent=2))
