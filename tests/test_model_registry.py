"""The identified model of a run as an MLflow model, as a user runs it.

``studies run tracking.register=NAME`` logs the identified model as the
run's MLflow model and registers it; ``mlflow.pyfunc.load_model`` of
``runs:/<id>/model`` or ``models:/NAME/1`` simulates the run's validation
manoeuvres with the run's results, to the last bit; ``studies simulate``
writes a run's validation files for a registered model; a bad URI is one
line and exit status 2.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from conftest import run_studies

from studies.analysis.characteristics import characteristics
from studies.errors import ConfigError, DataError

NAME = "mariner_ls"
#: a short run: 300 s training zig-zag, a zig-zag and a turning circle validated for 400 s
SHORT_RUN = ["manoeuvre.duration=300", "validate.manoeuvres=[zigzag_10_10,turning_35]",
             "validate.duration=400"]
STATES = ("x0", "y0", "psi", "u", "v", "r", "delta")


@pytest.fixture(scope="module")
def registered(tmp_path_factory):
    """A ``studies run`` into a temporary store, its model registered as ``mariner_ls``."""
    root = tmp_path_factory.mktemp("registry")
    uri = f"sqlite:///{root / 'store' / 'mlflow.db'}"
    run_dir = root / "run"
    proc = run_studies(["run", *SHORT_RUN, f"tracking.uri={uri}", f"tracking.register={NAME}",
                        f"hydra.run.dir={run_dir}"], root)
    assert proc.returncode == 0, proc.stderr[-3000:]
    run_id = proc.stdout.split("(", 1)[1].split(")", 1)[0]
    assert f"model runs:/{run_id}/model, registered as models:/{NAME}/1" in proc.stdout
    metrics = json.loads((run_dir / "metrics.json").read_text())
    return {"root": root, "uri": uri, "run_id": run_id, "run_dir": run_dir, "metrics": metrics}


@pytest.fixture
def mlflow_store(registered):
    """``mlflow``, pointed at the run's store as a user would point it
    (without leaving the URI in the environment of later commands)."""
    import mlflow

    from studies.runtime.tracking import configure

    configure(registered["uri"], registered["root"])
    return mlflow


def _characteristics(states: pd.DataFrame, name: str) -> dict:
    kind, heading = ("zigzag", np.deg2rad(10.0)) if name.startswith("zigzag") else ("turning", None)
    return {f"{name}/{k}": v for k, v in characteristics(states, kind, heading).items()
            if k not in ("execute_heading_deg", "turn_direction")}


@pytest.mark.slow
def test_the_runs_model_simulates_its_validation_manoeuvres_as_the_run_did(registered, mlflow_store):
    model = mlflow_store.pyfunc.load_model(f"runs:/{registered['run_id']}/model")
    for name in ("zigzag_10_10", "turning_35"):
        states = model.predict(pd.DataFrame({"manoeuvre": [name], "duration": [400.0]}))
        assert list(states.columns) == ["t", "x0", "y0", "psi", "u", "v", "r", "delta"]
        assert states["t"].iloc[-1] == pytest.approx(400.0)
        # the characteristics the run logged: overshoots, advance, transfer, tactical diameter
        found = _characteristics(states, name)
        assert len(found) >= 2
        for key, value in found.items():
            assert value == registered["metrics"][key], key
        # the states the run wrote beside the reference's (every tenth sample or so)
        table = pd.read_csv(registered["run_dir"] / f"validation_{name}.csv")
        at = states.set_index(states["t"].round(6)).loc[table["t"].round(6)]
        for col in STATES:
            np.testing.assert_allclose(at[col].to_numpy(), table[f"predicted_{col}"].to_numpy(),
                                       rtol=1e-12, atol=1e-12, err_msg=col)


@pytest.mark.slow
def test_the_registered_model_is_the_runs_model(registered, mlflow_store):
    client = mlflow_store.MlflowClient()
    version = client.get_model_version(NAME, "1")
    assert version.run_id == registered["run_id"]
    assert version.source.startswith("models:/m-")     # the run's logged model
    linked = {m.key: m.value for m in client.get_logged_model(version.source[len("models:/"):]).metrics}
    assert linked["turning_35/fitness"] == registered["metrics"]["turning_35/fitness"]
    assert not [k for k in linked if k.startswith("runtime/")]
    by_run = mlflow_store.pyfunc.load_model(f"runs:/{registered['run_id']}/model")
    by_name = mlflow_store.pyfunc.load_model(f"models:/{NAME}/1")
    ask = pd.DataFrame({"manoeuvre": ["turning_35"], "duration": [400.0]})
    pd.testing.assert_frame_equal(by_name.predict(ask), by_run.predict(ask))
    inputs = by_name.metadata.signature.inputs.input_names()
    assert {"manoeuvre", "t", "rudder", "delta"} <= set(inputs)
    assert by_name.metadata.signature.outputs.input_names()[:8] == ["t", "x0", "y0", "psi", "u", "v",
                                                                    "r", "delta"]


def test_a_rudder_time_series_is_simulated(registered, mlflow_store):
    """A commanded rudder of 35 deg held is the turning circle; the actual
    rudder angle prescribed from a given state is a replay."""
    model = mlflow_store.pyfunc.load_model(f"models:/{NAME}/1")
    t = np.round(np.arange(0.0, 300.05, 0.1), 10)
    turning = model.predict(pd.DataFrame({"manoeuvre": ["turning_35"], "duration": [300.0]}))
    commanded = model.predict(pd.DataFrame({"t": t, "rudder": np.full(len(t), np.deg2rad(35.0))}))
    for col in STATES:
        np.testing.assert_allclose(commanded[col], turning[col], rtol=1e-12, atol=1e-9, err_msg=col)
    # the turn's own rudder prescribed from its state at 100 s continues it
    later = turning[turning["t"] >= 100.0 - 1e-9].reset_index(drop=True)
    replayed = model.predict(later[["t", "delta", "u", "v", "r", "x0", "y0", "psi"]])
    assert replayed["t"].iloc[0] == pytest.approx(100.0)
    assert np.max(np.abs(replayed["psi"] - later["psi"])) < 1e-3
    with pytest.raises(Exception, match="radians"):
        model.predict(pd.DataFrame({"t": [0.0, 1.0], "rudder": [35.0, 35.0]}))


@pytest.mark.slow
def test_studies_simulate_writes_the_runs_characteristics_and_figures(registered, tmp_path):
    out = tmp_path / "sim"
    proc = run_studies(["simulate", f"model_uri=models:/{NAME}/1", "manoeuvre=turning_35",
                        "manoeuvre.duration=400", f"tracking.uri={registered['uri']}",
                        f"hydra.run.dir={out}"], tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    metrics = json.loads((out / "metrics.json").read_text())
    run = registered["metrics"]
    for key in ("turning_35/tactical_diameter_m", "turning_35/advance_m",
                "turning_35/tactical_diameter_error_pct", "turning_35/fitness"):
        assert metrics[key] == run[key], key
    assert metrics == {k: v for k, v in run.items() if k.startswith("turning_35/")}
    assert {"validation_turning_35.png", "validation_turning_35.csv",
            "simulation_turning_35.csv"} <= {p.name for p in out.iterdir()}
    record = pd.read_csv(out / "simulation_turning_35.csv")
    assert list(record.columns) == ["t", "x0", "y0", "psi", "u", "v", "r", "delta"]
    assert len(record) == 4001


@pytest.mark.slow      # the same refusal in process: test_uris_that_name_no_model_of_studies_are_refused
def test_a_bad_model_uri_is_one_line_and_exit_2(registered, tmp_path):
    proc = run_studies(["simulate", "model_uri=models:/no_such_model/1",
                        f"tracking.uri={registered['uri']}", f"hydra.run.dir={tmp_path / 'sim'}"],
                       tmp_path)
    assert proc.returncode == 2, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "model_uri" in lines[0] and "no_such_model" in lines[0], lines
    assert "Traceback" not in proc.stderr


def test_uris_that_name_no_model_of_studies_are_refused(registered):
    from studies.runtime import tracking

    root, uri = registered["root"], registered["uri"]
    for bad, text in ((f"models:/{NAME}/9", "not found"), ("runs:/0123456789abcdef/model", "not found"),
                      (f"runs:/{registered['run_id']}/nothing", "cannot load"), ("  ", "give runs:/")):
        with pytest.raises(ConfigError, match="model_uri") as info:
            tracking.load_model(bad, uri, root)
        assert text in str(info.value) and "\n" not in str(info.value)


def test_register_takes_a_model_name_and_a_manoeuvring_model(tmp_path, refused_in_process):
    refused_in_process("config", ["tracking.register=a/b"], tmp_path, "run", "tracking.register")
    refused_in_process("config", ["model=roll", "method=nls", "tracking.register=decay"], tmp_path, "run",
                       "tracking.register", "no MLflow model")
    refused_in_process("simulate", ["manoeuvre=roll_decay"], tmp_path, "simulate", "roll decay")


#: the reduced hull identified from HSVA's 13 zig-zags (experiment=kvlcc2_cross_facility)
REDUCED_HSVA = {"Xu": -1.2054, "Xuu": 1.1918, "Xrr": -0.0025, "Xvr": -0.334, "Xdd": -0.0394,
                "Yv": -0.3327, "Yr": 5.6182, "Yu": -0.002, "Yur": -5.5346, "Yd": 0.0476, "YTd": 0.9629,
                "YT": 0.0843, "Yvvd": 1.0384, "Nv": -0.0916, "Nr": -1.7181, "Nu": 0.0009, "Nur": 1.6776,
                "Nd": -0.0198, "NTd": -0.4345, "NT": -0.0313, "Nvvd": -0.3277}


def test_the_identified_model_file_round_trips_every_simulator():
    """Abkowitz subsets, and the MMG hull with its own propeller and rudder
    parameters: written, read and simulated to the same bits."""
    from dataclasses import replace

    from studies.environment.conditions import Environment
    from studies.models.mmg import family_modules, mmg
    from studies.models.registry import get_model
    from studies.simulate import zigzag
    from studies.vessels import get_mmg_vessel, get_vessel
    from studies.workflows.identified_model import IdentifiedModel

    mariner = get_vessel("mariner")
    simplified = get_model("simplified_li2023")
    kvlcc2 = get_mmg_vessel("kvlcc2")
    models = [
        IdentifiedModel(simplified, {n: 1.01 * mariner.coefficients[n] for n in simplified.names}, mariner,
                        Environment(8.0, np.deg2rad(30.0))),
        IdentifiedModel(mmg(), {n: 0.97 * kvlcc2.coefficients[n] for n in mmg().names}, kvlcc2,
                        modules=replace(kvlcc2.modules, epsilon=1.2, kappa=0.4)),
        # the reduced hull: terms of the thrust loading, the rudder module off
        IdentifiedModel(mmg(hull="reduced"), REDUCED_HSVA, kvlcc2, modules=family_modules("reduced", kvlcc2.modules)),
        # the cross-flow hybrid: two drag coefficients beside the linear derivatives
        IdentifiedModel(mmg(hull="crossflow"), {**{n: kvlcc2.coefficients[n] for n in mmg(hull="crossflow").names
                                                   if n in kvlcc2.coefficients}, "YCF": 0.9, "NCF": 0.5}, kvlcc2),
    ]
    assert [t.thrust for t in models[2].model.terms if t.thrust] == [1] * 4
    assert [t.name for t in models[3].model.terms if t.crossflow] == ["YCF", "NCF"]
    for model in models:
        again = IdentifiedModel.from_dict(json.loads(json.dumps(model.to_dict())))
        assert again.model == model.model
        man = zigzag(20, 20, duration=120.0 if model.is_mmg else 300.0)
        first, second = model.simulate(man), again.simulate(man)
        pd.testing.assert_frame_equal(first, second, check_exact=True)
        assert again.reference() is not None
    with pytest.raises(ConfigError, match="not an identified model"):
        IdentifiedModel.from_dict({"format": "something else"})
    with pytest.raises(DataError, match="time must increase"):
        models[0].predict(pd.DataFrame({"t": [0.0, 1.0, 1.0], "delta": [0.0, 0.1, 0.1]}))


@pytest.mark.slow
def test_an_mmg_run_logs_its_model_with_its_interaction_factors(tmp_path):
    """``model=mmg``: the run's logged model (propeller and rudder with it)
    simulates the validation manoeuvre with the run's characteristics."""
    import mlflow
    from hydra import initialize_config_module

    from studies.config import compose_settings
    from studies.runtime import tracking
    from studies.workflows.kinds import kind_for

    with initialize_config_module("studies.conf", version_base="1.3"):
        cfg = compose_settings("config", overrides=[
            "vessel=kvlcc2", "model=mmg", "manoeuvre.duration=300", "validate.manoeuvres=[turning_35]",
            "validate.duration=300", "model.captive=false"])
    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    run = kind_for(cfg).prepare(cfg, tmp_path)
    with tracking.start_run("mmg", "mmg", uri, tmp_path, {}) as logger:
        metrics = run.execute(tmp_path / "run")
        logged = logger.log_model(tmp_path / "run" / "identified_model.json", register="kvlcc2_mmg",
                                  metrics={"turning_35/fitness": metrics["turning_35/fitness"]})
        logger.log_outputs(metrics, tmp_path / "run")
    assert logged["registered"] == "models:/kvlcc2_mmg/1"
    assert mlflow.MlflowClient().get_logged_model(logged["model_id"]).metrics[0].key == "turning_35/fitness"
    model = mlflow.pyfunc.load_model(logged["uri"])         # start_run pointed mlflow at the store
    states = model.predict(pd.DataFrame({"manoeuvre": ["turning_35"], "duration": [300.0]}))
    assert "n" in states
    found = _characteristics(states, "turning_35")
    assert found and all(value == metrics[key] for key, value in found.items())
