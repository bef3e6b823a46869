"""``studies discover`` on manoeuvring records: show what the simulation gets
wrong, name the cause, extend the model with it and measure the gain on data
it was not fitted to.

The causes come from the catalogue of :mod:`studies.discover.causes`.
:func:`prepare_discovery` checks the options and loads every record before
any tracked run exists; :func:`execute_discovery` writes ``discovery.json``,
``report.md``/``report.html`` and figures. Roll decays have their own
discovery (:mod:`studies.roll.workflow.discover`); the command line reaches
both through :mod:`studies.workflows.kinds`.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path

import numpy as np
import pandas as pd

from ..config import DiscoverConfig
from ..data.resample import resample
from ..discover import diagnostics as dg
from ..discover.causes import Setup, compact_parameters
from ..discover.diagnostics import explains
from ..discover.fitting import Context, kinematic_smoothing, regression_fit, training_error
from ..discover.report import (indistinguishable, plot_predictions, plot_ranking, plot_residuals,
                               write_discovery, write_report)
from ..discover.confidence import certainty
from ..discover.search import (EVIDENCE, breaks_down, held_out_evidence, named_on_held_out,
                               named_on_held_out_windows, named_on_training, not_named, search,
                               second_on_held_out_note)
from ..errors import ConfigError
from ..vessels import get_vessel
from .manoeuvring import get_study_model
from .measured import load_measured, load_study_records
from .settings import as_path_list
from .protocol import PreparedDiscovery, Recorder, StudyKind, gain_pct
from .vessel_choice import settle_vessel

__all__ = ["prepare_discovery", "execute_discovery", "holdout", "split_discoveries", "gain_pct",
           "smooth_measured", "on_record_time"]

log = logging.getLogger(__name__)


def smooth_measured(record: pd.DataFrame) -> pd.DataFrame:
    """Velocities and heading of a measured record replaced by their EKF/RTS
    estimates (kinematic pass; positions and rudder kept): discovery then
    fits every cause on consistent states, estimated once
    (:func:`studies.discover.fitting.kinematic_smoothing`)."""
    return kinematic_smoothing(record)


def holdout(records: list, share: float) -> tuple[list, list, str]:
    """Training and validation records when no validation record is given.

    Two or more records: the last whole record is held out. One record: its
    last ``share`` is held out (replayed from its own state at the cut).
    """
    if len(records) >= 2:
        return records[:-1], records[-1:], f"held out the whole record {records[-1].attrs.get('name')}"
    rec = records[0]
    cut = int(len(rec) * (1.0 - share))
    train, val = rec.iloc[:cut].copy(), rec.iloc[cut:].copy()
    for part, suffix in ((train, "first"), (val, "last")):
        part.attrs = dict(rec.attrs)
        part.attrs["name"] = f"{rec.attrs.get('name', 'record')}_{suffix}"
    return [train], [val], f"held out the last {100 * share:.0f} % of {rec.attrs.get('name')}"


def prepare_discovery(cfg: DiscoverConfig, root: Path, kind: StudyKind,
                      record: Recorder | None = None) -> PreparedDiscovery:
    """Check the options and load every manoeuvring record (raises ConfigError/DataError)."""
    data = as_path_list(cfg.data.path)
    if not data:
        raise ConfigError("discover needs measured records: data.path=FILE or data.path=[a,b]")
    validate = as_path_list(cfg.validate.path)
    simulation = cfg.simulation.path
    vessel = get_vessel(settle_vessel(cfg, root))
    model = get_study_model(cfg, root, record)
    records, val = load_study_records(data, validate, min_samples=60, scale=cfg.data.scale)
    sim = load_measured([str(simulation)])[0] if simulation else None
    if cfg.data.derivative in ("ekf", "ekf_kinematic"):
        records = [smooth_measured(r) for r in records]
    prepared = PreparedDiscovery(cfg, kind, vessel, model, records, val, sim, records=records + val)
    if cfg.discover.splits and len(prepared.records) < 2:
        raise ConfigError("discover.splits=true needs two or more records (data.path + validate.path) "
                          "to hold out in turn")
    if not val:
        prepared.train, prepared.validation, note = holdout(records, cfg.discover.holdout)
        prepared.notes.append(note)
    return prepared


def _interval_dict(names, post) -> dict:
    if not post:
        return {}
    return {n: [float(lo), float(hi)] for n, lo, hi in zip(names, post["q05"], post["q95"])}


def _same_records(a: list, b: list) -> bool:
    return len(a) == len(b) and all(x is y for x, y in zip(a, b))


def split_discoveries(prepared: PreparedDiscovery, ctx, opts, main: dict, main_training_rmse: float) -> list[dict]:
    """Every record held out in turn: the cause each split names, fitted on the
    other records and judged on the held-out one (no second cause, no
    intervals). Shows whether the named cause depends on which manoeuvre
    was kept for validation. The split that is the main discovery's own
    (same training and validation records) reuses its search ``main`` and
    its named model's training error ``main_training_rmse``."""

    rows = []
    for k, held in enumerate(prepared.records):
        train = [r for j, r in enumerate(prepared.records) if j != k]
        if _same_records(train, prepared.train) and _same_records([held], prepared.validation):
            result, own = main, main_training_rmse
        else:
            split = Context(ctx.vessel, ctx.model, train, [held], ctx.derivative)
            split.horizon = ctx.horizon
            result = search(split, opts.terms_threshold, opts.max_terms, second=False,
                            seed=prepared.cfg.seed, output_error=opts.output_error,
                            intervals=False, score=opts.score)
            own = training_error(split, result["best"])
        best, base = result["best"], result["baseline"]
        b, e = base.validation_rmse, best.validation_rmse
        rows.append({"held_out": str(held.attrs.get("name", f"record {k + 1}")), "cause": best.cause.id,
                     "parameters": best.cause.parameters(best.theta, best.params),
                     "baseline_validation_rmse": b, "extended_validation_rmse": e,
                     "gain_pct": gain_pct(b, e), "training_rmse": own,
                     "explains_validation": explains(e, own, prepared.vessel.length),
                     "fit": "output error" if result["output_error"] else "equation error",
                     "notes": [n for n in (not_named(f, base) for f in result["fits"] if f is not best) if n]})
        log.info("split holding out %s: %s, gain %.1f %%", rows[-1]["held_out"], best.cause.id,
                 rows[-1]["gain_pct"])
    return rows


#: the baseline's largest departures kept in ``discovery.json`` and the verdict
DEPARTURES = 3

UNEXPLAINED = ("No cause in the catalogue gains on unseen data, yet the identified model does not "
               "explain them: its prediction error on the held-out records is many times that on the "
               "records it was fitted to. What the simulation gets wrong is listed below; no catalogue "
               "cause fitted to these training records removes it.")


def _departures(records: list, models: dict, vessel) -> pd.DataFrame:
    """Departures of every model's replays (``models``: label -> one prediction
    per record, None where there is none) from the validation records, largest
    first per model (:func:`studies.discover.diagnostics.departures`)."""

    tables = [dg.departures(rec, pred, str(rec.attrs.get("name", "record")), vessel).assign(model=label)
              for label, predictions in models.items() for rec, pred in zip(records, predictions)
              if pred is not None]
    tables = [t for t in tables if not t.empty]
    if not tables:
        return pd.DataFrame()
    out = pd.concat(tables, ignore_index=True)
    return out.sort_values(["model", "rmse_prime"], ascending=[True, False], ignore_index=True,
                           key=lambda c: c.map(list(models).index) if c.name == "model" else c)


def on_record_time(simulation: pd.DataFrame, record: pd.DataFrame) -> pd.DataFrame | None:
    """Another simulator's run interpolated onto a measured record's time axis
    (``t``, ``x0``, ``y0``, ``psi``, ``u``, ``v``, ``r``, ``delta``); None when
    it is not a run of that manoeuvre: its time span does not cover the
    record's (to within one sample), or its largest port or starboard rudder
    angle differs from the measured one by more than 2 deg or 20 % (the
    time history may differ: a zig-zag's rudder switches when the simulated
    heading says so)."""
    ts, t = simulation["t"].to_numpy(float), record["t"].to_numpy(float)
    step = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    if ts[0] > t[0] + step or ts[-1] < t[-1] - step:
        return None
    out = resample(simulation, t, [c for c in ("x0", "y0", "psi", "u", "v", "r", "delta") if c in simulation])
    out.attrs = {}
    if "delta" in out:
        measured, run = record["delta"].to_numpy(float), out["delta"].to_numpy()
        tolerance = max(np.deg2rad(2.0), 0.2 * float(np.max(np.abs(measured))))
        if (abs(run.max() - measured.max()) > tolerance or abs(run.min() - measured.min()) > tolerance):
            return None
    return out


def execute_discovery(prepared: PreparedDiscovery, out_dir: Path) -> tuple[dict, dict]:
    """Run the discovery on manoeuvring records; ``(discovery, metrics)``."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)

    opts = prepared.cfg.discover
    t0 = time.perf_counter()
    derivative = prepared.cfg.data.derivative
    if any(r.attrs.get("smoothed") == "ekf" for r in prepared.train):
        derivative = "central"      # states already smoothed once by the EKF/RTS pass
    ctx = Context(prepared.vessel, prepared.model, prepared.train, prepared.validation, derivative)
    ctx.horizon = opts.horizon or None
    result = search(ctx, opts.terms_threshold, opts.max_terms, opts.second_cause,
                    opts.posterior_steps, prepared.cfg.seed, opts.output_error, score=opts.score)
    best, baseline = result["best"], result["baseline"]
    # whole-record predictions for the figures and the characteristics
    full_base, full_best = baseline.whole, best.whole
    cause = best.cause
    params = cause.parameters(best.theta, best.params)
    post = result.get("posterior") or {}
    if post.get("method") == "linear":
        uncertainty = {"terms": _interval_dict(post["names"], post)}
    else:
        names = list(cause.nl_params)
        uncertainty = _interval_dict(names, post)
        if cause.id in ("current", "wind_unmodelled") and "direction" in uncertainty:
            uncertainty["direction"] = [float(x) % (2 * np.pi) for x in uncertainty["direction"]]
    # a cause that replaces the dynamics is scored on another model's residual: listed last, no score
    ranked = (sorted([f for f in result["fits"] if not f.cause.replaces_dynamics], key=lambda f: f.score)
              + [f for f in result["fits"] if f.cause.replaces_dynamics])
    top = ranked[0].score
    lost = {f.cause.id: breaks_down(f, baseline) for f in ranked}
    b_rmse, e_rmse = baseline.validation_rmse, best.validation_rmse
    b_train = training_error(ctx, baseline)
    e_train = b_train if best is baseline else training_error(ctx, best)
    explained = dg.explains(e_rmse, e_train, prepared.vessel.length)
    discovery = {
        "cause": cause.id, "parameters": params, "uncertainty": uncertainty,
        "explanation": cause.explanation if explained or cause.id != "none" else UNEXPLAINED,
        "baseline": {"validation_rmse": b_rmse, "validation_rmse_whole_records": full_base["position_rmse"],
                     "training_rmse": b_train},
        "extended": {"validation_rmse": e_rmse, "validation_rmse_whole_records": full_best["position_rmse"],
                     "training_rmse": e_train},
        "explains_validation": explained,
        "gain_pct": gain_pct(b_rmse, e_rmse),
        "units": "m (position RMSE over prediction windows)",
        "ranking": [{"cause": f.cause.id,
                     "score": None if f.cause.replaces_dynamics else float(f.score - top),
                     "validation_rmse": f.validation_rmse,
                     "validation_rmse_whole_records": f.whole["position_rmse"],
                     "diverges_on": lost[f.cause.id]} for f in ranked],
        "second_cause": ({"cause": result["second"].cause.id,
                          "parameters": result["second"].cause.parameters(result["second"].theta,
                                                                          result["second"].params),
                          "validation_rmse": result["second"].validation_rmse}
                         if result.get("second") else None),
        "pairs": [{"cause": f.cause.id, "score": float(f.score - best.score),
                   "validation_rmse": f.validation_rmse,
                   "parameters": f.cause.parameters(f.theta, f.params)} for f in result.get("pairs", [])],
        "fit": "output error" if result["output_error"] else "equation error",
        "score": result["score"],
        "candidate_terms": [t.name for t in result["candidates"]],
        "selected_terms": [t.name for t in result["terms"]],
        "notes": prepared.notes + result.get("notes", []) + [note for note in [named_on_held_out(best, baseline),
                                                  named_on_training(best, baseline),
                                                  named_on_held_out_windows(best, baseline),
                                                  second_on_held_out_note(result.get("second"), best)]
                                + [not_named(f, baseline) for f in ranked if f is not best] if note],
    }
    discovery["indistinguishable_from"] = indistinguishable(discovery["ranking"], discovery["cause"])
    # causes that explain the training records better but that they cannot decide for
    undecidable = [(f.cause.id, f.undecidable[1]) for f in ranked
                   if f.undecidable and f is not best and f.score < baseline.score - EVIDENCE]
    certainty(discovery, held_out_evidence(best, baseline)[2] if best.cause.replaces_dynamics else None,
              undecidable)
    other = [on_record_time(prepared.simulation, rec) if prepared.simulation is not None else None
             for rec in ctx.validation]
    if prepared.simulation is not None and all(o is None for o in other):
        discovery["notes"].append(f"simulation.path ({prepared.simulation.attrs.get('name')}) not judged: its "
                                  "time span or rudder matches no validation record")
    models = {"baseline": full_base["predictions"]}
    if best is not baseline:
        models[f"extended ({cause.id})"] = full_best["predictions"]
    if any(o is not None for o in other):
        models["other simulator"] = other
    departed = _departures(ctx.validation, models, prepared.vessel)
    discovery["departures"] = (departed.groupby("model", sort=False).head(DEPARTURES).to_dict("records")
                               if not departed.empty else [])
    if opts.splits:
        discovery["splits"] = split_discoveries(prepared, ctx, opts, result, e_train)
    # what the baseline gets wrong
    base_params, residuals, problems = regression_fit(ctx, Setup(ctx.model, ctx.train))
    ranking = pd.DataFrame(discovery["ranking"]).set_index("cause")
    ranking["diverges_on"] = [", ".join(names) for names in ranking["diverges_on"]]
    sections = [("Ranking of the causes (validation: windowed and whole-record position RMSE, m)", ranking)]
    if not departed.empty:
        sections.append(("Where the simulation departs most from the held-out records (baseline: whole "
                         "replay; u, v in m/s, r in deg/s; ranked by the prime RMSE)",
                         departed.set_index("model")))
    phase_tables, char_tables, figures = [], [], []
    for rec, pb, pe, sim in zip(ctx.validation, full_base["predictions"], full_best["predictions"], other):
        name = str(rec.attrs.get("name", "record"))
        preds = {"baseline": pb}
        if cause.id != "none":
            preds[f"extended ({cause.id})"] = pe
        if sim is not None:
            preds["other simulator"] = sim
        fig = f"prediction_{name}.png"
        plot_predictions(rec, preds, f"{name}: measured vs predicted", out_dir / fig)
        figures.append(fig)
        phase_tables.append(dg.phase_errors(rec, pb, name).assign(model="baseline"))
        if cause.id != "none":
            phase_tables.append(dg.phase_errors(rec, pe, name).assign(model="extended"))
        if sim is not None:
            phase_tables.append(dg.phase_errors(rec, sim, name).assign(model="other simulator"))
        char_tables.append(dg.characteristic_table(rec, preds, name))
    if discovery.get("splits"):
        table = pd.DataFrame(discovery["splits"]).set_index("held_out")
        table["parameters"] = [compact_parameters(p) for p in table["parameters"]]
        table = table.drop(columns="notes")         # printed under the verdict
        sections.append(("Every record held out in turn (validation: windowed position RMSE, m)", table))
    sections.append(("Prediction error per manoeuvre phase (u, v in m/s, r in deg/s)",
                     pd.concat(phase_tables, ignore_index=True) if phase_tables else pd.DataFrame()))
    for table in char_tables:
        if not table.empty:
            sections.append((f"Manoeuvre characteristics: {table.index.name}", table))
    sections.append(("Structure of the baseline's regression residual",
                     dg.residual_structure(problems, residuals, prepared.vessel)))
    plot_residuals(problems, residuals, out_dir / "residuals.png")
    plot_ranking(discovery["ranking"], out_dir / "ranking.png")
    figures += ["residuals.png", "ranking.png"]
    write_discovery(out_dir / "discovery.json", discovery)
    write_report(out_dir, discovery, discovery["explanation"], sections, figures)
    metrics = {"discover/gain_pct": discovery["gain_pct"],
               "discover/baseline_validation_rmse": b_rmse, "discover/extended_validation_rmse": e_rmse,
               "discover/baseline_training_rmse": b_train, "discover/extended_training_rmse": e_train,
               "discover/explains_validation": float(explained),
               "discover/n_causes": float(len(result["fits"])), "discover/tau": ctx.tau,
               "runtime/total_s": time.perf_counter() - t0}
    for f in result["fits"]:
        if not f.cause.replaces_dynamics:
            metrics[f"discover/score/{f.cause.id}"] = float(f.score - top)
        metrics[f"discover/validation_rmse/{f.cause.id}"] = f.validation_rmse
    if discovery.get("splits"):
        metrics["discover/splits_agreeing"] = float(sum(r["cause"] == cause.id for r in discovery["splits"]))
        metrics["discover/splits"] = float(len(discovery["splits"]))
        metrics["discover/splits_explained"] = float(sum(bool(r["explains_validation"])
                                                         for r in discovery["splits"]))
    return discovery, metrics
