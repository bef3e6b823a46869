"""``studies run model=mmg``: the MMG model identified from records with a propeller rate.

Steps of :meth:`MMGRun.execute`:

1. states and accelerations of every training record (the kinematic Kalman
   smoother for measured records, ``data.derivative`` otherwise; the
   model-based smoother needs an Abkowitz process model and is replaced by
   the kinematic one);
2. the hull coefficients by the inverse-dynamics regression with the
   propeller and rudder forces known and a Gaussian prior on the vessel's
   published coefficients (:mod:`studies.identification.mmg_regression`), fitted by
   the configured method (LS, bayes, SINDy, SVM; the GA refines on the
   training trajectories with :class:`~studies.identification.mmg_output_error.MMGObjective`);
3. with ``model.output_error``, those interaction factors fitted by output
   error on the training trajectories, the hull re-identified for each trial
   (:func:`~studies.identification.mmg_output_error.refine_modules`);
4. validation as for the Abkowitz models (:mod:`studies.workflows.manoeuvring`):
   every ``validate.path`` record replayed with its measured rudder and
   propeller rate from its first state, characteristics, steady turn,
   closed-loop zig-zag overshoots and, with ``method=bayes``, the posterior
   predictive bands replayed by the MMG simulator (with
   ``method.discrepancy=process_noise`` the discrepancy is estimated by the
   Kalman filter with the MMG model as process model); simulated validation manoeuvres against
   the published MMG coefficients when there are no measured records;
5. ``model.compare_abkowitz``: the Abkowitz ``symmetric`` model identified
   by least squares from the same records, validated alike
   (``abkowitz/...`` metrics, files under ``abkowitz/``), and
   ``comparison.csv``/``comparison.md``: each characteristic measured, by
   the MMG and by the Abkowitz model;
6. ``model.captive``: the identified and the published model against the
   vessel's captive tests (``captive.csv``, ``captive_summary.csv``,
   ``captive.png``, ``captive/...`` metrics).

Scale: the particulars are those of the tested model, Froude scaled to the
records (``model.scale``); the scale is stated in ``mmg.md`` and the
``scale`` tag. Hull coefficients are MMG primes (forces over ``0.5 rho L d
U^2``), the same at every scale.
"""

from __future__ import annotations

import logging

import dataclasses
import json
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..analysis.captive import captive_comparison, plot_captive
from ..config import MethodConfig, MMGModelConfig, RunConfig, settled_discrepancy
from ..data.captive import read_captive
from ..environment.conditions import Environment
from ..environment.noise import add_measurement_noise
from ..errors import ConfigError, DataError
from ..identification import make_identifier
from .methods import check_method
from ..identification.ls import LeastSquares
from ..identification.mmg_output_error import MMGObjective, refine_modules
from ..identification.mmg_propeller import fit_wake
from ..identification.mmg_rudder import RUDDER_LIFT_FACTORS, fit_rudder_lift, rudder_lift_columns
from ..identification.mmg_regression import mmg_problems
from ..models.mmg import HULL_FAMILIES, family_modules, family_ties, mmg
from ..models.registry import get_model
from ..simulate.mmg import replay_mmg, simulate_mmg
from ..vessels import get_mmg_vessel, get_vessel, mmg_vessel_at_speed
from ..vessels.kvlcc2_mmg import MMGVessel
from . import manoeuvring as _manoeuvring
from . import measured as _measured
from ..data.scaling import scale_label
from ..papers import get_paper, published
from .band_calibration import write_band_calibration
from .cross_validation import cross_validate, cv_table_markdown
from .sparse_terms import sindy_beside_ls
from .identified_model import IDENTIFIED_MODEL_FILE
from .hull_choice import HULL_CHOICE_FILE, choose_hull, with_hull
from .identifiability import identifiability
from .settings import read_settings
from .vessel_choice import settle_vessel

logger = logging.getLogger(__name__)

__all__ = ["MMGRun", "is_mmg", "prepare_mmg", "execute_mmg", "choose_scale"]


def is_mmg(cfg: RunConfig) -> bool:
    """Whether the configuration's model is the MMG model (``model=mmg``)."""
    return isinstance(cfg.model, MMGModelConfig)


@dataclass
class MMGRun(_manoeuvring.ManoeuvringRun):
    """A checked ``model=mmg`` configuration with its records (a PreparedRun).

    The fields, name and inputs of :class:`studies.workflows.manoeuvring.ManoeuvringRun`
    (``vessel`` the MMG particulars at the records' scale), plus the
    propeller and rudder parameters ``modules``; replays, simulations and the
    posterior predictive bands (``method=bayes``) use the MMG simulator.
    """

    modules: object = None
    #: the records' state and acceleration estimates, shared with the run's folds (:func:`_estimates`)
    estimate_cache: dict = dataclasses.field(default_factory=dict)

    @property
    def tags(self) -> dict:
        tags = _manoeuvring.run_tags(self.cfg, self.settings)
        tags["hull"] = str(self.cfg.model.hull)
        tags["scale"] = "model" if self.vessel.scale == 1 else f"1:{1 / self.vessel.scale:g}" \
            if self.vessel.scale < 1 else f"{self.vessel.scale:g}x model"
        return tags

    def execute(self, out_dir: Path) -> dict:
        return execute_mmg(self, out_dir)

    def replay(self, params: dict, record: pd.DataFrame) -> pd.DataFrame:
        """The record's rudder and propeller rate replayed from its first state."""
        rps = None if "n" in record else self.vessel.rps
        return replay_mmg(self.model, params, self.vessel, record, self.modules, rps)

    def simulate_manoeuvre(self, params: dict, manoeuvre, initial: dict | None = None) -> pd.DataFrame:
        rps = self.vessel.rps
        if initial and "u" in initial:
            # the approach rate of the record the manoeuvre starts from
            rps = float(self._approach_rps)
        return simulate_mmg(self.model, params, self.vessel, manoeuvre, self.modules, rps, initial)

    @property
    def _approach_rps(self) -> float:
        rates = [float(r["n"].iloc[0]) for r in self.validation_records + self.records if "n" in r]
        return float(np.median(rates)) if rates else self.vessel.rps


def published_values(vessel: MMGVessel, model) -> dict:
    """The vessel's published hull coefficients of ``model``'s terms; a term it does not
    publish (the asymmetry constants ``Y0``, ``N0``) is zero: the published model is symmetric."""
    return {name: float(vessel.coefficients.get(name, 0.0)) for name in model.names}


def _approach_speed(records) -> float:
    """Median initial speed [m/s] of the records."""
    return float(np.median([float(np.hypot(r["u"].iloc[0], r["v"].iloc[0])) for r in records]))


def choose_scale(vessel_name: str, setting: str, records) -> MMGVessel:
    """The vessel's MMG particulars at the records' scale (``model.scale``).

    ``auto`` takes the scale (model or full) whose approach speed is nearest,
    on a log scale, to the median initial speed of the records.
    """
    if setting in ("model", "full"):
        return get_mmg_vessel(vessel_name, full_scale=setting == "full")
    if not records:
        return get_mmg_vessel(vessel_name)
    return mmg_vessel_at_speed(vessel_name, _approach_speed(records))


def _at_approach(vessel: MMGVessel, records) -> MMGVessel:
    """The vessel with the training records' median approach speed and rate."""
    if not records:
        return vessel
    rps = float(np.median([float(r["n"].iloc[0]) for r in records]))
    return dataclasses.replace(vessel, speed=_approach_speed(records), rps=rps)


def _require_rate(records, paths) -> None:
    for rec, path in zip(records, paths):
        if "n" not in rec:
            raise DataError(str(path), "model=mmg needs the propeller rate of every record "
                            "(column n [rps]; MARIN files carry it as rev [rpm])", "n")
        bad = np.flatnonzero(~(rec["n"].to_numpy(float) >= 0))
        if len(bad):
            raise DataError(str(path), "the propeller rate must be a number >= 0 [rps]", "n", int(bad[0]))


def prepare_mmg(cfg: RunConfig, root: Path | None = None, record=None) -> MMGRun:
    """Check a ``model=mmg`` configuration and load or simulate its records."""
    settings = read_settings(cfg)
    # auto: the family is chosen when the run executes (hull_choice); the standard one until then
    hull = "standard" if cfg.model.hull == "auto" else cfg.model.hull
    model = mmg(str(cfg.model.name), asymmetry=cfg.model.asymmetry, hull=hull)
    method = str(cfg.method.name)
    check_method("manoeuvring", method)
    vessel_name = settle_vessel(cfg, root)
    get_mmg_vessel(vessel_name)                       # refuse a vessel without MMG particulars
    truth = None
    if settings.data_paths:
        n_params = max(len(model.terms_of(d)) for d in ("X", "Y", "N"))
        min_samples = _manoeuvring.MIN_SAMPLES_PER_COEFFICIENT * n_params + 5
        records, validation = _measured.load_study_records(settings.data_paths, settings.validate_paths,
                                                           min_samples, cfg.data.resample, cfg.data.scale)
        _require_rate(validation, settings.validate_paths)
        _require_rate(records, settings.data_paths)
        vessel = _at_approach(choose_scale(vessel_name, cfg.model.scale, records), records)
        measured = True
    else:
        if cfg.model.hull == "auto" or not HULL_FAMILIES[cfg.model.hull][1]:
            raise ConfigError(f"model.hull={cfg.model.hull} needs measured records (data.path): "
                              "the families are chosen by records, and the reduced one has no "
                              "published coefficients to simulate them with")
        validation = _measured.load_measured(settings.validate_paths) if settings.validate_paths else []
        _require_rate(validation, settings.validate_paths)
        vessel = choose_scale(vessel_name, "full" if cfg.model.scale == "full" else "model", [])
        truth = published_values(vessel, model)
        rng = np.random.default_rng(settings.seed)
        records = []
        for man in _manoeuvring.training_manoeuvres(cfg):
            rec = simulate_mmg(model, truth, vessel, man)
            if "diverged_at" in rec.attrs:
                raise RuntimeError(f"the reference MMG simulation of {man.name} diverged")
            rec = add_measurement_noise(rec, settings.measurement_noise, vessel.speed, rng)
            rec.attrs["name"] = man.name
            records.append(rec)
        measured = False
    said = settled_discrepancy(cfg.method, measured)
    if said:
        logger.info(said)
    return MMGRun(cfg, settings, vessel, model, method, records, truth, validation, measured,
                  family_modules(hull, vessel.modules))


def _record_key(record: pd.DataFrame) -> tuple:
    """What tells a record from another within a run, across processes: its name, length
    and the sums of its track (two folds of a cross-validation hold the same record objects;
    a worker process holds copies of them)."""
    return (str(record.attrs.get("name", "")), len(record), float(record["x0"].sum()),
            float(record["y0"].sum()), float(record["psi"].sum()))


def _estimates(run: MMGRun) -> list:
    """The states and accelerations of the run's records (each record's own smoother, or
    ``data.derivative``): computed once per record and kept in ``run.estimate_cache``, which
    the run's cross-validation folds and hull families share (a record's estimate does not
    depend on the other records)."""
    derivative = run.cfg.data.derivative
    if run.measured:
        derivative = _manoeuvring.measured_derivative(run.records, derivative)
    if derivative == "ekf":
        derivative = "ekf_kinematic"
    kalman, _ = _measured.kalman_options(run.cfg)
    cache = run.estimate_cache
    setting = (derivative, repr(kalman))
    keys = [(_record_key(r), setting) for r in run.records]
    missing = [r for r, k in zip(run.records, keys) if k not in cache]
    for record, estimate in zip(missing, _measured.estimate_all(missing, derivative, kalman)):
        cache[(_record_key(record), setting)] = estimate
    return [cache[k] for k in keys]


def hull_problems(run: MMGRun, estimates=None):
    """``problems(modules)``: the hull regression of the run's records (prior and captive rows
    as configured) for given propeller and rudder parameters; ``estimates`` the records'
    smoothed states when already computed."""
    cfg = run.cfg.model
    if estimates is None:
        estimates = _estimates(run)
    # the published values are those of the standard hull: a family whose terms share them out
    # differently (the rudder and u' = cos(beta) in the hull's terms) is regressed without them
    prior = dict(run.vessel.coefficients) \
        if math.isfinite(cfg.prior_scale) and HULL_FAMILIES[run_hull(run)][1] else None

    captive = None
    if cfg.captive_weight > 0:
        model_scale = get_mmg_vessel(str(run.cfg.vessel.name))
        if not model_scale.captive:
            raise ConfigError(f"model.captive_weight: vessel '{run.cfg.vessel.name}' has no captive tests")
        captive = (model_scale, read_captive(model_scale.captive), cfg.captive_weight)

    def problems(modules):
        ties = family_ties(run_hull(run), run.vessel, modules) if cfg.tie_rudder else ()
        return mmg_problems(run.model, run.vessel, modules, run.records, estimates, prior,
                            cfg.prior_scale, cfg.prior_floor, cfg.weights, captive, ties)
    return problems


def run_hull(run: MMGRun) -> str:
    """The hull family the run identifies (``model.hull``; ``auto`` before its choice is
    made is the standard family the run was prepared with)."""
    hull = run.cfg.model.hull
    return "standard" if hull == "auto" else hull


def identify_mmg(run: MMGRun):
    """Hull coefficients (and listed interaction factors); ``(result, modules, metrics)``."""
    cfg = run.cfg.model
    estimates = _estimates(run)
    problems = hull_problems(run, estimates)

    def fit_hull(modules):
        return LeastSquares().fit(problems(modules)).params

    metrics = {"mmg/prior_scale": cfg.prior_scale, "mmg/scale": float(run.vessel.scale),
               "mmg/captive_weight": cfg.captive_weight}
    modules = run.modules
    if cfg.fit_wake:
        modules, wake = fit_wake(run.records, run.vessel, modules)
        metrics.update(wake)
    if cfg.rudder_lift == "fit":
        modules, lift = fit_rudder_lift(problems(modules),
                                        rudder_lift_columns(run.vessel, modules, run.records, estimates),
                                        modules)
        metrics.update(lift)
        logger.info("rudder lift identified with the hull: f_alpha %.3f (published %.3f), "
                    "f_alpha_2 %.3f", modules.f_alpha, run.vessel.modules.f_alpha, modules.f_alpha_2)
    if cfg.output_error:
        modules, _, info = refine_modules(run.model, run.vessel, run.records, modules,
                                          cfg.output_error, fit_hull, cfg.output_error_sample_s,
                                          max_evaluations=cfg.output_error_evaluations)
        metrics.update(info)
    identifier = make_identifier(run.method, _manoeuvring._method_options(run.cfg))
    objective = MMGObjective(run.model, run.vessel, run.records, modules, max_samples=2000)
    t0 = time.perf_counter()
    # the result holds the problems' known coefficients too (the tied rudder pairs)
    result = identifier.fit(problems(modules), objective=objective)
    metrics["runtime/identify_s"] = time.perf_counter() - t0
    metrics.update(result.metrics)
    run.estimates = estimates
    return result, modules, metrics


def _factor_table(run: MMGRun, modules) -> pd.DataFrame:
    fitted = set(run.cfg.model.output_error)
    regressed = set(RUDDER_LIFT_FACTORS) if run.cfg.model.rudder_lift == "fit" else set()

    def source(name):
        if name in fitted:
            return "output_error"
        return "regression" if name in regressed else "published"
    rows = [{"name": k, "value": v, "prior": getattr(run.vessel.modules, k), "source": source(k)}
            for k, v in modules.as_dict().items()]
    return pd.DataFrame(rows)


def _validate_simulated(run: MMGRun, params: dict, out_dir: Path) -> dict:
    """Validation manoeuvres simulated with the identified and the published coefficients."""
    metrics = {}
    # the published model is the standard method's, whatever the run's hull family
    published_model = mmg(str(run.model.name))
    reference = published_values(run.vessel, published_model)
    for name in run.settings.validate_manoeuvres:
        man = _manoeuvring.validation_manoeuvre(name, run.cfg.validate.duration)
        ref = simulate_mmg(published_model, reference, run.vessel, man)
        pred = simulate_mmg(run.model, params, run.vessel, man, run.modules)
        metrics.update(_manoeuvring.compare_simulated(
            name, man, pred, ref, out_dir, f"{name}: identified MMG ({run.method}) vs published MMG",
            table=False))
    return metrics


#: characteristics set side by side in comparison.csv
COMPARED = ("rmse_position", "advance_error_pct", "tactical_diameter_error_pct",
            "steady_speed_error_pct", "steady_yaw_rate_error_pct", "steady_diameter_error_pct",
            "overshoot1_error_deg", "overshoot2_error_deg", "closed_loop/overshoot1_error_deg",
            "closed_loop/overshoot2_error_deg")


def _abkowitz_beside(run: MMGRun, out_dir: Path) -> dict:
    """The Abkowitz ``symmetric`` model identified (LS) and validated on the same records."""
    abk_vessel = get_vessel(str(run.cfg.vessel.name))
    if abs(math.log(abk_vessel.speed / run.vessel.speed)) > math.log(1.5):
        return {}                                      # not the Abkowitz particulars' scale
    cfg = dataclasses.replace(run.cfg, method=MethodConfig(name="ls"),
                              validate=dataclasses.replace(run.cfg.validate, compare_derivatives=False,
                                                           band_draws=0))
    study = _manoeuvring.ManoeuvringRun(cfg, run.settings, abk_vessel, get_model("symmetric"), "ls",
                               run.records, None, run.validation_records, True)
    metrics = _manoeuvring.execute(study, out_dir / "abkowitz")
    return {f"abkowitz/{k}": v for k, v in metrics.items()}


def _comparison(run: MMGRun, metrics: dict, out_dir: Path) -> None:
    rows = []
    for rec in run.validation_records:
        name = rec.attrs.get("name", "record")
        for key in COMPARED:
            mmg = metrics.get(f"{name}/{key}")
            abk = metrics.get(f"abkowitz/{name}/{key}")
            if mmg is None and abk is None:
                continue
            rows.append({"record": name, "quantity": key, "mmg": mmg, "abkowitz": abk})
    if not rows:
        return
    table = pd.DataFrame(rows, columns=["record", "quantity", "mmg", "abkowitz"])
    table.to_csv(out_dir / "comparison.csv", index=False)
    training = ", ".join(str(r.attrs.get("name")) for r in run.records)
    lines = [f"# MMG against Abkowitz, trained on {training}", "",
             "Errors of the replayed validation records (prediction minus measurement; "
             "`_pct` in %, `_deg` in deg, `rmse_position` in m).", "",
             "| record | quantity | MMG | Abkowitz |", "|---|---|---:|---:|"]
    fmt = (lambda x: "–" if x is None or not np.isfinite(x) else f"{x:+.1f}")
    for row in table.itertuples():
        lines.append(f"| {row.record} | {row.quantity} | {fmt(row.mmg)} | {fmt(row.abkowitz)} |")
    (out_dir / "comparison.md").write_text("\n".join(lines) + "\n")


#: papers whose published predictions of measured records are set beside a run's
PUBLISHED_PREDICTIONS = (("alexandersson2022", "turning_circles"),)


def _turn_side(record: pd.DataFrame) -> str:
    """``port`` when the heading decreases over the record (a turn to port), else ``starboard``."""
    return "port" if float(record["psi"].iloc[-1] - record["psi"].iloc[0]) < 0 else "starboard"


def _held_rudder_deg(record: pd.DataFrame) -> float:
    """The rudder angle [deg, data contract's sign] the record holds longest, to the degree
    (a turning circle's +35 or -35)."""
    angles = np.round(np.rad2deg(record["delta"].to_numpy(float)))
    values, counts = np.unique(angles, return_counts=True)
    return float(values[np.argmax(counts)])


def _published_beside(run: MMGRun, metrics: dict, out_dir: Path) -> None:
    """``published.md``/``.csv``: published predictions of the validation records beside the run's,
    each record matched to the published turn with its own rudder angle (sign included)."""
    rows = []
    for paper_id, table_name in PUBLISHED_PREDICTIONS:
        paper = get_paper(paper_id)
        table = published(paper_id, table_name)
        for rec in run.validation_records:
            name = str(rec.attrs.get("name"))
            side = _turn_side(rec)
            rudder = _held_rudder_deg(rec)
            same = table[(table["record"] == name) & (table["rudder_deg"].astype(float) == rudder)]
            for row in same.itertuples():
                rows.append({"record": name, "turn of the record": side, "rudder [deg]": rudder,
                             "quantity": row.quantity,
                             "mmg": metrics.get(f"{name}/{row.quantity}"),
                             "abkowitz": metrics.get(f"abkowitz/{name}/{row.quantity}"),
                             "published": float(row.value),
                             "published training": row.training, "source": paper.citation})
    if not rows:
        return
    frame = pd.DataFrame(rows)
    frame.to_csv(out_dir / "published.csv", index=False)
    training = ", ".join(str(r.attrs.get("name")) for r in run.records)
    fmt = (lambda x: "–" if x is None or not np.isfinite(x) else f"{x:+.1f}")
    lines = ["# The run's predictions beside published ones", "",
             f"Trained on {training}; prediction minus measurement in %, {_records_scale(run)}. The "
             "published values are the papers' own predictions of the same measured record, the turn "
             "with the same rudder angle (the data contract's sign: positive turns to a decreasing "
             "heading); their training records in the last column. The turn of the record is read from "
             "its heading (decreasing: port).", "",
             "| record | turn | rudder [deg] | quantity | MMG | Abkowitz | published | published training | source |",
             "|---|---|---:|---|---:|---:|---:|---|---|"]
    for r in frame.itertuples(index=False):
        lines.append(f"| {r[0]} | {r[1]} | {r[2]:+.0f} | {r[3]} | {fmt(r[4])} | {fmt(r[5])} | {r[6]:+.1f} | "
                     f"{r[7]} | {r[8]} |")
    (out_dir / "published.md").write_text("\n".join(lines) + "\n")


def _records_scale(run: MMGRun) -> str:
    labels = {scale_label(r) for r in run.records + run.validation_records}
    return ", ".join(sorted(labels))


def _cross_validation(run: MMGRun, out_dir: Path) -> dict:
    """Leave-one-record-out over the training records (``model.cross_validate``)."""
    table, metrics, bands = cross_validate(run, identify_mmg, out_dir, run.cfg.validate.band_draws,
                                           run.settings.seed, run.cfg.model.cross_validate_jobs)
    table.to_csv(out_dir / "cross_validation.csv", index=False)
    facilities = sorted({str(r.attrs.get("facility", "")) for r in run.records} - {""})
    title = "Leave-one-record-out cross-validation" + (f" over the {' and '.join(facilities)} records"
                                                      if facilities else "")
    (out_dir / "cross_validation.md").write_text(cv_table_markdown(table, title, _records_scale(run)))
    if bands is not None:
        metrics.update(write_band_calibration(bands, out_dir, _discrepancy_setting(run), _records_scale(run)))
    return metrics


def _discrepancy_setting(run: MMGRun) -> str:
    method = run.cfg.method
    out = (f"model={run.model.name}, method=bayes, method.discrepancy="
           f"{getattr(method, 'discrepancy', 'none')}")
    if getattr(method, "discrepancy", "none") != "none":
        out += (", each training record filtered by the model of the others"
                if getattr(method, "discrepancy_out_of_sample", False) else ", in sample")
    replay = run.cfg.validate.band_replay
    return out + ("; zig-zags replayed as they were run (the rudder reversed at the test's heading)"
                  if replay == "steered" else "; every record replayed with its measured rudder")


def _captive(run: MMGRun, params: dict, modules, out_dir: Path) -> dict:
    model_scale = get_mmg_vessel(str(run.cfg.vessel.name))
    if not model_scale.captive:
        return {}
    tests = read_captive(model_scale.captive)
    published = published_values(model_scale, run.model)
    table, summary = captive_comparison({"identified": (run.model, params, modules),
                                         "published": (run.model, published, model_scale.modules)},
                                        model_scale, tests)
    table.to_csv(out_dir / "captive.csv", index=False)
    summary.to_csv(out_dir / "captive_summary.csv", index=False)
    plot_captive(table, ("identified", "published"), out_dir / "captive.png",
                 "captive tests: identified and published MMG against measured forces")
    out = {}
    for row in summary.itertuples():
        kind = row.test.replace(" + ", "_and_").replace(" ", "_")
        out[f"captive/{row.model}/{kind}/{row.quantity}_rmse_pct_of_range"] = row.rmse_pct_of_range
    return out


def _scale_note(run: MMGRun) -> str:
    v = run.vessel
    if v.scale == 1:
        scale = "model scale (the particulars of the tested model)"
    else:
        scale = f"Froude scaled by {v.scale:g} from the tested model (lengths x{v.scale:g}, " \
                f"speeds and times x{math.sqrt(v.scale):.3g}, rates /{math.sqrt(v.scale):.3g})"
    return "\n".join([f"# MMG model of {v.name}", "",
                      f"- scale: {scale}; L = {v.length:.4g} m, approach {v.speed:.4g} m/s at "
                      f"{v.rps:.4g} rps",
                      f"- hull family: {run_hull(run)} ({', '.join(run.model.names)})"
                      + (", the rudder's forces in its terms (rudder module off)"
                         if not HULL_FAMILIES[run_hull(run)][1] else ""),
                      f"- hull coefficients: MMG primes (X, Y over 0.5 rho L d U^2, N over "
                      f"0.5 rho L^2 d U^2; u' = u/U, T' = T / (0.5 rho L d U^2)), "
                      + (f"prior sd max({run.cfg.model.prior_scale:g} |c0|, "
                         f"{run.cfg.model.prior_floor:g}) around {v.reference}"
                         if HULL_FAMILIES[run_hull(run)][1] and math.isfinite(run.cfg.model.prior_scale)
                         else "no prior (least squares on the records)"),
                      f"- captive tests in the regression: "
                      f"{'weight %g' % run.cfg.model.captive_weight if run.cfg.model.captive_weight > 0 else 'no'}",
                      f"- interaction factors fitted by output error: "
                      f"{', '.join(run.cfg.model.output_error) or 'none (published values)'}", ""])


def _identifiability(run: MMGRun, modules, params: dict, out_dir: Path) -> dict:
    """``identifiability.md``: the hull regression's conditioning, each coefficient's change with
    each training record left out, the held-out records' states beyond the training records'."""
    estimates = getattr(run, "estimates", None) or _estimates(run)
    scale = next((line[2:] for line in _scale_note(run).splitlines() if line.startswith("- scale:")), "")
    return identifiability(hull_problems(run, estimates)(modules), params, run.records,
                           run.validation_records, run.vessel, out_dir, scale[:1].upper() + scale[1:])


def execute_mmg(run: MMGRun, out_dir: Path) -> dict:
    """Identify, validate and write the run's files; the metrics (also ``metrics.json``)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    chosen = {}
    if run.cfg.model.hull == "auto" and run.measured:
        _estimates(run)                       # once, before the folds (and their processes) share them
        hull, chosen = choose_hull(run, identify_mmg, out_dir)
        picked = with_hull(run, hull)
        run.cfg, run.model, run.modules = picked.cfg, picked.model, picked.modules
        logger.info("model.hull=auto: the training records support the %s hull (%s)", hull, HULL_CHOICE_FILE)
    result, modules, metrics = identify_mmg(run)
    metrics.update(chosen)
    run.modules = modules
    params = {name: result.params[name] for name in run.model.names}
    table = _manoeuvring.coefficient_table(run.model, params, result.lower, result.upper, run.truth)
    table.to_csv(out_dir / "coefficients.csv", index=False)
    _factor_table(run, modules).to_csv(out_dir / "interaction_factors.csv", index=False)
    _manoeuvring.identified_model(run, params, modules, Environment()).write(out_dir / IDENTIFIED_MODEL_FILE)
    (out_dir / "mmg.md").write_text(_scale_note(run))
    for filename, writer in result.writers.items():
        writer(out_dir / filename)
    _manoeuvring.write_metric_history(result.history, out_dir / _manoeuvring.METRIC_HISTORY)
    metrics["training/samples"] = float(sum(len(r) for r in run.records))
    if run.truth:
        dev = table["deviation_pct"].abs()
        metrics["deviation/median_abs_pct"] = float(dev.median())
        metrics["deviation/max_abs_pct"] = float(dev.max())
    metrics.update(_manoeuvring._replay_training(run, params, out_dir))
    if run.measured:
        metrics.update(_identifiability(run, modules, params, out_dir))
    if run.validation_records:
        metrics.update(_manoeuvring._validate_records(run, params, out_dir, result))
        if run.cfg.model.compare_abkowitz and run.measured:
            metrics.update(_abkowitz_beside(run, out_dir))
            _comparison(run, metrics, out_dir)
        if run.measured:
            _published_beside(run, metrics, out_dir)
    else:
        metrics.update(_validate_simulated(run, params, out_dir))
    if run.method == "sindy":
        metrics.update(sindy_beside_ls(run, run.model, result,
                                       lambda: LeastSquares().fit(hull_problems(run)(modules)).params,
                                       metrics, out_dir, _manoeuvring._validate_records))
    if run.cfg.model.captive:
        metrics.update(_captive(run, params, modules, out_dir))
    if run.cfg.model.cross_validate and run.measured:
        metrics.update(_cross_validation(run, out_dir))
    own = {k: v for k, v in metrics.items() if not k.startswith(("abkowitz/", "captive/", "ls/", "cv/"))}
    metrics.update(_manoeuvring.speed_mae_summary(own, {str(r.attrs.get("name")) for r in run.records}))
    metrics["runtime/total_s"] = time.perf_counter() - started
    metrics = {k: float(v) for k, v in metrics.items() if v is not None and np.isfinite(v)}
    (out_dir / "metrics.json").write_text(json.dumps(metrics, indent=1, sort_keys=True))
    return metrics
