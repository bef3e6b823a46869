"""Nothing a command wrote before is missing now.

The manifests in ``tests/manifests/`` list, by name, the files, MLflow
params, metrics, tags, artifacts and logged models that the README's main
job and the tour's discovery left behind, as written by the version of
`studies` before the start-up work (lazy imports, thinned figures, the
compiled filter in loops). Each test runs the command as a user does, in a
fresh folder, and fails naming whatever is gone (new outputs are allowed).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from conftest import run_studies
from run_manifest import MANIFESTS, manifest, missing
from studies.benchmarks import shared_data

MARIN = shared_data("kvlcc2_free_running")


def _kept(name: str, args: list, project) -> None:
    proc = run_studies(args, project, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    stored = json.loads((MANIFESTS / f"{name}.json").read_text())
    gone = missing(stored, manifest(project))
    assert not gone, f"{name}: outputs missing since the stored manifest: {gone}"


#: modules a least-squares run on simulated data does not use: each costs 0.3-2 s to import
HEAVY = ("emcee", "scipy.stats", "scipy.signal", "pygad", "pysindy", "sklearn", "SALib", "corner")


@pytest.fixture(scope="module")
def main_job(tmp_path_factory):
    """The README's main job run once as a user runs it, with Python's import log."""
    project = tmp_path_factory.mktemp("main_job")
    env = dict(os.environ, MLFLOW_DISABLE_TELEMETRY="true")
    proc = subprocess.run([sys.executable, "-X", "importtime", "-m", "studies", "run"], cwd=project,
                          capture_output=True, text=True, timeout=900, env=env)
    assert proc.returncode == 0, proc.stderr[-3000:]
    imported = {line.rsplit("|", 1)[-1].strip() for line in proc.stderr.splitlines()
                if line.startswith("import time:")}
    return project, imported


@pytest.mark.slow
def test_the_main_job_writes_everything_it_wrote(main_job):
    project, _ = main_job
    stored = json.loads((MANIFESTS / "main_job.json").read_text())
    gone = missing(stored, manifest(project))
    assert not gone, f"main_job: outputs missing since the stored manifest: {gone}"


@pytest.mark.slow
def test_the_main_job_imports_only_what_it_uses(main_job):
    """The estimators, the discovery and the roll pipeline are imported when used
    (``studies.lazy``, :mod:`studies.workflows.kinds`): the main job loads none of their
    libraries."""
    _, imported = main_job
    assert "studies.identification.ls" in imported and "mlflow" in imported     # the log is read
    loaded = sorted(m for m in HEAVY if m in imported)
    assert not loaded, f"the main job imported {loaded}"


@pytest.mark.slow
@pytest.mark.skipif(not (MARIN / "MARIN_FREE_KVLCC2_tc_35_m.dat").is_file(), reason="MARIN's records are not here")
def test_the_tour_discovery_writes_everything_it_wrote(tmp_path):
    train = ",".join(str(MARIN / f"MARIN_FREE_KVLCC2_{n}_m.dat") for n in ("zz_10", "zz_20"))
    _kept("tour_discover", ["discover", "model=mmg", f"data.path=[{train}]",
                            f"validate.path=[{MARIN / 'MARIN_FREE_KVLCC2_tc_35_m.dat'}]"], tmp_path)


def test_a_missing_output_is_named():
    """The comparison itself: a file, a metric and the model gone are each reported."""
    stored = {"files": ["a.png", "b.csv"], "metrics": ["x", "y"], "logged_models": 1}
    now = {"files": ["b.csv", "c.json"], "metrics": ["y"], "logged_models": 0}
    assert missing(stored, now) == {"files": ["a.png"], "metrics": ["x"], "logged_models": "0 < 1"}
    assert missing(stored, {**stored, "files": ["a.png", "b.csv", "new.png"]}) == {}
