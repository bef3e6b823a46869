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


def test_the_main_job_writes_everything_it_wrote(tmp_path):
    _kept("main_job", ["run"], tmp_path)


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
