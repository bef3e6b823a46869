"""``studies run`` for manoeuvring models: data -> identification -> validation -> files.

The pipeline is split so that everything that can refuse user input (config
values, data files) runs before an MLflow run is opened:

1. :func:`prepare` checks the configuration and gets the training records
   (loaded from ``data.path`` or simulated from the vessel's reference
   coefficients with the configured wind, disturbance and noise);
2. :func:`execute` identifies, validates and writes ``coefficients.csv``,
   ``metrics.json`` and figures into the run directory.

Identification only sees the records (and the vessel's prior knowledge),
never how they were produced.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from omegaconf import OmegaConf

from ..analysis.characteristics import characteristics, manoeuvre_kind
from ..analysis.metrics import error_metrics
from ..data import load_manoeuvres
from ..errors import ConfigError
from ..environment.noise import add_measurement_noise, disturbance_forces, record_wind
from ..identify import build_problems, make_identifier
from ..identify.objective import TrajectoryObjective
from ..identify.regression import prime_states
from ..models.abkowitz import ManoeuvringModel
from ..models.abkowitz import abkowitz
from ..models.registry import get_model
from ..report.figures import plot_deviations, plot_overlay
from ..simulate import replay, simulate
from ..vessels import get_vessel
from ..vessels.base import Vessel
from .settings import Settings, named_manoeuvre, read_settings

__all__ = ["Study", "prepare", "execute", "simulate_training", "coefficient_table", "run_name"]

MIN_SAMPLES_PER_COEFFICIENT = 3


@dataclass
class Study:
    """A checked configuration with its training records."""

    cfg: object
    settings: Settings
    vessel: Vessel
    model: ManoeuvringModel
    method: str
    records: list
    truth: dict | None
    validation_records: list = field(default_factory=list)


def simulate_training(vessel: Vessel, model: ManoeuvringModel, truth: dict, manoeuvre,
                      settings: Settings, rng: np.random.Generator) -> pd.DataFrame:
    """Simulate a training record as a sensor would record it.

    The true wind acts; the record carries the wind speed with the
    anemometer error (thesis eq. 4.1). With a disturbance level, a clean run
    first gives the force scale of the bias and process noise (SVM paper eq.
    14). Measurement noise (Li et al. eq. 22) is added last.
    """
    env = settings.environment
    external = None
    if settings.bias_level > 0 or settings.process_level > 0:
        clean = simulate(model, truth, vessel, manoeuvre, env)
        primes = prime_states(clean["u"], clean["v"], clean["r"], clean["delta"], vessel)
        scale = np.max(np.abs(model.forces(primes, truth)), axis=0)
        n_steps = len(manoeuvre.step_times()) - 1
        external = disturbance_forces(n_steps, manoeuvre.step, scale, settings.bias_level,
                                      settings.process_level, rng)
    record = simulate(model, truth, vessel, manoeuvre, env, external)
    if "diverged_at" in record.attrs:
        raise RuntimeError(f"the reference simulation of {manoeuvre.name} diverged at "
                           f"t = {record.attrs['diverged_at']:.1f} s")
    record = record_wind(record, settings.wind_speed_error)
    record = add_measurement_noise(record, settings.measurement_noise, vessel.speed, rng)
    record.attrs["name"] = manoeuvre.name
    return record


def reference_model(vessel: Vessel) -> tuple[ManoeuvringModel, dict]:
    """The model that plays the real ship in simulated studies: the full
    Abkowitz model with the vessel's published coefficients."""
    full = abkowitz()
    return full, {name: vessel.coefficients[name] for name in full.names}


def get_study_model(cfg, root: Path | None = None) -> ManoeuvringModel:
    """The model to identify; ``simplified`` is derived first when its file is missing."""
    name = str(cfg.model.name)
    if name == "simplified":
        from .simplify import ensure_definition

        root = Path(root or Path.cwd())
        return get_model(name, ensure_definition(cfg, root))
    return get_model(name)


def prepare(cfg, root: Path | None = None) -> Study:
    """Check the configuration and get the training records.

    Raises ``ConfigError``/``DataError`` on bad input before anything is
    written (deriving a missing simplified-model definition is logged as its
    own MLflow run).
    """
    settings = read_settings(cfg)
    vessel = get_vessel(str(cfg.vessel.name))
    model = get_study_model(cfg, root)
    method = str(cfg.method.name)
    make_identifier(method, _method_options(cfg))
    n_params = max(len(model.terms_of(d)) for d in ("X", "Y", "N"))
    if settings.data_paths:
        records = load_manoeuvres(settings.data_paths,
                                  min_samples=MIN_SAMPLES_PER_COEFFICIENT * n_params + 5)
        truth = None
    else:
        manoeuvre = named_manoeuvre(str(cfg.manoeuvre.name), _manoeuvre_overrides(cfg))
        if not vessel.coefficients:
            raise ConfigError(f"vessel '{vessel.name}' has no reference coefficients to simulate "
                              "from; give measured records with data.path=")
        full, full_truth = reference_model(vessel)
        truth = {name: full_truth[name] for name in model.names}
        rng = np.random.default_rng(settings.seed)
        records = [simulate_training(vessel, full, full_truth, manoeuvre, settings, rng)]
    validation = load_manoeuvres(settings.validate_paths) if settings.validate_paths else []
    return Study(cfg, settings, vessel, model, method, records, truth, validation)


def _method_options(cfg) -> dict:
    options = OmegaConf.to_container(cfg.method, resolve=True) or {}
    options.pop("name", None)
    return options


def _manoeuvre_overrides(cfg) -> dict:
    node = OmegaConf.to_container(cfg.manoeuvre, resolve=True) or {}
    return {k: v for k, v in node.items() if k != "name"}


def coefficient_table(model: ManoeuvringModel, params: dict, lower: dict, upper: dict,
                      truth: dict | None) -> pd.DataFrame:
    """``coefficients.csv``: name, value, lower, upper, true, deviation_pct."""
    rows = []
    for name in model.names:
        value = params.get(name, np.nan)
        true = truth.get(name, np.nan) if truth else np.nan
        dev = 100.0 * (value - true) / true if truth and true != 0 else np.nan
        rows.append({"name": name, "value": value, "lower": lower.get(name, np.nan),
                     "upper": upper.get(name, np.nan), "true": true, "deviation_pct": dev})
    return pd.DataFrame(rows, columns=["name", "value", "lower", "upper", "true", "deviation_pct"])


def run_name(cfg, settings: Settings) -> str:
    """Readable MLflow run name, e.g. ``ls zigzag_20_20 wind=12 dir=45 err=-5%``."""
    if cfg.get("run_name"):
        return str(cfg.run_name)
    parts = [str(cfg.method.name)]
    parts.append(", ".join(Path(p).stem for p in settings.data_paths) if settings.data_paths
                 else str(cfg.manoeuvre.name))
    env = settings.environment
    if env.wind_speed > 0:
        parts.append(f"wind={env.wind_speed:g} dir={np.rad2deg(env.wind_direction):g}"
                     f" err={100 * settings.wind_speed_error:+g}%")
    if settings.measurement_noise:
        parts.append(f"noise={100 * settings.measurement_noise:g}%")
    if settings.bias_level:
        parts.append(f"NL={cfg.disturbance.level}")
    if str(cfg.model.name) != "abkowitz":
        parts.append(f"model={cfg.model.name}")
    parts.append(f"seed={settings.seed}")
    return " ".join(parts)


def run_tags(cfg, settings: Settings) -> dict:
    """Tags that make the MLflow UI's filters useful."""
    return {
        "method": cfg.method.name, "vessel": cfg.vessel.name, "model": cfg.model.name,
        "manoeuvre": "measured" if settings.data_paths else cfg.manoeuvre.name,
        "data": "measured" if settings.data_paths else "simulated",
        "wind_speed": f"{settings.environment.wind_speed:g}",
        "wind_direction_deg": f"{np.rad2deg(settings.environment.wind_direction):g}",
        "wind_speed_error_pct": f"{100 * settings.wind_speed_error:g}",
        "preset": cfg.get("preset") or "none",
    }


def _validate_simulated(study: Study, params: dict, out_dir: Path) -> dict:
    """Simulate the validation manoeuvres with the identified and the reference model."""
    metrics = {}
    if not study.vessel.coefficients:
        return metrics
    full, ref_values = reference_model(study.vessel)
    env = study.settings.validation_environment
    duration = study.cfg.validate.get("duration")
    for name in study.settings.validate_manoeuvres:
        man = named_manoeuvre(name, {"duration": float(duration)} if duration else None)
        ref = simulate(full, ref_values, study.vessel, man, env)
        pred = simulate(study.model, params, study.vessel, man, env)
        metrics.update(error_metrics(pred, ref, name))
        heading = np.deg2rad(man.heading) if man.kind == "zigzag" else None
        kind = man.kind if man.kind in ("zigzag", "turning") else None
        metrics.update(_characteristic_errors(pred, ref, name, kind, heading))
        plot_overlay({"reference": ref, "identified": pred}, out_dir / f"validation_{name}.png",
                     f"{name}: identified ({study.method}) vs reference model")
        write_overlay_table(ref, pred, out_dir / f"validation_{name}.csv")
    return metrics


def _characteristic_errors(pred, ref, name: str, kind, heading) -> dict:
    out = {}
    if "diverged_at" in pred.attrs:
        return out
    c_pred = characteristics(pred, kind, heading)
    c_ref = characteristics(ref, kind, heading)
    for key, value in c_pred.items():
        if key in ("execute_heading_deg", "turn_direction"):
            continue
        out[f"{name}/{key}"] = value
        if key in c_ref:
            out[f"{name}/{key}_reference"] = c_ref[key]
            if key.endswith("_m"):
                out[f"{name}/{key[:-2]}_error_pct"] = 100.0 * (value - c_ref[key]) / c_ref[key]
            elif key.endswith("_deg"):
                out[f"{name}/{key[:-4]}_error_deg"] = value - c_ref[key]
    return out


def _validate_records(study: Study, params: dict, out_dir: Path) -> dict:
    """Replay each validation record's measured rudder from its initial state."""
    metrics = {}
    for rec in study.validation_records:
        name = rec.attrs.get("name", "record")
        pred = replay(study.model, params, study.vessel, rec)
        metrics.update(error_metrics(pred, rec, name))
        metrics.update(_characteristic_errors(pred, rec, name, manoeuvre_kind(rec), None))
        plot_overlay({"measured": rec, "predicted": pred}, out_dir / f"validation_{name}.png",
                     f"{name}: prediction ({study.method}) vs measurement")
        write_overlay_table(rec, pred, out_dir / f"validation_{name}.csv")
    return metrics


OVERLAY_COLUMNS = ("x0", "y0", "psi", "u", "v", "r", "delta")
MAX_OVERLAY_ROWS = 1000


def write_overlay_table(reference: pd.DataFrame, prediction: pd.DataFrame, path: Path) -> None:
    """Reference and predicted time series side by side (at most 1000 rows),
    so that reports can redraw overlays from the store alone."""
    n = min(len(reference), len(prediction))
    step = max(1, int(np.ceil(n / MAX_OVERLAY_ROWS)))
    rows = slice(0, n, step)
    table = {"t": reference["t"].to_numpy(float)[rows]}
    for col in OVERLAY_COLUMNS:
        table[f"reference_{col}"] = reference[col].to_numpy(float)[rows]
        table[f"predicted_{col}"] = prediction[col].to_numpy(float)[rows]
    pd.DataFrame(table).to_csv(path, index=False)


def _training_names(study: Study) -> set:
    if study.settings.data_paths:
        return {str(r.attrs.get("name")) for r in study.records}
    return {str(study.cfg.manoeuvre.name)}


def speed_mae_summary(metrics: dict, training: set) -> dict:
    """Mean absolute speed error over validation manoeuvres (Li et al. Fig. 10).

    ``validation/mae_speed`` averages ``(mae_u + mae_v) / 2`` [m/s] over the
    manoeuvres that were not the training one (all of them when each was);
    a diverged prediction counts with the finite penalty.
    """
    names = sorted({k.split("/")[0] for k in metrics if k.endswith("/mae_u")} - {"training"})
    others = [n for n in names if n not in training] or names
    if not others:
        return {}
    values = [0.5 * (metrics[f"{n}/mae_u"] + metrics[f"{n}/mae_v"]) for n in others]
    return {"validation/mae_speed": float(np.mean(values)),
            "validation/diverged": float(sum(metrics.get(f"{n}/diverged", 0.0) for n in others))}


def execute(study: Study, out_dir: Path) -> dict:
    """Identify, validate and write the run's files into ``out_dir``.

    Returns the metrics (also written to ``metrics.json``).
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    cfg = study.cfg
    started = time.perf_counter()
    problems = build_problems(study.model, study.vessel, study.records,
                              str(cfg.data.get("derivative", "auto")))
    identifier = make_identifier(study.method, _method_options(cfg))
    t0 = time.perf_counter()
    objective = TrajectoryObjective(study.model, study.vessel, study.records)
    result = identifier.fit(problems, objective=objective)
    metrics = {"runtime/identify_s": time.perf_counter() - t0}
    metrics.update(result.metrics)
    metrics["training/samples"] = float(sum(len(r) for r in study.records))
    params = {name: result.params[name] for name in study.model.names}
    table = coefficient_table(study.model, params, result.lower, result.upper, study.truth)
    table.to_csv(out_dir / "coefficients.csv", index=False)
    for filename, writer in result.writers.items():
        writer(out_dir / filename)
    if study.truth:
        dev = table["deviation_pct"].abs()
        metrics["deviation/median_abs_pct"] = float(dev.median())
        metrics["deviation/max_abs_pct"] = float(dev.max())
        plot_deviations(table, out_dir / "deviations.png",
                        f"{study.method}: deviation from the reference coefficients")
        # training fit: the identified model replays the training manoeuvre
        rec = study.records[0]
        pred = simulate(study.model, params, study.vessel, named_manoeuvre(
            str(cfg.manoeuvre.name), _manoeuvre_overrides(cfg)), study.settings.environment)
        metrics.update(error_metrics(pred, rec, "training"))
    if study.validation_records:
        metrics.update(_validate_records(study, params, out_dir))
    else:
        metrics.update(_validate_simulated(study, params, out_dir))
    metrics.update(speed_mae_summary(metrics, _training_names(study)))
    metrics["runtime/total_s"] = time.perf_counter() - started
    metrics = {k: float(v) for k, v in metrics.items()}
    (out_dir / "metrics.json").write_text(json.dumps(metrics, indent=1, sort_keys=True))
    return metrics
