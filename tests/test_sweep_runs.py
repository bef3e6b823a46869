"""A sweep is a parent MLflow run with its jobs as child runs, and a report is
about one sweep, not every run of the experiment pooled."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from conftest import run_studies
from studies.runtime.tracking import select_sweep

SHORT = ["manoeuvre.duration=300", "validate.manoeuvres=[zigzag_10_10]", "validate.duration=100"]


def _run(name, start, **tags):
    return SimpleNamespace(name=name, start_time=start, tags=tags)


def test_the_report_takes_the_latest_sweep_and_never_a_parent_run():
    runs = [_run("plain", 1), _run("parent a", 2, kind="sweep", sweep_id="a"),
            _run("a1", 3, sweep_id="a"), _run("a2", 4, sweep_id="a"),
            _run("parent b", 5, kind="sweep", sweep_id="b"), _run("b1", 6, sweep_id="b")]
    assert [r.name for r in select_sweep(runs, None)] == ["b1"]
    assert [r.name for r in select_sweep(runs, "a")] == ["a1", "a2"]
    assert [r.name for r in select_sweep(runs, "all")] == ["plain", "a1", "a2", "b1"]
    assert [r.name for r in select_sweep(runs[:1], None)] == ["plain"]
    with pytest.raises(LookupError, match="known: a, b"):
        select_sweep(runs, "nope")


@pytest.mark.slow
def test_a_sweep_is_a_parent_run_with_child_runs_and_its_own_report(tmp_path):
    import mlflow

    plain = run_studies(["run", "wind.speed=8", *SHORT], tmp_path)
    assert plain.returncode == 0, plain.stderr
    swept = run_studies(["run", "-m", "wind.speed=4,12", *SHORT], tmp_path)
    assert swept.returncode == 0, swept.stderr
    assert "studies report report.experiment=studies report.sweep=" in swept.stderr
    client = mlflow.MlflowClient(f"sqlite:///{tmp_path / 'mlruns' / 'mlflow.db'}")
    runs = client.search_runs([client.get_experiment_by_name("studies").experiment_id])
    parents = [r for r in runs if r.data.tags.get("kind") == "sweep"]
    assert len(parents) == 1
    parent = parents[0]
    children = [r for r in runs if r.data.tags.get("mlflow.parentRunId") == parent.info.run_id]
    assert len(children) == 2 and parent.info.status == "FINISHED"
    assert {r.data.tags["sweep_id"] for r in children} == {parent.data.tags["sweep_id"]}
    assert parent.data.metrics["jobs/finished"] == 2.0
    assert parent.data.tags["multirun_dir"].startswith(str(tmp_path / "multirun"))
    report = run_studies(["report"], tmp_path)
    assert report.returncode == 0, report.stderr
    page = (tmp_path / "reports" / "studies" / "index.md").read_text()
    assert "2 runs" in page and "8 m/s" not in page        # the plain run is not pooled in


def test_conditions_sort_by_value_not_as_text():
    from studies.report.tables import _condition_sort

    assert _condition_sort(["12 m/s", "16 m/s", "4 m/s", "8 m/s"]) == ["4 m/s", "8 m/s", "12 m/s", "16 m/s"]
    assert _condition_sort(["+5 %", "-10 %", "+10 %", "-5 %"]) == ["-10 %", "-5 %", "+5 %", "+10 %"]
    assert _condition_sort(["circle, +10 %", "circle, +5 %"]) == ["circle, +5 %", "circle, +10 %"]


def test_several_varying_keys_are_named_instead_of_pooled():
    from studies.report.builder import _condition_key

    def run(**params):
        return SimpleNamespace(params={k.replace("_", "."): v for k, v in params.items()})

    runs = [run(wind_speed="0", manoeuvre_duration="200"), run(wind_speed="8", manoeuvre_duration="300")]
    with pytest.raises(LookupError, match="differ in manoeuvre.duration, wind.speed"):
        _condition_key(runs, None)
    assert _condition_key(runs, "wind.speed") == "wind.speed"
    assert _condition_key(runs[:1], None) is None
    assert _condition_key([run(wind_speed="0"), run(wind_speed="4")], None) == "wind.speed"
