"""Shared fixtures: the Mariner, its model, reference records, and a CLI runner.

Records that several test modules build identically (simulated zig-zags, the
regression problems of the 4000 s zig-zag, the reference program's short
zig-zag, the hidden-effect records of seed 11) are built once per session.
Tests must not modify them in place (copy first).
"""

from __future__ import annotations

import os

# as the CLI does: one BLAS thread (small regressions; multi-threaded BLAS contends)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import socket
import sqlite3
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from studies.config_check import check_arguments
from studies.errors import StudiesError

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"

sys.path.insert(0, str(Path(__file__).resolve().parent))


def marin_file(manoeuvre: str) -> Path:
    """A MARIN KVLCC2 free-running record (``zz_10``, ``zz_20``, ``tc_35``) of
    the shared data folder; the test is skipped when it is absent."""
    path = SHARED_DATA / "kvlcc2_free_running" / f"MARIN_FREE_KVLCC2_{manoeuvre}_m.dat"
    if not path.is_file():
        pytest.skip(f"MARIN KVLCC2 data not available: {path} is absent "
                    "(the shared data folder is not mounted next to the repo)")
    return path


def hsva_file(test: str) -> Path:
    """An HSVA KVLCC2 free-running zig-zag of the shared data folder (``10_10_S``,
    ``35_05``, ...); the test is skipped when it is absent."""
    path = SHARED_DATA / "kvlcc2_hsva" / f"HSVA_CPMC_KVLCC2_Z_{test}.dat"
    if not path.is_file():
        pytest.skip(f"HSVA KVLCC2 data not available: {path} is absent "
                    "(the shared data folder is not mounted next to the repo)")
    return path


@pytest.fixture(scope="session")
def vessel():
    from studies.vessels import get_vessel

    return get_vessel("mariner")


@pytest.fixture(scope="session")
def model():
    from studies.models import abkowitz

    return abkowitz()


@pytest.fixture(scope="session")
def zigzag_4000(vessel, model):
    """Clean RK4 zig-zag 20/20 of the thesis: 4000 s at 0.1 s (40 001 samples)."""
    from studies.simulate import simulate, zigzag

    return simulate(model, vessel.coefficients, vessel, zigzag(20, 20, duration=4000.0))


@pytest.fixture(scope="session")
def zigzag_1500(vessel, model):
    """Clean RK4 zig-zag 20/20 of the Mariner: 1500 s at 0.1 s."""
    from studies.simulate import simulate, zigzag

    return simulate(model, vessel.coefficients, vessel, zigzag(20, 20, duration=1500.0))


@pytest.fixture(scope="session")
def zigzag_600(vessel, model):
    """Clean RK4 zig-zag 20/20 of the Mariner: 600 s at 0.1 s."""
    from studies.simulate import simulate, zigzag

    return simulate(model, vessel.coefficients, vessel, zigzag(20, 20, duration=600.0))


@pytest.fixture(scope="session")
def windy_zigzag_4000(vessel, model):
    """RK4 zig-zag 20/20 of the Mariner, 4000 s at 0.1 s, in a 12 m/s wind from
    45 deg (thesis Tables 4.6-4.8); the record carries the true wind."""
    from studies.environment.conditions import Environment
    from studies.simulate import simulate, zigzag

    env = Environment(12.0, np.deg2rad(45.0))
    return simulate(model, vessel.coefficients, vessel, zigzag(20, 20, duration=4000.0), env)


@pytest.fixture(scope="session")
def problems_4000(model, vessel, zigzag_4000):
    """Regression problems (X, Y, N) of the clean 4000 s zig-zag."""
    from studies.identification.regression import build_problems

    return build_problems(model, vessel, zigzag_4000)


@pytest.fixture(scope="session")
def good_frame():
    """A valid record as a table: the reference program's 120 s zig-zag 20/20
    at 0.1 s (tests/reference_mariner.py), the starting point of bad input."""
    import reference_mariner as ref

    return pd.DataFrame(ref.zigzag_record(20.0, 20.0, duration=120.0, dt=0.1))


@pytest.fixture(scope="session")
def hidden_none_11(vessel):
    """``(records, truth)`` of :func:`studies.scenarios.hidden.hidden_records` with
    nothing hidden, seed 11, no noise: zig-zag 20/20, turning circle, zig-zag 10/10."""
    from studies.scenarios.hidden import hidden_records

    return hidden_records(vessel, "none", seed=11)


def deviations(params: dict, truth: dict) -> dict:
    """100 (identified - true) / true per coefficient."""
    return {k: 100.0 * (params[k] - truth[k]) / truth[k] for k in truth}


def run_studies(args, cwd, timeout=600, env_extra=None):
    """Run the installed ``studies`` console script as a user would."""
    env = dict(os.environ)
    env["MLFLOW_DISABLE_TELEMETRY"] = "true"
    env.update(env_extra or {})
    return subprocess.run([sys.executable, "-m", "studies", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=timeout, env=env)


def _refused_in_process(config_name: str, args: list[str], root: Path, command: str,
                        *expected: str) -> str:
    """The check ``studies <command> <args>`` runs before Hydra starts a job, in
    process: it must refuse with one line (what the CLI prints after
    ``studies: error:``, exit status 2) holding every ``expected`` text, and
    write nothing under ``root``. Returns the line."""
    root = Path(root)
    before = sorted(root.rglob("*"))
    with pytest.raises(StudiesError) as info:
        check_arguments(config_name, list(args), root, command)
    line = str(info.value)
    assert line and "\n" not in line.strip(), line
    for text in expected:
        assert text in line, (text, line)
    assert sorted(root.rglob("*")) == before, "the check wrote files"
    return line


@pytest.fixture(scope="session")
def refused_in_process():
    """``refused_in_process(config_name, args, root, command, *expected)``: a
    command line refused by the check before Hydra, run in process (fast); the
    end-to-end refusal (exit status 2, one line on stderr, no MLflow run) is
    tested through the console script once per kind of refusal."""
    return _refused_in_process


def mlflow_runs(root: Path) -> list[tuple]:
    """(run_uuid, status, name) of every job's run in the default store under
    ``root`` (a sweep's parent run, tagged ``kind=sweep``, is left out: see
    :func:`sweep_parents`)."""
    return [r for r in _all_runs(root) if r[0] not in {p[0] for p in sweep_parents(root)}]


def sweep_parents(root: Path) -> list[tuple]:
    """(run_uuid, status, name) of the sweeps' parent runs in the default store."""
    db = Path(root) / "mlruns" / "mlflow.db"
    if not db.exists():
        return []
    with sqlite3.connect(db) as con:
        parents = {r for (r,) in con.execute("select run_uuid from tags where key = 'kind' "
                                             "and value = 'sweep'").fetchall()}
    return [r for r in _all_runs(root) if r[0] in parents]


def _all_runs(root: Path) -> list[tuple]:
    db = Path(root) / "mlruns" / "mlflow.db"
    if not db.exists():
        return []
    with sqlite3.connect(db) as con:
        return con.execute("select run_uuid, status, name from runs").fetchall()


def rng(seed=0):
    return np.random.default_rng(seed)


def free_port() -> int:
    """A TCP port free on 127.0.0.1 at the time of asking."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_until_healthy(url: str, proc: subprocess.Popen, seconds: float) -> None:
    """Wait until the MLflow server or UI of ``proc`` answers ``<url>/health``
    (AssertionError when it does not within ``seconds`` or ``proc`` ends)."""
    deadline = time.time() + seconds
    while True:
        try:
            with urllib.request.urlopen(f"{url}/health", timeout=2) as answer:
                if answer.status == 200:
                    return
        except OSError:
            pass
        if proc.poll() is not None or time.time() > deadline:
            raise AssertionError(f"the MLflow server at {url} did not answer within {seconds:g} s")
        time.sleep(0.5)


@pytest.fixture(scope="module")
def hydra():
    """The package's Hydra configuration, initialised for the module's tests (``compose``)."""
    from hydra import initialize_config_module
    from hydra.core.global_hydra import GlobalHydra

    GlobalHydra.instance().clear()
    with initialize_config_module("studies.conf", version_base="1.3"):
        yield
    GlobalHydra.instance().clear()
