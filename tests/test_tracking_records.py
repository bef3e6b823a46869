"""What a run records besides its files: the params of its own kind of study,
step metrics of the GA and of emcee, and the report's HTML page."""

from __future__ import annotations

import json
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from hydra import compose
from omegaconf import OmegaConf

from studies.identification import GeneticRefinement, LeastSquares, build_problems
from studies.identification.base import Identification
from studies.identification.bayes import BayesianRegression
from studies.identification.objective import TrajectoryObjective
from studies.runtime.tracking import RunLogger, flatten
from studies.simulate import simulate, zigzag
from studies.workflows.kinds import logged_params


# ------------------------------------------------------------------ params of the run's kind

def _logged(name: str, *overrides: str) -> dict:
    """The flattened params a job of ``studies <name> overrides`` logs."""
    cfg = compose(name, overrides=list(overrides))
    return flatten(logged_params(OmegaConf.to_object(cfg), OmegaConf.to_container(cfg, resolve=True)))


def _groups(params: dict) -> set:
    return {key.split(".")[0] for key in params}


def test_a_plain_run_logs_only_the_settings_it_uses(hydra):
    params = _logged("config")
    assert not [k for k in params if k.startswith(("simplify.", "report.", "discover.", "tracking.",
                                                   "kalman.", "identify."))]
    assert not {"verbose", "resume", "run_name"} & set(params)
    assert params["method.name"] == "ls" and params["model.name"] == "abkowitz"
    assert params["manoeuvre.name"] == "zigzag_20_20" and params["vessel.name"] == "mariner"
    assert {"wind.speed", "wind.direction", "noise.wind_speed_error", "noise.measurement", "seed",
            "validate.manoeuvres", "disturbance.level"} <= set(params)


def test_each_kind_and_command_adds_what_it_reads(hydra):
    # a preset tells the report its rows; the default series is not logged
    preset = _logged("config", "experiment=thesis_wind_speed")
    assert preset["report.condition"] == "wind.speed" and "report.series" not in preset
    # the simplified model is derived with the simplify settings
    assert "simplify.realisations" in _logged("config", "model=simplified")
    # measured records go through the Kalman smoother and the weighted regression
    assert {"kalman", "identify"} <= _groups(_logged("config", "data.path=rec.csv"))
    # a roll decay knows no wind, vessel or manoeuvre; it reads another simulator's run
    roll = _groups(_logged("config", "model=roll", "method=nls"))
    assert {"model", "method", "data", "validate", "simulation"} <= roll
    assert not {"wind", "vessel", "manoeuvre", "noise"} & roll
    # a discovery logs its own options
    assert {"discover", "simulation", "wind"} <= _groups(_logged("discover", "data.path=rec.csv"))


def test_the_report_still_finds_the_swept_key_in_the_logged_params(hydra):
    from studies.report.builder import _condition_key

    runs = [SimpleNamespace(params=_logged("config", f"wind.speed={v}", "method=ls_ga")) for v in (4, 8)]
    assert _condition_key(runs, None) == "wind.speed"


# ------------------------------------------------------------------ step metrics

@pytest.fixture(scope="module")
def short_zigzag(vessel, model):
    """A clean 300 s zig-zag 20/20 of the Mariner and its regression problems."""
    record = simulate(model, vessel.coefficients, vessel, zigzag(20, 20, duration=300.0))
    return record, build_problems(model, vessel, record)


class _OffStart(GeneticRefinement):
    """GA started from LS with its genes 20 % off: it has something to improve."""

    def start(self, problems, objective):
        params = dict(LeastSquares().fit(problems).params)
        for gene in self.genes:
            params[gene] *= 1.2
        return Identification(params=params)


def test_ga_records_its_best_fitness_per_generation(short_zigzag, model, vessel):
    record, problems = short_zigzag
    ga = _OffStart(genes=["Xrr", "Yvvr", "Nvvr", "Yr", "Nr"], generations=8, seed=1)
    result = ga.fit(problems, TrajectoryObjective(model, vessel, [record]))
    steps, best = zip(*result.history["ga/best_fitness"])
    assert steps == tuple(range(9))                     # generation 0 = the starting solution
    assert best[0] == result.metrics["ga/initial_fitness"]
    assert best[-1] == result.metrics["ga/best_fitness"] < best[0]
    assert all(b <= a for a, b in zip(best, best[1:]))  # eq. 3.43: lower is better
    population = dict(result.history["ga/population_best_fitness"])
    assert set(population) == set(steps) and all(population[g] >= best[g] for g in steps)


def test_emcee_records_acceptance_and_autocorrelation_at_checkpoints(short_zigzag):
    _, problems = short_zigzag
    result = BayesianRegression(n_samples=640, burn_in=100, thin=2, seed=0).fit_one(problems["N"])
    acceptance = result.history["bayes/N/acceptance_fraction"]
    steps = [s for s, _ in acceptance]
    assert 10 < len(steps) <= 50 and steps == sorted(steps) and steps[-1] == 140   # 100 + 2 x 20
    assert all(0.0 <= a <= 1.0 for _, a in acceptance)
    assert acceptance[-1][1] == result.metrics["bayes/N/acceptance_fraction"]
    tau = result.history["bayes/N/autocorr_time_max"]
    assert len(tau) >= 2 and tau[-1] == (140, result.metrics["bayes/N/autocorr_time_max"])


class _Client:
    """Records what a RunLogger sends to the store."""

    def __init__(self):
        self.metrics, self.artifacts = [], []

    def log_batch(self, run_id, metrics=(), params=()):
        self.metrics += list(metrics)

    def log_artifact(self, run_id, path):
        self.artifacts.append(Path(path).name)

    def log_artifacts(self, run_id, path, artifact_path=None):
        pass


def test_a_history_is_logged_at_its_steps_and_not_again_at_step_0(tmp_path):
    (tmp_path / "metric_history.json").write_text(json.dumps(
        {"ga/best_fitness": [[0, 3.0], [1, 2.0], [2, 1.5]], "bayes/X/autocorr_time_max": [[5, np.nan]]}))
    client = _Client()
    RunLogger(client, "run", f"sqlite:///{tmp_path / 'db'}").log_outputs(
        {"ga/best_fitness": 1.5, "ga/initial_fitness": 3.0, "bad": np.inf}, tmp_path)
    logged = sorted((m.key, m.step, m.value) for m in client.metrics)
    assert logged == [("ga/best_fitness", 0, 3.0), ("ga/best_fitness", 1, 2.0), ("ga/best_fitness", 2, 1.5),
                      ("ga/initial_fitness", 0, 3.0)]
    assert "metric_history.json" in client.artifacts


# ------------------------------------------------------------------ the HTML report

class _StoredRun:
    """A run as :func:`studies.runtime.tracking.read_experiment` gives it."""

    def __init__(self, number: int, speed: int, method: str, fitness: float, status="FINISHED", error=None):
        self.run_id = f"{number:032x}"
        self.name = f"{method} zigzag_20_20 wind={speed}"
        self.status, self.start_time = status, number
        self.params = {"wind.speed": str(speed), "method.name": method}
        self.metrics = {"zigzag_10_10/fitness": fitness}
        self.tags = {"error": error} if error else {}
        self.url = f"http://127.0.0.1:5000/#/experiments/1/runs/{self.run_id}"

    def artifact(self, path, destination):
        if path != "coefficients.csv":
            return None
        Path(destination).mkdir(parents=True, exist_ok=True)
        table = pd.DataFrame({"name": ["Xu", "Yv"], "value": [1.0, 2.0], "lower": np.nan, "upper": np.nan,
                              "true": [1.0, 2.1], "deviation_pct": [0.0, -4.8]})
        table.to_csv(Path(destination) / path, index=False)
        return Path(destination) / path


def test_the_html_page_is_the_rendered_markdown_with_run_links(tmp_path):
    from studies.report.builder import build_report

    runs = [_StoredRun(1, 8, "ls", 1e-3), _StoredRun(2, 4, "ls", 2e-3), _StoredRun(3, 4, "ls_ga", 1e-4),
            _StoredRun(4, 8, "ls_ga", 0.0, "FAILED", "ValueError: <b>bad</b> | x")]
    page = build_report("small", runs, tmp_path)
    html = page.with_suffix(".html").read_text()
    body = html.split("<body>", 1)[1]
    assert "`" not in body and "**" not in body and "<code>wind.speed</code>" in body
    tables = re.findall(r"<table>.*?</table>", body, re.S)
    assert len(tables) >= 3
    for table in tables:
        head = table.split("<tbody>")[0]
        assert head.count("<tr>") == 1, head                 # one header row
    for run in runs:
        assert f'<a href="{run.url}">{run.name}</a>' in body and f"<code>{run.run_id}</code>" in body
    assert "&lt;b&gt;bad&lt;/b&gt;" in body and "<b>bad" not in body   # text from the store stays text
    # the run table reads in condition order, one row per run
    rows = re.findall(r"^\| \[(.+?)\]", page.read_text(), re.M)
    assert rows == ["ls zigzag_20_20 wind=4", "ls_ga zigzag_20_20 wind=4", "ls zigzag_20_20 wind=8",
                    "ls_ga zigzag_20_20 wind=8"]


def test_overlay_titles_do_not_repeat_the_manoeuvre():
    from studies.report.builder import _overlay_title

    assert _overlay_title("zigzag_20_20", None, "zigzag_20_20", 1) == "zigzag_20_20"
    assert _overlay_title("zigzag_10_10", None, "circle", 2) == "zigzag_10_10, trained on circle"
    assert _overlay_title("zigzag_10_10", "wind.speed", "8", 2) == "zigzag_10_10 at 8 m/s"
