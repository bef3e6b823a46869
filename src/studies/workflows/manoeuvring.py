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

Measured records (a vessel without reference coefficients such as the
KVLCC2, MARIN ``.dat`` files, ``data.derivative=ekf|ekf_kinematic`` or
``data.resample=``) go through :mod:`studies.workflows.measured`: MARIN
files on their rebuilt uniform time axis, states and accelerations from the
EKF/RTS smoother (``auto`` picks it for noisy records), a regression
weighted by ``(U/U0)^4`` (``identify.weights``), the training records
replayed (``training/<record>/...``) and, with ``validate.path``, the same
validation repeated with least squares on Savitzky-Golay and on EKF/RTS
estimates (``derivatives/<estimator>/...``). The settings involved
(``data.resample``, ``identify.weights``, ``kalman.*``,
``validate.band_draws``, ``validate.compare_derivatives``) are declared,
with units, in :mod:`studies.config`.
"""

from __future__ import annotations

import logging

import dataclasses
import json
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from ..config import RunConfig, settled_discrepancy
from ..analysis.characteristics import characteristics, manoeuvre_kind
from ..analysis.bands import (TRUSTED_COVERAGE, outside_fraction, plot_calibration, point_replay,
                              training_envelope, trust_verdict)
from ..analysis.metrics import error_metrics
from ..data import load_manoeuvres
from ..data.derivatives import STATE_COLUMNS, noise_ratio
from ..errors import ConfigError
from ..stages import say
from ..environment.conditions import Environment
from ..environment.noise import add_measurement_noise, disturbance_forces, record_wind
from ..identification import build_problems, make_identifier
from ..identification.discrepancy import Discrepancy
from ..identification.ls import LeastSquares
from ..identification.objective import trajectory_objective
from ..identification.regression import prime_states
from ..models.abkowitz import ManoeuvringModel
from ..models.abkowitz import abkowitz
from ..models.registry import get_model
from ..models.terms import DOFS, candidate_terms
from .sparse_terms import ls_problems, sindy_beside_ls
from ..analysis.figures import plot_deviations, plot_overlay
from ..plotting import draw
from ..simulate import replay, simulate
from ..simulate.manoeuvres import zigzag_of_record
from ..vessels import get_vessel, has_mmg_particulars
from ..vessels.base import Vessel
from . import measured as _measured
from .identified_model import IDENTIFIED_MODEL_FILE, IdentifiedModel
from .settings import Settings, named_manoeuvre, read_settings
from .methods import check_method
from .protocol import Recorder
from .vessel_choice import settle_vessel
from ..config import DERIVATIVES

logger = logging.getLogger(__name__)

__all__ = ["ManoeuvringRun", "prepare", "execute", "simulate_training", "coefficient_table", "run_name",
           "identified_model", "compare_simulated", "validation_manoeuvre"]

MIN_SAMPLES_PER_COEFFICIENT = 3


@dataclass
class ManoeuvringRun:
    """A checked configuration with its training records."""

    cfg: RunConfig
    settings: Settings
    vessel: Vessel
    model: ManoeuvringModel
    method: str
    records: list
    truth: dict | None
    validation_records: list = field(default_factory=list)
    measured: bool = False

    @property
    def name(self) -> str:
        """The tracked run's name (:func:`run_name`)."""
        return run_name(self.cfg, self.settings)

    @property
    def tags(self) -> dict:
        """The tracked run's tags (:func:`run_tags`)."""
        return run_tags(self.cfg, self.settings)

    @property
    def inputs(self) -> list:
        """``(path, record, context)`` of every record file the run reads."""
        training = list(zip(self.settings.data_paths, self.records)) if self.settings.data_paths else []
        return ([(p, r, "training") for p, r in training]
                + [(p, r, "validation") for p, r in zip(self.settings.validate_paths,
                                                        self.validation_records)])

    def execute(self, out_dir: Path) -> dict:
        """Identify, validate, write the files (:func:`execute`); the metrics."""
        return execute(self, out_dir)

    def replay(self, params: dict, record: pd.DataFrame) -> pd.DataFrame:
        """The record's own rudder replayed by the model from its first state."""
        return replay(self.model, params, self.vessel, record)

    def simulate_manoeuvre(self, params: dict, manoeuvre, initial: dict | None = None) -> pd.DataFrame:
        """A manoeuvre simulated by the model (calm water) from ``initial``."""
        return simulate(self.model, params, self.vessel, manoeuvre, initial=initial)


def identified_model(study: ManoeuvringRun, params: dict, modules=None,
                     environment: Environment | None = None) -> IdentifiedModel:
    """What the run identified, with what its simulations need (the run's
    ``identified_model.json`` and MLflow model): the model, ``params``, the
    vessel, the validation environment (``environment`` replaces it), the
    MMG ``modules`` and the validation manoeuvres."""
    simulated = not study.validation_records and bool(study.vessel.coefficients)
    return IdentifiedModel(
        study.model, dict(params), study.vessel,
        study.settings.validation_environment if environment is None else environment, modules,
        tuple(study.settings.validate_manoeuvres) if simulated else (),
        study.cfg.validate.duration or None,
        {"method": study.method, "vessel": str(study.cfg.vessel.name), "model": study.model.name,
         "data": "measured" if study.settings.data_paths else "simulated",
         "training": [str(r.attrs.get("name", "record")) for r in study.records]})


def simulate_training(vessel: Vessel, model: ManoeuvringModel, truth: dict, manoeuvre,
                      settings: Settings, rng: np.random.Generator) -> pd.DataFrame:
    """Simulate a training record as a sensor would record it.

    The true wind acts; the record carries the wind speed with the
    anemometer error (thesis eq. 4.1). ``settings.data_scheme`` integrates
    it (``rk4``, or ``euler`` steps as MSS ``zigzag.m``). With a disturbance level, a clean run
    first gives the force scale of the bias and process noise (SVM paper eq.
    14, the bias sized by ``disturbance.scaling`` over this record's length).
    Measurement noise (Li et al. eq. 22) is added last.
    """
    env = settings.environment
    scheme = settings.data_scheme
    external = None
    if settings.bias_level > 0 or settings.process_level > 0:
        clean = simulate(model, truth, vessel, manoeuvre, env, scheme=scheme)
        primes = prime_states(clean["u"], clean["v"], clean["r"], clean["delta"], vessel)
        scale = np.max(np.abs(model.forces(primes, truth)), axis=0)
        n_steps = len(manoeuvre.step_times()) - 1
        external = disturbance_forces(n_steps, manoeuvre.step, scale, settings.bias_level,
                                      settings.process_level, rng, settings.bias_scaling)
    record = simulate(model, truth, vessel, manoeuvre, env, external, scheme=scheme)
    if "diverged_at" in record.attrs:
        raise RuntimeError(f"the reference simulation of {manoeuvre.name} diverged at "
                           f"t = {record.attrs['diverged_at']:.1f} s")
    record = record_wind(record, settings.wind_speed_error)
    record = add_measurement_noise(record, settings.measurement_noise, vessel.speed, rng)
    record.attrs["name"] = manoeuvre.name
    return record


def with_wind_convention(vessel: Vessel, convention: str) -> Vessel:
    """``vessel`` whose wind loads follow ``convention`` (``wind.convention``:
    ``downwind`` or ``zhu2021``, :class:`~studies.vessels.base.WindParticulars`);
    the simulation of the training and validation manoeuvres and the
    identification use it alike."""
    if vessel.wind is None or vessel.wind.convention == convention:
        return vessel
    return dataclasses.replace(vessel, wind=dataclasses.replace(vessel.wind, convention=convention))


def reference_model(vessel: Vessel) -> tuple[ManoeuvringModel, dict]:
    """The model that plays the real ship in simulated studies: the full
    Abkowitz model with the vessel's published coefficients."""
    full = abkowitz()
    return full, {name: vessel.coefficients[name] for name in full.names}


def get_study_model(cfg: RunConfig, root: Path | None = None,
                    record: Recorder | None = None) -> ManoeuvringModel:
    """The model to identify; ``simplified`` is derived first when its file
    is missing (the derivation recorded by ``record``)."""
    name = str(cfg.model.name)
    if name == "simplified":
        root = Path(root or Path.cwd())
        from .simplify import ensure_definition  # SALib and pygad: only for the simplified model
        return get_model(name, ensure_definition(cfg, root, record))
    return get_model(name)


def prepare(cfg: RunConfig, root: Path | None = None, record: Recorder | None = None) -> ManoeuvringRun:
    """Check the configuration and get the training records.

    Raises ``ConfigError``/``DataError`` on bad input before anything is
    written (deriving a missing simplified-model definition is recorded as
    its own run by ``record``).
    """
    settings = read_settings(cfg)
    vessel = with_wind_convention(get_vessel(settle_vessel(cfg, root)), cfg.wind.convention)
    model = get_study_model(cfg, root, record)
    method = str(cfg.method.name)
    check_method("manoeuvring", method)
    n_params = max(len(model.terms_of(d)) for d in ("X", "Y", "N"))
    resample_dt = cfg.data.resample
    derivative = cfg.data.derivative
    _measured.kalman_options(cfg)           # refuse bad kalman.* settings before any run
    validation = None
    if settings.data_paths:
        min_samples = MIN_SAMPLES_PER_COEFFICIENT * n_params + 5
        if _is_measured_study(vessel, settings.data_paths, derivative, resample_dt):
            records, validation = _measured.load_study_records(settings.data_paths, settings.validate_paths,
                                                               min_samples, resample_dt, cfg.data.scale)
        else:
            records = load_manoeuvres(settings.data_paths, min_samples=min_samples)
        truth = None
    else:
        manoeuvres = training_manoeuvres(cfg)
        if not vessel.coefficients:
            raise ConfigError(f"vessel '{vessel.name}' has no reference coefficients to simulate "
                              "from; give measured records with data.path=")
        full, full_truth = reference_model(vessel)
        truth = {name: full_truth[name] for name in model.names}
        rng = np.random.default_rng(settings.seed)
        records = [simulate_training(vessel, full, full_truth, man, settings, rng) for man in manoeuvres]
    if validation is None:
        validation = _measured.load_measured(settings.validate_paths) if settings.validate_paths else []
    measured = bool(settings.data_paths) and _is_measured_study(vessel, settings.data_paths, derivative,
                                                                resample_dt)
    said = settled_discrepancy(cfg.method, bool(settings.data_paths))
    if said:
        logger.info(said)
    if method == "bayes" and settings.data_paths and has_mmg_particulars(vessel.name):
        logger.info("the bands of model=%s on %s records are not judged by the calibration page; it judges "
                    "model=mmg's (experiment=kvlcc2_calibration, each record held out in turn; "
                    "docs/calibration.md)", cfg.model.name, vessel.name)
    return ManoeuvringRun(cfg, settings, vessel, model, method, records, truth, validation, measured)




def _is_measured_study(vessel: Vessel, paths, derivative: str, resample_dt) -> bool:
    """Whether training records go through :mod:`studies.workflows.measured`.

    Measured data of a vessel without reference coefficients (KVLCC2), MARIN
    ``.dat`` files, the Kalman estimators or a resampling request; a CSV of
    the Mariner keeps the original path (same loader, unweighted
    regression).
    """
    return (not vessel.coefficients or any(str(p).lower().endswith(".dat") for p in paths)
            or derivative in _measured.EKF_METHODS or resample_dt is not None)


def _method_options(cfg: RunConfig) -> dict:
    """The identifier's constructor arguments: the ``method`` settings but its name."""
    return {k: v for k, v in asdict(cfg.method).items() if k != "name"}


def _manoeuvre_overrides(cfg: RunConfig) -> dict:
    """The ``manoeuvre`` settings given (not None) but its name."""
    return {k: v for k, v in asdict(cfg.manoeuvre).items() if k != "name" and v is not None}


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


def run_name(cfg: RunConfig, settings: Settings) -> str:
    """Readable MLflow run name, e.g. ``ls zigzag_20_20 wind=12 dir=45 err=-5%``."""
    if cfg.run_name:
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
        parts.append(f"NL={cfg.disturbance.level}"
                     + ("" if settings.bias_scaling == "record" else f" ({settings.bias_scaling})"))
    if str(cfg.model.name) != "abkowitz":
        parts.append(f"model={cfg.model.name}")
    parts.append(f"seed={settings.seed}")
    return " ".join(parts)


def run_tags(cfg: RunConfig, settings: Settings) -> dict:
    """Tags that make the MLflow UI's filters useful."""
    return {
        "method": cfg.method.name, "vessel": cfg.vessel.name, "model": cfg.model.name,
        "manoeuvre": "measured" if settings.data_paths else cfg.manoeuvre.name,
        "data": "measured" if settings.data_paths else "simulated",
        "wind_speed": f"{settings.environment.wind_speed:g}",
        "wind_direction_deg": f"{np.rad2deg(settings.environment.wind_direction):g}",
        "wind_speed_error_pct": f"{100 * settings.wind_speed_error:g}",
        "preset": cfg.preset or "none",
    }


def _validate_simulated(study: ManoeuvringRun, params: dict, out_dir: Path) -> dict:
    """Simulate the validation manoeuvres with the identified and the reference model."""
    metrics = {}
    if not study.vessel.coefficients:
        return metrics
    full, ref_values = reference_model(study.vessel)
    env = study.settings.validation_environment
    for name in study.settings.validate_manoeuvres:
        man = validation_manoeuvre(name, study.cfg.validate.duration)
        ref = simulate(full, ref_values, study.vessel, man, env)
        pred = simulate(study.model, params, study.vessel, man, env)
        metrics.update(compare_simulated(name, man, pred, ref, out_dir,
                                         f"{name}: identified ({study.method}) vs reference model"))
    return metrics


def validation_manoeuvre(name: str, duration: float | None = None):
    """The named validation manoeuvre, ``duration`` [s] (``validate.duration``) replacing its own."""
    return named_manoeuvre(name, {"duration": float(duration)} if duration else None)


def compare_simulated(name: str, manoeuvre, pred: pd.DataFrame, ref: pd.DataFrame | None,
                      out_dir: Path, title: str, table: bool = True) -> dict:
    """One simulated validation manoeuvre: metrics and files of a run.

    ``pred`` is the identified model's simulation of ``manoeuvre`` and
    ``ref`` the reference model's (None when there is none). Returns the
    flat metrics ``<name>/...``: errors against the reference (fitness,
    ``rmse_u|v|r``, ``mae_*``, ``diverged``) and the characteristics
    (``advance_m``, ``tactical_diameter_m``, ``overshoot1_deg``, ...) with
    the reference's (``..._reference``) and the errors (``..._error_pct``,
    ``..._error_deg``); without a reference, ``diverged`` and the
    characteristics alone. Writes ``validation_<name>.png`` (trajectory and
    time series) and, with ``table``, ``validation_<name>.csv`` (the
    overlay's time series, reference beside prediction).
    """
    heading = np.deg2rad(manoeuvre.heading) if manoeuvre.kind == "zigzag" else None
    kind = manoeuvre.kind if manoeuvre.kind in ("zigzag", "turning") else None
    if ref is None:
        diverged = "diverged_at" in pred.attrs or not np.all(np.isfinite(pred[["u", "v", "r"]].to_numpy()))
        metrics = {f"{name}/diverged": float(diverged)}
        metrics.update(_characteristic_errors(pred, None, name, kind, heading))
        draw(plot_overlay, {"identified": pred}, out_dir / f"validation_{name}.png", title)
        return metrics
    metrics = error_metrics(pred, ref, name)
    metrics.update(_characteristic_errors(pred, ref, name, kind, heading))
    draw(plot_overlay, {"reference": ref, "identified": pred}, out_dir / f"validation_{name}.png", title)
    if table:
        write_overlay_table(ref, pred, out_dir / f"validation_{name}.csv")
    return metrics


def _characteristic_errors(pred, ref, name: str, kind, heading, measured: bool = False) -> dict:
    """Characteristics of ``pred``, those of ``ref`` (``..._reference``; also
    ``..._measured`` when ``ref`` is a measurement) and the errors (``ref``
    None: those of ``pred`` alone)."""
    out = {}
    if "diverged_at" in pred.attrs:
        return out
    c_pred = characteristics(pred, kind, heading)
    c_ref = characteristics(ref, kind, heading) if ref is not None else {}
    for key, value in c_pred.items():
        if key in ("execute_heading_deg", "turn_direction"):
            continue
        out[f"{name}/{key}"] = value
        if key in c_ref:
            out[f"{name}/{key}_reference"] = c_ref[key]
            if measured:
                out[f"{name}/{key}_measured"] = c_ref[key]
            if key.endswith("_m"):
                out[f"{name}/{key[:-2]}_error_pct"] = 100.0 * (value - c_ref[key]) / c_ref[key]
            elif key.endswith("_deg"):
                out[f"{name}/{key[:-4]}_error_deg"] = value - c_ref[key]
    return out


def _validate_records(study: ManoeuvringRun, params: dict, out_dir: Path, result=None) -> dict:
    """Replay each validation record's measured rudder from its initial state.

    Characteristics (``<record>/advance_m`` ...) of the prediction, the
    measured values (``..._measured``; also ``..._reference`` as for
    simulated validation) and the errors (``<record>/advance_error_pct``,
    ``<record>/overshoot1_error_deg``, ...). A zig-zag's overshoots of both
    are taken from the measured execute heading (the heading when the
    measured rudder reverses), because the replayed rudder reverses at the
    measured instants; the closed-loop zig-zag of the model (rudder
    reversed when the *model's* heading reaches the nominal execute angle,
    from the measured initial state) is reported as
    ``<record>/closed_loop/overshoot1_deg`` and its error against the
    measurement with the nominal execute heading. With posterior samples
    (``method=bayes``) the 5-95 % predictive band of the trajectory is
    drawn and its coverage of the measurement logged
    (``<record>/band/coverage_xy`` ...). Also writes ``characteristics.csv``
    (one row per record and quantity) and ``validation.md``.
    """
    metrics = {}
    rows = []
    n_draws = study.cfg.validate.band_draws
    vectors = None
    if result is not None and result.samples and n_draws > 0:
        vectors = _measured.posterior_vectors(study.model, result, n_draws, study.settings.seed)
    discrepancy = Discrepancy.from_sample(result.samples.get("discrepancy")) if vectors is not None else None
    envelope = training_envelope(study.records, study.vessel) if vectors is not None else None
    verdicts = []
    for rec in study.validation_records:
        name = rec.attrs.get("name", "record")
        pred = study.replay(params, rec)
        metrics.update(error_metrics(pred, rec, name))
        kind = manoeuvre_kind(rec)
        heading = None
        if kind == "zigzag":
            measured = characteristics(rec, kind)
            if "execute_heading_deg" in measured:
                heading = np.deg2rad(measured["execute_heading_deg"])
        chars = _characteristic_errors(pred, rec, name, kind, heading, measured=True)
        metrics.update(chars)
        rows += _characteristic_rows(name, "replay", chars)
        if kind == "turning":
            steady = _measured.steady_turn_errors(pred, rec, name)
            metrics.update(steady)
            rows += _characteristic_rows(name, "replay", steady)
        if kind == "zigzag":
            closed = _closed_loop_zigzag(study, params, rec)
            metrics.update(closed)
            rows += _characteristic_rows(name, "closed_loop", closed, prefix="closed_loop/")
        draw(plot_overlay, {"measured": rec, "predicted": pred}, out_dir / f"validation_{name}.png",
                     f"{name}: prediction ({study.method}) vs measurement")
        write_overlay_table(rec, pred, out_dir / f"validation_{name}.csv")
        if vectors is not None:
            t_band = time.perf_counter()
            steer = study.cfg.validate.band_replay == "steered"
            band = _measured.posterior_band(study.model, vectors, study.vessel, rec,
                                            discrepancy=discrepancy, seed=study.settings.seed,
                                            modules=getattr(study, "modules", None), steer=steer)
            centre, steered = None, False
            if steer:
                centre, steered = point_replay(study.model, study.model.vector(params, default=0.0),
                                               study.vessel, rec, getattr(study, "modules", None), steer)
            metrics[f"{name}/band/steered"] = float(steered)
            for key in BAND_KEYS:
                metrics[f"{name}/band/{key}"] = band[key]
            metrics[f"{name}/band/draws"] = float(len(vectors))
            metrics[f"{name}/band/discrepancy"] = float(discrepancy is not None)
            outside, ranges = outside_fraction(rec, envelope, study.vessel)
            metrics[f"{name}/band/outside_training"] = outside
            trusted, sentence = trust_verdict(name, band, outside, ranges, envelope)
            metrics[f"{name}/band/trusted"] = float(trusted)
            verdicts.append(sentence)
            what = "coefficients and model discrepancy" if discrepancy is not None else "coefficients"
            if steered:
                what += "; the zig-zag run by its rule"
            _measured.plot_band(rec, centre if steered else pred, band, out_dir / f"band_{name}.png",
                                f"{name}: 5-95 % posterior predictive band ({len(vectors)} draws: {what})")
            plot_calibration(band, out_dir / f"calibration_{name}.png",
                             f"{name}\ncoverage of the measured track ({what})")
            metrics[f"{name}/band/runtime_s"] = time.perf_counter() - t_band
            pd.DataFrame({"t": band["t"], **{f"{ch}_{q}": band[ch][i] for ch in ("x0", "y0", "psi")
                                            for i, q in enumerate(("q05", "q50", "q95"))}}
                         ).iloc[::max(1, len(band["t"]) // MAX_OVERLAY_ROWS)].to_csv(
                out_dir / f"band_{name}.csv", index=False)
    if verdicts:
        trusted = [metrics[f"{r.attrs.get('name', 'record')}/band/trusted"] for r in study.validation_records]
        metrics["validation/bands_trusted"] = float(np.mean(trusted))
        (out_dir / "bands.md").write_text(_bands_markdown(verdicts, discrepancy))
    if rows:
        table = pd.DataFrame(rows, columns=["record", "simulation", "quantity", "predicted",
                                            "measured", "error", "error_unit"])
        table.to_csv(out_dir / "characteristics.csv", index=False)
        (out_dir / "validation.md").write_text(_markdown_table(table, study))
    return metrics


#: ``<record>/band/<key>`` metrics of a predictive band (:func:`studies.analysis.bands.band_statistics`)
BAND_KEYS = ("coverage_x0", "coverage_y0", "coverage_psi", "coverage_xy", "coverage_all", "diverged",
             "covered_until_s", "coverage_xy_50", "coverage_xy_80", "coverage_xy_90", "coverage_xy_95",
             "coverage_joint", "coverage_joint_50", "coverage_joint_80", "coverage_joint_90",
             "coverage_joint_95",
             "width_x0_m", "width_y0_m", "width_xy_m", "width_psi_deg", "extent_m", "width_over_extent",
             "interval_score_x0_m", "interval_score_y0_m", "interval_score_xy_m", "crps_x0_m", "crps_y0_m",
             "crps_xy_m")


def _bands_markdown(verdicts: list, discrepancy) -> str:
    """``bands.md``: whether the predictive bands can be trusted, record by record."""
    if discrepancy is None:
        source = ("The bands come from the coefficient posterior alone (`method.discrepancy=none`): "
                  "the model is taken as exact, so they hold only the coefficients' uncertainty.")
    else:
        source = (f"The bands come from the coefficient posterior and a model discrepancy "
                  f"(`method.discrepancy={discrepancy.kind}`): AR(1) accelerations the model misses, "
                  f"standard deviations {discrepancy.sigma[0]:.2g} m/s^2 (surge), "
                  f"{discrepancy.sigma[1]:.2g} m/s^2 (sway), {discrepancy.sigma[2]:.2g} rad/s^2 (yaw), "
                  f"correlation times {discrepancy.taus[0]:.1f}, {discrepancy.taus[1]:.1f} and "
                  f"{discrepancy.taus[2]:.1f} s, their size times 1 + {discrepancy.rate_gain:.2f} |r'| "
                  f"(r' = r L / U), estimated on the training records only; each replay also starts "
                  f"from an initial u, v, r drawn from the sensors' noise and the sensor biases at "
                  f"the start of the training records.")
    lo, hi = TRUSTED_COVERAGE
    lines = ["# Predictive bands on the validation records", "", source, "",
             f"A band is trusted on a record when its joint 90 % band holds the measured track (x0 and "
             f"y0) between {100 * lo:.0f} and {100 * hi:.0f} % of the time, is narrower than the manoeuvre "
             "and fewer than 10 % of the replays diverge (figures `calibration_<record>.png`: "
             "coverage against the nominal 50/80/90/95 %). The joint band is the rectangle of x0 and y0 "
             "that holds the level's share of the replays jointly (the measurement ranked as one more "
             "replay); the 5-95 % bands of x0 and y0 hold both channels of a calibrated ensemble less "
             "often than 90 % (81 % when their errors are independent).", ""]
    lines += [f"- {v}" for v in verdicts]
    return "\n".join(lines) + "\n"


def _characteristic_rows(name: str, simulation: str, chars: dict, prefix: str = "") -> list:
    rows = []
    for key, value in chars.items():
        if not key.startswith(f"{name}/{prefix}"):
            continue
        quantity = key[len(name) + 1 + len(prefix):]
        if "/" in quantity or quantity.endswith(("_reference", "_measured")) or "_error_" in quantity:
            continue
        if quantity in _measured.STEADY_ERROR_KEYS:
            err_key, unit = f"{name}/{prefix}{_measured.STEADY_ERROR_KEYS[quantity]}", "%"
        elif quantity.endswith("_m"):
            err_key, unit = f"{name}/{prefix}{quantity[:-2]}_error_pct", "%"
        elif quantity.endswith("_deg"):
            err_key, unit = f"{name}/{prefix}{quantity[:-4]}_error_deg", "deg"
        else:
            continue
        rows.append({"record": name, "simulation": simulation, "quantity": quantity,
                     "predicted": value, "measured": chars.get(f"{name}/{prefix}{quantity}_measured",
                                                               np.nan),
                     "error": chars.get(err_key, np.nan), "error_unit": unit})
    return rows


def _markdown_table(table: pd.DataFrame, study: ManoeuvringRun) -> str:
    lines = [f"# Validation of {study.method} on measured records", "",
             "Training records: " + ", ".join(str(r.attrs.get("name")) for r in study.records), "",
             "| record | simulation | quantity | predicted | measured | error |",
             "|---|---|---|---:|---:|---:|"]
    for row in table.itertuples():
        lines.append(f"| {row.record} | {row.simulation} | {row.quantity} | {row.predicted:.1f} | "
                     f"{row.measured:.1f} | {row.error:+.1f} {row.error_unit} |")
    lines += ["", "replay: the measured rudder prescribed from the measured initial state; "
              "closed_loop: the model's own zig-zag, the record's (rudder reversed when the model's "
              "heading reaches the record's execute heading), overshoots against the measured ones "
              "at that heading.", ""]
    return "\n".join(lines)


def _closed_loop_zigzag(study: ManoeuvringRun, params: dict, rec: pd.DataFrame) -> dict:
    """Overshoots of the model's own zig-zag started from the record's initial state.

    The zig-zag the record shows (:func:`~studies.simulate.manoeuvres.zigzag_of_record`:
    rudder amplitude, execute heading, first side and execute time read from the record,
    so a 35/5 is run as a 35/5); the rudder reversed when the model's heading has changed
    by the execute heading from the initial one. Both overshoots, predicted and measured,
    are measured from that heading.
    """
    name = rec.attrs.get("name", "record")
    measured = characteristics(rec, "zigzag")
    if "execute_heading_deg" not in measured:
        return {}
    man = zigzag_of_record(rec)
    if man is None:
        return {}
    heading = man.heading
    row = rec.iloc[0]
    initial = {k: float(row[k]) for k in ("u", "v", "r", "x0", "y0", "psi")}
    sim = study.simulate_manoeuvre(params, man, initial)
    out = {}
    if "diverged_at" in sim.attrs:
        return {f"{name}/closed_loop/diverged": 1.0}
    c_pred = characteristics(sim, "zigzag", np.deg2rad(heading))
    c_meas = characteristics(rec, "zigzag", np.deg2rad(heading))
    for key, value in c_pred.items():
        if key == "execute_heading_deg":
            continue
        out[f"{name}/closed_loop/{key}"] = value
        if key in c_meas:
            out[f"{name}/closed_loop/{key}_measured"] = c_meas[key]
            out[f"{name}/closed_loop/{key[:-4]}_error_deg"] = value - c_meas[key]
    return out


def measured_derivative(records, derivative: str) -> str:
    """``data.derivative`` for measured records: ``auto`` is the Kalman
    smoother (``ekf``) when the records show sensor noise, central
    differences otherwise."""
    if derivative != "auto":
        return derivative
    noisy = any(max(noise_ratio(r[c].to_numpy(float)) for c in STATE_COLUMNS) > 1e-3 for r in records)
    return "ekf" if noisy else "central"


def _replay_training(study: ManoeuvringRun, params: dict, out_dir: Path) -> dict:
    """How the identified model replays its own training records (``training/<record>/...``)."""
    metrics = {}
    for rec in study.records:
        name = rec.attrs.get("name", "record")
        pred = study.replay(params, rec)
        metrics.update(error_metrics(pred, rec, f"training/{name}"))
        kind = manoeuvre_kind(rec)
        heading = None
        if kind == "zigzag":
            heading = characteristics(rec, kind).get("execute_heading_deg")
            heading = None if heading is None else np.deg2rad(heading)
        metrics.update(_characteristic_errors(pred, rec, f"training/{name}", kind, heading, measured=True))
        draw(plot_overlay, {"measured": rec, "replayed": pred}, out_dir / f"training_{name}.png",
                     f"{name} (training): replay ({study.method}) vs measurement")
    return metrics


#: estimators compared on measured data (``derivatives/<estimator>/...``)
COMPARED_DERIVATIVES = ("savgol", "ekf")
#: characteristics compared per estimator
_COMPARED_KEYS = ("advance_error_pct", "transfer_error_pct", "tactical_diameter_error_pct",
                  "overshoot1_error_deg", "overshoot2_error_deg", "rmse_position", "fitness")


def _compare_derivatives(study: ManoeuvringRun, derivative: str, estimates, params: dict, out_dir: Path) -> dict:
    """Least squares with each estimator of :data:`COMPARED_DERIVATIVES`, validated alike.

    The run's own estimates are reused when the estimator is the run's
    (and its method is ``ls``, its coefficients too). Metrics
    ``derivatives/<estimator>/<record>/<quantity>`` and
    ``derivatives/<estimator>/regression/<dof>/r2``; table
    ``derivatives.csv``.
    """
    cfg = study.cfg
    kalman, iterations = _measured.kalman_options(cfg)
    weights = cfg.identify.weights
    metrics, rows = {}, []
    for est in COMPARED_DERIVATIVES:
        t0 = time.perf_counter()
        if est == derivative and estimates is not None:
            problems = _measured.problems_from_estimates(study.model, study.vessel, study.records,
                                                         estimates, weights=weights)
            fit = LeastSquares().fit(problems)
        else:
            fit, _ = _measured.identify_measured(study.model, study.vessel, study.records, est,
                                                 LeastSquares(), None, kalman, iterations, weights)
        values = params if (est == derivative and study.method == "ls") else fit.params
        prefix = f"derivatives/{est}"
        for dof in ("X", "Y", "N"):
            key = f"regression/{dof}/r2"
            if key in fit.metrics:
                metrics[f"{prefix}/{key}"] = fit.metrics[key]
        for rec in study.validation_records:
            name = rec.attrs.get("name", "record")
            pred = replay(study.model, values, study.vessel, rec)
            kind = manoeuvre_kind(rec)
            heading = None
            if kind == "zigzag":
                heading = characteristics(rec, kind).get("execute_heading_deg")
                heading = None if heading is None else np.deg2rad(heading)
            found = {**error_metrics(pred, rec, name),
                     **_characteristic_errors(pred, rec, name, kind, heading)}
            row = {"estimator": est, "record": name}
            for key in _COMPARED_KEYS:
                if f"{name}/{key}" in found:
                    metrics[f"{prefix}/{name}/{key}"] = found[f"{name}/{key}"]
                    row[key] = found[f"{name}/{key}"]
            rows.append(row)
        metrics[f"{prefix}/runtime_s"] = time.perf_counter() - t0
    if rows:
        pd.DataFrame(rows).to_csv(out_dir / "derivatives.csv", index=False)
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


def training_manoeuvres(cfg: RunConfig) -> list:
    """The simulated training manoeuvres: ``train.manoeuvres`` (a list of names,
    e.g. several zig-zags as in Wang et al. 2021) or the ``manoeuvre`` group."""
    names = cfg.train.manoeuvres or []
    if names:
        return [named_manoeuvre(str(n)) for n in names]
    return [named_manoeuvre(str(cfg.manoeuvre.name), _manoeuvre_overrides(cfg))]


def _training_names(study: ManoeuvringRun) -> set:
    if study.settings.data_paths:
        return {str(r.attrs.get("name")) for r in study.records}
    return {str(r.attrs.get("name")) for r in study.records}


def speed_mae_summary(metrics: dict, training: set) -> dict:
    """Mean absolute speed error over validation manoeuvres (Li et al. Fig. 10).

    Over the manoeuvres that were not the training one (all of them when
    each was): ``validation/validated`` counts them,
    ``validation/diverged`` counts the predictions that diverged, and
    ``validation/mae_speed`` averages ``(mae_u + mae_v) / 2`` [m/s] over the
    ones that stayed bounded (absent when none did): a diverged prediction
    is counted, never averaged.
    """
    names = sorted({k.split("/")[0] for k in metrics if k.endswith("/mae_u")} - {"training"})
    others = [n for n in names if n not in training] or names
    if not others:
        return {}
    diverged = [n for n in others if metrics.get(f"{n}/diverged", 0.0)]
    bounded = [n for n in others if n not in diverged]
    out = {"validation/validated": float(len(others)), "validation/diverged": float(len(diverged))}
    if bounded:
        out["validation/mae_speed"] = float(np.mean([0.5 * (metrics[f"{n}/mae_u"] + metrics[f"{n}/mae_v"])
                                                     for n in bounded]))
    return out


#: the file of the identification's step metrics (the run logs them with their steps)
METRIC_HISTORY = "metric_history.json"


def write_metric_history(history: dict, path: Path) -> None:
    """Write ``{name: [(step, value), ...]}`` (:attr:`Identification.history`)
    as JSON ``{name: [[step, value], ...]}``; nothing when it is empty."""
    if history:
        path.write_text(json.dumps({k: [[int(step), float(value)] for step, value in v]
                                    for k, v in sorted(history.items())}, indent=1))


def _with_selected_terms(study: ManoeuvringRun, result) -> ManoeuvringRun:
    """The study with the model extended by the terms an identifier selected beyond it
    (SINDy's extended library), so that the identified model simulates what was fitted."""
    extra = [name for name in result.params if name not in study.model.names]
    if not extra:
        return study
    order = int(getattr(study.cfg.method, "max_order", 3))
    library = {t.name: t for dof in DOFS for t in candidate_terms(dof, order)}
    terms = [library[name] for name in extra if name in library]
    if not terms:
        return study
    return dataclasses.replace(study, model=study.model.extended(terms, name=f"{study.model.name}+sindy"))


def execute(study: ManoeuvringRun, out_dir: Path) -> dict:
    """Identify, validate and write the run's files into ``out_dir``.

    Returns the metrics (also written to ``metrics.json``).
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    cfg = study.cfg
    started = time.perf_counter()
    derivative = cfg.data.derivative
    identifier = make_identifier(study.method, _method_options(cfg))
    objective = trajectory_objective(study.model, study.vessel, study.records, cfg.objective.simulation)
    info = {}
    say(f"run: identifying {study.model.name} by {study.method} on {len(study.records)} record(s)")
    if study.measured:
        derivative = measured_derivative(study.records, derivative)
        kalman, iterations = _measured.kalman_options(cfg)
        weights = cfg.identify.weights
        t0 = time.perf_counter()
        result, info = _measured.identify_measured(study.model, study.vessel, study.records, derivative,
                                                   identifier, objective, kalman, iterations, weights)
    else:
        problems = build_problems(study.model, study.vessel, study.records, derivative)
        t0 = time.perf_counter()
        result = identifier.fit(problems, objective=objective)
    metrics = {"runtime/identify_s": time.perf_counter() - t0}
    estimates = info.pop("estimates", None)
    metrics.update(info)
    metrics.update(result.metrics)
    metrics["training/samples"] = float(sum(len(r) for r in study.records))
    base_model = study.model
    study = _with_selected_terms(study, result)
    params = {name: result.params[name] for name in study.model.names}
    table = coefficient_table(study.model, params, result.lower, result.upper, study.truth)
    table.to_csv(out_dir / "coefficients.csv", index=False)
    identified_model(study, params).write(out_dir / IDENTIFIED_MODEL_FILE)
    for filename, writer in result.writers.items():
        writer(out_dir / filename)
    write_metric_history(result.history, out_dir / METRIC_HISTORY)
    if study.truth:
        dev = table["deviation_pct"].abs()
        metrics["deviation/median_abs_pct"] = float(dev.median())
        metrics["deviation/max_abs_pct"] = float(dev.max())
        draw(plot_deviations, table, out_dir / "deviations.png",
                        f"{study.method}: deviation from the reference coefficients")
        # training fit: the identified model repeats the training manoeuvre(s)
        for k, (man, rec) in enumerate(zip(training_manoeuvres(cfg), study.records)):
            pred = simulate(study.model, params, study.vessel, man, study.settings.environment)
            metrics.update(error_metrics(pred, rec, "training" if k == 0 else f"training_{man.name}"))
    say("run: predicting the validation manoeuvres and records")
    if study.measured:
        metrics.update(_replay_training(study, params, out_dir))
    if study.validation_records:
        metrics.update(_validate_records(study, params, out_dir, result))
        compare = cfg.validate.compare_derivatives
        if study.measured and compare:
            metrics.update(_compare_derivatives(study, derivative, estimates, params, out_dir))
    else:
        metrics.update(_validate_simulated(study, params, out_dir))
    if study.method == "sindy":
        plain = dataclasses.replace(study, model=base_model)
        metrics.update(sindy_beside_ls(study, base_model, result,
                                       lambda: LeastSquares().fit(ls_problems(plain, estimates)).params,
                                       metrics, out_dir, _validate_records))
    metrics.update(speed_mae_summary({k: v for k, v in metrics.items() if not k.startswith("ls/")},
                                     _training_names(study)))
    metrics["runtime/total_s"] = time.perf_counter() - started
    metrics = {k: float(v) for k, v in metrics.items()}
    (out_dir / "metrics.json").write_text(json.dumps(metrics, indent=1, sort_keys=True))
    return metrics
