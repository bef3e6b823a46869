"""Shared fixtures: the Mariner, its model, reference records, and a CLI runner."""

from __future__ import annotations

import os

# as the CLI does: one BLAS thread (small regressions; multi-threaded BLAS contends)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

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


def mlflow_runs(root: Path) -> list[tuple]:
    """(run_uuid, status, name) of every run in the default store under ``root``."""
    db = Path(root) / "mlruns" / "mlflow.db"
    if not db.exists():
        return []
    with sqlite3.connect(db) as con:
        return con.execute("select run_uuid, status, name from runs").fetchall()


def rng(seed=0):
    return np.random.default_rng(seed)
