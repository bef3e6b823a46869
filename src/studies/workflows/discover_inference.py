"""``studies discover`` by one inference over the cause catalogue
(``discover.method=inference``, the default).

:func:`execute_inference` smooths every record with the baseline, compares
every cause and pair of causes at once (:mod:`studies.discovery.inference`),
refines the named model, replays the held-out records with the baseline and
with it, and writes ``discovery.json`` (a :class:`~studies.discovery.verdict.Discovery`),
``report.md``/``report.html`` and the figures. Any baseline the cause
protocol reaches is accepted: the Abkowitz and symmetric models, and the MMG
model (``model=mmg``: hull by regression with its prior on the published
coefficients, thrust from the measured rpm, rudder in the slipstream).
"""

from __future__ import annotations

import logging
import time
from pathlib import Path

import numpy as np
import pandas as pd

from ..discovery import diagnostics as dg
from ..discovery.causes import NoCause, compact_parameters, manoeuvring_causes
from ..discovery.causes.propulsion import MMGDynamics
from ..discovery.confidence import separating_manoeuvre
from ..discovery.fitting import Context, calibrate, training_error, validate
from ..discovery.held_out import judge_held_out
from ..discovery.inference import baseline_fit, infer, intervals, refine, smooth_with_baseline
from ..discovery.look_alike import detection_limits, verdict_class
from ..discovery.settling import settle
from ..discovery.stated_effect import score_stated, stated_causes
from ..discovery.track_inference import infer_on_tracks
from ..discovery.training_states import outside_training
from ..discovery.report import plot_evidence, plot_predictions, write_discovery, write_report
from ..discovery.verdict import Discovery
from ..plotting import draw
from ..stages import say
from ..threads import single_thread_blas
from ..vessels import has_mmg_particulars, mmg_vessel_at_speed
from .discover import DEPARTURES, departures, on_record_time
from .protocol import PreparedDiscovery, gain_pct

__all__ = ["execute_inference", "baseline_dynamics", "UNDECIDED_BELOW"]

log = logging.getLogger(__name__)

#: a verdict less probable than this lists its rivals (``undecided``) and the manoeuvre that separates them
UNDECIDED_BELOW = 0.9
#: a rival is listed when at least this fraction as probable as the named verdict
RIVAL_FRACTION = 0.1
#: the verdict when the held-out departures lie where training never went
OUTSIDE = "outside_training_states"
OUTSIDE_EXPLANATION = (
    "The held-out records go where the training records never went (drift, yaw rate, speed, rudder or thrust "
    "loading beyond their range), and that is where the model departs from them: no term fitted to the "
    "training records can be trusted there, and no cause of the catalogue predicts them better. Add the "
    "manoeuvre below to the training records.")


def _outside_note(beyond: dict, inferred: str, whole: dict | None) -> str:
    """The ``outside_training_states`` verdict in one sentence, with the inference's own."""
    def unit(v):
        return "" if v["unit"] == "-" else f" {v['unit']}"
    ranges = "; ".join(f"{v['meaning']} {v['held_out'][0]:.3g} to {v['held_out'][1]:.3g}{unit(v)} held out "
                       f"against {v['training'][0]:.3g} to {v['training'][1]:.3g} in training"
                       for v in beyond["states"].values())
    named = "none" if inferred == "none" else (
        f"{inferred}, whose extension does not predict the held-out records better"
        + (f" (whole-record gain {whole['gain_pct']:.1f} %)" if whole else ""))
    return (f"{100 * beyond['departure_share']:.0f} % of the baseline's departure from the held-out records lies "
            f"beyond the training records' states ({ranges}); the inference on the training records alone "
            f"named {named}; {beyond['manoeuvre']} would cover them")


def baseline_dynamics(prepared: PreparedDiscovery) -> MMGDynamics | None:
    """The MMG model's dynamics when the baseline is ``model=mmg`` (particulars
    at the records' scale, from the first record's speed), else None."""
    if str(prepared.cfg.model.name) != "mmg":
        return None
    name = str(prepared.cfg.vessel.name)
    if not has_mmg_particulars(name):
        from ..errors import ConfigError
        raise ConfigError(f"model=mmg: vessel {name} has no MMG particulars (propeller, rudder, K_T curve)")
    hull = str(getattr(prepared.cfg.model, "hull", "standard"))
    if hull == "auto":
        from ..errors import ConfigError
        raise ConfigError("discover: model.hull=auto is chosen by `studies run` (hull_choice.md); "
                          "name the family here (model.hull=standard|thrust|reduced)")
    first = prepared.train[0]
    return MMGDynamics(mmg_vessel_at_speed(name, float(np.hypot(first["u"].iloc[0], first["v"].iloc[0]))),
                       asymmetry=bool(getattr(prepared.cfg.model, "asymmetry", False)), hull=hull,
                       tie_rudder=bool(getattr(prepared.cfg.model, "tie_rudder", True)))


def check_injected(prepared: PreparedDiscovery) -> None:
    """``discover.injected`` refused in one line when a cause or parameter does
    not fit the baseline and the records (:func:`studies.discovery.stated_effect.stated_causes`)."""
    dynamics = baseline_dynamics(prepared)
    model = dynamics.model if dynamics is not None else prepared.model
    stated_causes(Context(prepared.vessel, model, list(prepared.train), list(prepared.validation), "recorded",
                          dynamics=dynamics), prepared.cfg.discover.injected)


def _scale(prepared: PreparedDiscovery, dynamics) -> str:
    if dynamics is not None:
        return "model" if getattr(dynamics.vessel, "model_scale", False) or \
            dynamics.vessel.length < 0.5 * prepared.vessel.length else "full"
    return "model" if any(r.attrs.get("model_scale") for r in prepared.records) else "full"


def _undecided(ranking: list, named: str, confidence: float, undecidable: list, members=()) -> tuple:
    """``(undecided, next_manoeuvre)``: the named verdict, the look-alikes of its
    class (``members`` after the named one), the rivals of some probability, the
    causes the records cannot decide; and what would separate them."""
    alike = [m for m in members if m != named]
    rivals = alike + [r["cause"] for r in ranking if r["cause"] != named and r["cause"] not in alike
                      and r["probability"] >= RIVAL_FRACTION * max(confidence, 1e-12)]
    if confidence >= UNDECIDED_BELOW and not undecidable and not alike:
        return None, None
    if not rivals and not undecidable:
        return None, None
    ids = [c for r in rivals for c in r.split("+")]
    manoeuvre = separating_manoeuvre(named.split("+")[0], ids) if rivals else None
    extra = [m for _, m in undecidable]
    text = "; ".join([m for m in [manoeuvre] + extra if m])
    return [named] + rivals + [c for c, _ in undecidable if c not in rivals], text or None


#: how to read the signatures' likeness (the report's table and the named cause's note)
ALIKE_READING = ("first canonical correlation, the baseline's coefficients projected out; near 1 the records "
                 "cannot tell the two apart, whatever the noise")


def _rounded_alike(alike: dict) -> dict:
    return {a: {b: {**v, "correlation": round(float(v["correlation"]), 4)} for b, v in row.items()}
            for a, row in alike.items()}


def alike_table(alike: dict) -> pd.DataFrame:
    """The causes' signatures' likeness as a square table (1 on the diagonal)."""
    ids = list(alike)
    table = pd.DataFrame([[1.0 if a == b else round(float(alike[a].get(b, {}).get("correlation", np.nan)), 2)
                           for b in ids] for a in ids], index=ids, columns=ids)
    table.index.name = "cause"
    return table


def _alike_note(named: str, alike: dict) -> str | None:
    """In words, how alike each named cause's signature is to the other causes'
    on these records (:mod:`studies.discovery.alike`), most alike first."""
    parts = []
    for cid in named.split("+"):
        row = sorted((alike.get(cid) or {}).items(), key=lambda kv: -kv[1]["correlation"])
        if row:
            others = ", ".join(f"{other} {v['correlation']:.2f}"
                               + (f" ({v['variant']})" if v["variant"] != other else "") for other, v in row)
            parts.append(f"{cid}'s signature on these records is alike {others} ({ALIKE_READING})")
    return "; ".join(parts) or None


def execute_inference(prepared: PreparedDiscovery, out_dir: Path) -> tuple[dict, dict]:
    """Run the discovery on manoeuvring records by one inference; ``(discovery, metrics)``
    (BLAS single-threaded: :func:`studies.threads.single_thread_blas`)."""
    with single_thread_blas():
        return _execute(prepared, out_dir)


def _execute(prepared: PreparedDiscovery, out_dir: Path) -> tuple[dict, dict]:
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    opts = prepared.cfg.discover
    t0 = time.perf_counter()
    dynamics = baseline_dynamics(prepared)
    model = dynamics.model if dynamics is not None else prepared.model
    raw = list(prepared.train) + list(prepared.validation)
    say(f"discover: smoothing {len(raw)} records (kinematic, then with the {model.name} baseline)")
    first = Context(prepared.vessel, model, list(prepared.train), list(prepared.validation), "recorded",
                    dynamics=dynamics)
    smoothed = smooth_with_baseline(first, raw)
    t_smooth = time.perf_counter() - t0
    ctx = Context(prepared.vessel, model, smoothed[:len(prepared.train)], list(prepared.validation), "recorded",
                  dynamics=dynamics)
    ctx.horizon = opts.horizon or None
    calibrate(ctx)
    undecidable = [(c.id, c.undecidable(ctx)[1]) for c in manoeuvring_causes(ctx)
                   if c.undecidable(ctx) is not None]
    judge = str(getattr(opts, "judge", "auto"))
    on_tracks = judge == "tracks" or (judge == "auto" and dynamics is None)
    say(f"discover: comparing the causes on {len(prepared.train)} training records")
    if on_tracks:
        result = infer_on_tracks(ctx, smoothed, raw, pairs=opts.second_cause)
    else:
        result = infer(ctx, smoothed, pairs=opts.second_cause, seed=prepared.cfg.seed)
    named = result.verdict_of(result.named)
    stated = opts.injected
    injected = score_stated(result, stated) if stated and on_tracks else None
    # the verdict and its parameters come from every record; the held-out gain from the named
    # model and the baseline refitted on the training records alone
    baseline = baseline_fit(ctx)
    if result.named:
        say(f"discover: refining {result.fit.cause}")
    best = refine(ctx, result.fit.cause, result.fit.theta) if result.named else baseline
    t_infer = time.perf_counter() - t0 - t_smooth
    say(f"discover: predicting {len(ctx.validation)} held-out records")
    validate(ctx, baseline)
    if best is not baseline:
        validate(ctx, best)
    whole_base = validate(ctx, _copy(baseline), keep=True, whole=True)
    whole_best = validate(ctx, _copy(best), keep=True, whole=True) if best is not baseline else whole_base
    b_window, e_window = baseline.validation_rmse, best.validation_rmse
    b_train = training_error(ctx, baseline)
    e_train = b_train if best is baseline else training_error(ctx, best)
    judged = judge_held_out(ctx.validation, whole_base["predictions"], whole_best["predictions"],
                            seed=prepared.cfg.seed)
    whole = judged["whole"]
    # the headline: whole replays of the held-out records run as the test was (turns); the
    # windowed error when every held-out record is a zig-zag
    b_rmse = whole["baseline_rmse"] if whole else b_window
    e_rmse = whole["extended_rmse"] if whole else e_window
    explained = dg.explains(e_window, e_train, prepared.vessel.length) and judged["explains"]
    beyond = outside_training(ctx.train, ctx.validation, whole_base["predictions"], prepared.vessel)
    ranking = result.ranking()
    confidence = result.confidence
    candidates = {f.cause.id: f.cause.parameters(f.theta, f.params) for m, f in result.fits.items() if len(m) == 1}
    look_alikes = verdict_class(result, candidates, {
        cid: (f.cause.parameters(f.theta, f.params) or {}).get(cid)
        for cid, f in (getattr(result, "pair_fits", None) or {}).items()})
    if look_alikes is not None and named != "none":
        look_alikes["parameters"].setdefault(named, result.fit.cause.parameters(result.fit.theta, result.fit.params))
        # the probability that the records' cause is one of those they cannot tell apart
        confidence = look_alikes["probability"] if len(look_alikes["class"]) > 1 else confidence
    else:
        look_alikes = None
    by_id = {v.cause.id: v.cause for v in result.variants}
    limits = detection_limits(by_id, candidates, result.detectability)
    inferred, inferred_whole = named, whole
    better = whole["gain_pct"] > 0.0 if whole else gain_pct(b_window, e_window) > 0.0
    if beyond is not None and (best is baseline or not better):
        # the departure lies where training never went and no extension predicts the whole
        # held-out records better: never an extension that predicts them worse (a
        # characteristic it predicts worse is said, not overruling)
        named, best, e_rmse, e_window, e_train, explained = (
            OUTSIDE, baseline, b_rmse, b_window, b_train, False)
        whole_best = whole_base
        judged = judge_held_out(ctx.validation, whole_base["predictions"], whole_base["predictions"])
        inferred_whole, whole = whole, judged["whole"]
        confidence = None        # a measurement of where the departure lies, not a probability
    undecided, next_manoeuvre = (_undecided(ranking, named, confidence, undecidable,
                                            look_alikes["class"] if look_alikes else ())
                                 if named != OUTSIDE else (None, beyond["manoeuvre"]))
    settling = None
    if look_alikes is not None and len(look_alikes["class"]) > 1:
        say(f"discover: simulating the {len(look_alikes['class'])} look-alikes over the standard manoeuvres")
        t_settle = time.perf_counter()
        members = look_alikes["class"]
        first = members[0].split("+")
        observed = {m: look_alikes["evidence"].get(m if len(first) == 1 else
                                                   next(iter(set(m.split("+")) - {first[0]}), m), 0.0)
                    for m in members[1:]}
        fitted = _member_fits(result, members, ctx)
        for member, fit in fitted.items():
            look_alikes["parameters"].setdefault(member, fit.cause.parameters(fit.theta, fit.params))
        settling = settle(ctx, baseline, fitted, members[0], result.block_seconds / 4.0,
                          observed, look_alikes["threshold"], 1 if on_tracks else 2)
        result.seconds["settling"] = time.perf_counter() - t_settle
        if settling is not None:
            settling["predictions"] = _write_predictions(settling.pop("predictions"), out_dir)
        if settling is not None and named != OUTSIDE:
            rival = min(settling["evidence"], key=settling["evidence"].get)
            closest = settling["evidence"][rival]
            gain = min(settling["ratio"][settling["manoeuvre"]].values())
            expected = (f"expected evidence {closest:.2f} over the closest look-alike once added, "
                        f"{settling['needed']:.2f} tells two causes apart" if closest > 0 else
                        f"the records give the named cause no edge over {rival} to build on")
            next_manoeuvre = "; ".join(
                [f"{settling['manoeuvre']} (computed by simulating every member: it separates them {gain:.1f} "
                 f"times as much as the training records do; {expected})"]
                + [m for _, m in undecidable])
    cause = best.cause if best is not baseline else NoCause()
    notes = list(prepared.notes)
    if named == OUTSIDE:
        notes.append(_outside_note(beyond, inferred, inferred_whole))
    elif beyond is not None:
        gained = (f"whole-record gain {whole['gain_pct']:.1f} %, 90 % interval "
                  f"[{whole['interval'][0]:.1f}, {whole['interval'][1]:.1f}] %" if whole else
                  f"windowed gain {gain_pct(b_window, e_window):.1f} %: every held-out record is a zig-zag")
        notes.append(f"the held-out records go beyond the training records in "
                     f"{', '.join(beyond['states'])}, where {inferred} predicts them better all the same ({gained})")
    if on_tracks:
        notes.append(f"{len(result.variants)} single-cause variants compared by their likelihood on the "
                     f"tracks of {len(raw)} records (the baseline's Kalman filter's one-step-ahead "
                     f"predictions, {result.n_rows} measured innovations, clustered in {result.n_blocks} "
                     f"stretches of {result.block_seconds:.0f} s); the verdict of highest BIC weight is "
                     f"named; probability of beating none: "
                     + ", ".join(f"{k} {v:.3f}" for k, v in sorted(result.beats_none.items(),
                                                                   key=lambda kv: -kv[1])))
        reading = result.filter_reading
        notes.append(f"the filter steps {reading['step_s']:.2f} s, the velocities "
                     + ("measured" if reading["velocities_measured"] else "inferred from the track")
                     + "; its process noise is "
                     + (f"coloured: disturbances that last {reading['correlation_time_s']:.0f} s (correlation "
                        "time, by maximum likelihood; white was less likely)" if reading["process_noise"] == "coloured"
                        else "white (a correlated disturbance was not more likely)"))
    else:
        notes.append(f"{len(result.variants)} single-cause variants compared on {len(raw)} records cut into "
                     f"{result.n_blocks} blocks of {result.block_seconds:.0f} s, each block predicted by models "
                     f"fitted to the others; a cause is named when its held-out gain exceeds "
                     f"{result.threshold:.2f} standard errors; probability of beating none: "
                     + ", ".join(f"{k} {v:.3f}" for k, v in sorted(result.beats_none.items(),
                                                                   key=lambda kv: -kv[1])))
    if best is not baseline and best.cause.replaces_dynamics:
        notes.append(f"{named} replaces the baseline's process model (the MMG model: thrust from the measured rpm, "
                     "the rudder in the slipstream), so no second cause is judged beside it: run the discovery "
                     "with model=mmg to judge the catalogue on that model")
    if stated and injected is None:
        notes.append("discover.injected is scored on the tracks' criterion only (discover.judge=tracks); "
                     "it was not scored")
    elif injected is not None:
        notes.append(_injected_note(injected))
    said = _alike_note(named, result.alike)
    if said:
        notes.append(said)
    if look_alikes is not None and len(look_alikes["class"]) > 1:
        notes.append(_class_note(look_alikes))
    for cid, manoeuvre in undecidable:
        notes.append(f"{cid} is not compared: the training records cannot decide it ({manoeuvre} would)")
    if best is not baseline and best.validation.get("diverged"):
        notes.append(f"the named model's replay diverges on {', '.join(best.validation['diverged'])}")
    other = [on_record_time(prepared.simulation, rec) if prepared.simulation is not None else None
             for rec in ctx.validation]
    if prepared.simulation is not None and all(o is None for o in other):
        notes.append(f"simulation.path ({prepared.simulation.attrs.get('name')}) not judged: its time span or "
                     "rudder matches no validation record")
    models = {"baseline": whole_base["predictions"]}
    if best is not baseline:
        models[f"extended ({named})"] = whole_best["predictions"]
    if any(o is not None for o in other):
        models["other simulator"] = other
    departed = departures(ctx.validation, models, prepared.vessel)
    gain = whole["gain_pct"] if whole else gain_pct(b_rmse, e_rmse)
    error_units = ("m (position RMSE of the whole held-out " + ", ".join(judged["judged"]) + " replayed)" if whole else
             "m (position RMSE over prediction windows: every held-out record is a zig-zag, whose whole "
             "open-loop replay measures the replay rather than the model)")
    if best is not baseline and judged["worse"]:
        notes.append(f"the extension predicts the held-out records worse than the baseline on "
                     f"{'; '.join(judged['worse'])}: the records' evidence for the cause lies in motions the "
                     "held-out records do not repeat, or the cause is wrong; weigh the confidence against this")
    if named == OUTSIDE:
        parameters = {"states": {k: [v["training"], v["held_out"]] for k, v in beyond["states"].items()},
                      "manoeuvre": beyond["manoeuvre"]}
        units = {"states": {k: v["unit"] for k, v in beyond["states"].items()}}
        uncertainty, fixed = {}, {}
    else:
        parameters = result.fit.cause.parameters(result.fit.theta, result.fit.params) if result.named else {}
        units, fixed = dict(cause.units), cause.fixed_parameters()
        uncertainty = intervals(result, seed=prepared.cfg.seed)
    discovery = Discovery(
        cause=named,
        parameters=parameters,
        parameter_units=units, fixed_parameters=fixed,
        uncertainty=uncertainty, confidence=confidence,
        confidence_basis=(("probability that the records' cause is one of the class (the sum of its members' "
                           "probabilities, each: " + _basis(on_tracks) + ")")
                          if look_alikes is not None and len(look_alikes["class"]) > 1 else
                          ("none: the verdict is a measurement, the share of the baseline's departure from the "
                           "held-out records that lies beyond the training records' states "
                           f"({100 * beyond['departure_share']:.0f} %)") if named == OUTSIDE else
                          ("posterior probability of the verdict from the BIC of the tracks' likelihood "
                           "(the baseline's Kalman-filter innovations; the likelihood ratio, or the Wald "
                           "statistic robust to correlated innovations where smaller), uniform prior over "
                           "none, the single causes and the second causes beside the first")
                          if on_tracks else
                          ("share of the Bayesian-bootstrap reweightings of the records' blocks for which "
                           "the criterion names this verdict (held-out gain beyond the Bonferroni quantile "
                           "of its standard error, leave-one-block-out cross-validation)")),
        inclusion={k: float(v) for k, v in sorted(result.inclusion.items(), key=lambda kv: -kv[1])},
        ranking=ranking[:12],
        baseline={"validation_rmse": b_rmse, "validation_rmse_windowed": b_window, "training_rmse": b_train},
        extended={"validation_rmse": e_rmse, "validation_rmse_windowed": e_window, "training_rmse": e_train},
        gain_pct=gain, explains_validation=bool(explained),
        gain_interval_pct=list(whole["interval"]) if whole else None,
        gain_windowed_pct=gain_pct(b_window, e_window),
        held_out={"characteristics": judged["characteristics"], "worse": judged["worse"],
                  "judged": judged["judged"], "zigzags_left_to_the_windowed_error": judged["not_judged"]},
        units=error_units,
        outside_training=beyond, inference_verdict=inferred,
        look_alikes=look_alikes["class"] if look_alikes else None, settling=settling,
        class_parameters=look_alikes["parameters"] if look_alikes else {},
        class_probability=look_alikes["probability"] if look_alikes else None,
        class_evidence=({k: look_alikes[k] for k in ("evidence", "threshold", "measure")} if look_alikes else {}),
        detection_limits=limits,
        detection_units={cid: dict(by_id[cid].units) for cid in limits if cid in by_id},
        explanation=(OUTSIDE_EXPLANATION if named == OUTSIDE else
                     cause.explanation if named != "none" else NoCause.explanation),
        baseline_model=str(prepared.cfg.model.name), scale=_scale(prepared, dynamics),
        method="tracks" if on_tracks else "inference",
        undecided=undecided, next_manoeuvre=next_manoeuvre, notes=notes,
        candidates=candidates,
        candidates_beside={cid: (f.cause.parameters(f.theta, f.params) or {}).get(cid, {})
                           for cid, f in result.beside.items()},
        evidence={"margin": {k: float(v) for k, v in result.evidence.items()}, "measure": _measure(on_tracks),
                  "threshold": float(result.threshold),
                  "second_threshold": (float(result.second_threshold) if np.isfinite(result.second_threshold)
                                       else None)},
        departures=(departed.groupby("model", sort=False).head(DEPARTURES).to_dict("records")
                    if not departed.empty else []),
        alike=_rounded_alike(result.alike),
        seconds={"smoothing": t_smooth, "inference": t_infer, **{k: float(v) for k, v in result.seconds.items()},
                 "total": time.perf_counter() - t0})
    discovery.injected = injected
    if opts.splits:
        discovery.splits = held_out_in_turn(prepared, smoothed, raw, model, dynamics,
                                            result.fit if result.named else None, inferred)
    out = discovery.to_dict()
    say("discover: writing the report and its figures")
    sections, figures = _sections(ctx, result, whole_base, whole_best, named, out_dir, on_tracks, other, departed,
                                  discovery.splits, judged, beyond, settling)
    write_discovery(out_dir / "discovery.json", out)
    write_report(out_dir, out, out["explanation"], sections, figures)
    metrics = {"discover/gain_pct": gain, **({"discover/confidence": confidence} if confidence is not None else {}),
               "discover/baseline_validation_rmse": b_rmse, "discover/extended_validation_rmse": e_rmse,
               "discover/baseline_validation_rmse_windowed": b_window,
               "discover/extended_validation_rmse_windowed": e_window,
               "discover/outside_training_states": float(named == OUTSIDE),
               "discover/baseline_training_rmse": b_train, "discover/extended_training_rmse": e_train,
               "discover/explains_validation": float(explained), "discover/blocks": float(result.n_blocks),
               "discover/n_variants": float(len(result.variants)), "runtime/total_s": time.perf_counter() - t0}
    for cid, p in result.inclusion.items():
        metrics[f"discover/inclusion/{cid}"] = float(p)
    for cid, t in result.evidence.items():
        if "+" not in cid:
            metrics[f"discover/evidence/{cid}"] = float(t)
    return out, metrics


def held_out_in_turn(prepared: PreparedDiscovery, smoothed: list, raw: list, model, dynamics, named_fit,
                     named: str) -> list[dict]:
    """Every record held out in turn (``discover.splits``): the baseline and
    the named model (its cause refined again from the verdict's parameters)
    identified on the other records and replayed on the held-out one. Shows
    whether the named model's gain holds on every manoeuvre, or on the one
    that happened to be held out (the verdict itself comes from every
    record). ``smoothed``/``raw``: every record smoothed and as measured, in
    the same order."""
    rows = []
    for k, held in enumerate(raw):
        others = [r for j, r in enumerate(smoothed) if j != k]
        split = Context(prepared.vessel, model, others, [held], "recorded", dynamics=dynamics)
        split.horizon = prepared.cfg.discover.horizon or None
        calibrate(split)
        base = baseline_fit(split)
        ext = refine(split, named_fit.cause, named_fit.theta) if named_fit is not None else base
        validate(split, base)
        if ext is not base:
            validate(split, ext)
        b, e = base.validation_rmse, ext.validation_rmse
        own = training_error(split, ext)
        rows.append({"held_out": str(held.attrs.get("name", f"record {k + 1}")), "cause": named,
                     "parameters": ext.cause.parameters(ext.theta, ext.params) if ext is not base else {},
                     "baseline_validation_rmse": b, "extended_validation_rmse": e, "gain_pct": gain_pct(b, e),
                     "training_rmse": own, "explains_validation": bool(dg.explains(e, own, prepared.vessel.length)),
                     "diverges": list(ext.validation.get("diverged") or [])})
        log.info("holding out %s: %s gains %.1f %%", rows[-1]["held_out"], named, rows[-1]["gain_pct"])
    return rows


#: the columns of a member's prediction of the recommended manoeuvre (the data contract's)
PREDICTION_COLUMNS = ("t", "x0", "y0", "psi", "u", "v", "r", "delta", "n")


def _write_predictions(predictions: dict, out_dir: Path) -> dict:
    """Each member's prediction of the recommended manoeuvre as a record under
    ``settling/`` (a test run of it is compared with them); ``{member: file}``."""
    folder = out_dir / "settling"
    folder.mkdir(parents=True, exist_ok=True)
    out = {}
    for member, record in predictions.items():
        path = folder / f"{member.replace('+', '_and_')}.csv"
        record[[c for c in PREDICTION_COLUMNS if c in record]].to_csv(path, index=False)
        out[member] = f"settling/{path.name}"
    return out


def _member_fits(result, members: list, ctx: Context) -> dict:
    """``{member verdict id: CauseFit}`` of the class's members: those the judge
    refined, and a pair the judge did not refine refined here on the training
    records (``ctx``) from its two causes' own fits."""
    from ..discovery.inference import _joined_theta, _model_cause, _pair_id

    fits = {f.cause.id: f for m, f in result.fits.items() if len(m) == 1}
    if result.fit is not None:
        fits[result.verdict_of(result.named)] = result.fit
    if len(result.named) == 2:
        first = result.variants[result.named[0]].cause.id
        for cid, fit in (getattr(result, "pair_fits", None) or {}).items():
            fits.setdefault(_pair_id(first, cid), fit)
        singles = {result.variants[m[0]].cause.id: m[0] for m in result.fits if len(m) == 1}
        for member in members:
            parts = member.split("+")
            second = next((c for c in parts if c != first), None)
            if member in fits or second not in singles or first not in singles:
                continue
            pair = (singles[first], singles[second])
            start = _joined_theta(result.variants, pair, {i: result.fits[(i,)].theta for i in pair})
            fits[member] = refine(ctx, _model_cause(result.variants, pair), start)
    return {m: fits[m] for m in members if m in fits}


def _class_note(look_alikes: dict) -> str:
    """The class of look-alikes in one sentence: who is in it, and by how much the records fall short."""
    members = look_alikes["class"]
    gaps = ", ".join(f"{m} {look_alikes['evidence'][m]:+.2f}" for m in members[1:] if m in look_alikes["evidence"])
    return (f"the records cannot tell {members[0]} from {', '.join(members[1:])}: its evidence over each ({gaps}) "
            f"is below the {look_alikes['threshold']:.2f} that tells two causes apart ({look_alikes['measure']}); "
            f"the class's probability is {look_alikes['probability']:.2f}")


def _basis(on_tracks: bool) -> str:
    """How a member's probability is computed, in a few words."""
    return ("its BIC weight on the tracks" if on_tracks else
            "the share of the bootstrap reweightings of the blocks that name it")


def _injected_note(injected: dict) -> str:
    """The stated effect's score in one sentence (:mod:`studies.discovery.stated_effect`)."""
    what = f"the injected {injected['causes']}"
    line = (f"{what} scores {injected['score']:+.1f} on these records at its stated parameters (evidence "
            f"{injected['evidence']:.1f} against a penalty of {injected['penalty']:.1f})")
    for cid, m in (injected.get("members") or {}).items():
        line += f"; {cid} beside the other {m['score']:+.1f}"
    if injected["shown"]:
        return line + ": the records can show it"
    return (line + ": even exactly as injected it does not beat none by this criterion, so no verdict of it "
            "can name it on these records")


def _measure(on_tracks: bool) -> str:
    """What a cause's margin in ``evidence`` is."""
    if on_tracks:
        return ("BIC score over none of the tracks' likelihood (evidence less k ln n less 2 ln of the "
                "cause's variants)")
    return "held-out gain over its standard error (blocks left out in turn)"


def _copy(fit):
    from dataclasses import replace
    return replace(fit)


def _sections(ctx, result, whole_base: dict, whole_best: dict, named: str, out_dir: Path,
              on_tracks: bool = False, other: list | None = None, departed: pd.DataFrame | None = None,
              splits: list | None = None, judged: dict | None = None, beyond: dict | None = None,
              settling: dict | None = None):
    """The report's tables and figures: verdicts, inclusion probabilities,
    where the replays depart most from the held-out records, every record
    held out in turn, predictions of every held-out record (with another
    simulator's run of it, ``other``), their phase errors and manoeuvre
    characteristics."""
    other = other or [None] * len(ctx.validation)
    ranking = pd.DataFrame(result.ranking()[:12]).set_index("cause")
    inclusion = pd.DataFrame({"probability": result.inclusion}).sort_values("probability", ascending=False)
    inclusion.index.name = "cause"
    if on_tracks:
        sections = [("Verdicts compared (probability: BIC weight of the tracks' likelihood; gain: half the "
                     "BIC score over none; score: -2 ln of the probability relative to the most probable)",
                     ranking),
                    ("Probability of each cause (alone or in a pair)", inclusion)]
    else:
        sections = [("Verdicts compared (probability: share of the bootstrap reweightings of the blocks that "
                     "name it; gain: held-out log-likelihood gain over none, summed over the blocks; score: -2 ln "
                     "of the probability relative to the most probable)", ranking),
                    ("Share of the bootstrap reweightings naming each cause (alone or in a pair)", inclusion)]
    if result.alike:
        sections.append((f"How alike the causes' signatures are on these records ({ALIKE_READING}; a cause "
                         "with variants at its variant most alike)", alike_table(result.alike)))
    if settling:
        table = pd.DataFrame(settling["ratio"]).T
        table.index.name = "manoeuvre"
        sections.append((f"The test that would settle the class: each standard manoeuvre's separation of the named "
                         f"member from each look-alike, over the training records' own (every member replays the "
                         f"manoeuvre as the baseline steers it); recommended: {settling['manoeuvre']}; each member's "
                         "prediction of it in settling/", table.round(2)))
    if departed is not None and not departed.empty:
        sections.append(("Where the simulation departs most from the held-out records (whole replays; u, v in "
                         "m/s, r in deg/s; ranked by the prime RMSE)", departed.set_index("model")))
    if beyond is not None:
        states = pd.DataFrame([{"state": v["meaning"], "unit": v["unit"], "training from": v["training"][0],
                                "training to": v["training"][1], "held out from": v["held_out"][0],
                                "held out to": v["held_out"][1], "share of samples beyond": v["share"]}
                               for v in beyond["states"].values()]).set_index("state")
        sections.append((f"Where the held-out records leave the training records' states ("
                         f"{100 * beyond['departure_share']:.0f} % of the baseline's departure lies there; ranges: "
                         "the 0.5 and 99.5 % quantiles)", states))
    if judged and judged["characteristics"] and named not in ("none", OUTSIDE):
        rows = pd.DataFrame(judged["characteristics"]).set_index("record")
        sections.append(("The held-out manoeuvres' characteristics: each model's error (prediction minus "
                         "measurement; advance and tactical diameter in m, overshoots in deg; worse: the "
                         "extension's error exceeds the baseline's beyond the reported resolution)", rows))
    if splits:
        table = pd.DataFrame(splits).set_index("held_out")
        table["parameters"] = [compact_parameters(p) for p in table["parameters"]]
        table["diverges"] = [", ".join(d) for d in table["diverges"]]
        sections.append(("Every record held out in turn (the baseline and the named model identified on the "
                         "others; validation: windowed position RMSE, m)", table))
    figures, phase_tables, char_tables = [], [], []
    for rec, pb, pe, sim in zip(ctx.validation, whole_base["predictions"], whole_best["predictions"], other):
        name = str(rec.attrs.get("name", "record"))
        preds = {"baseline": pb}
        if named not in ("none", OUTSIDE):
            preds[f"extended ({named})"] = pe
        if sim is not None:
            preds["other simulator"] = sim
        fig = f"prediction_{name}.png"
        draw(plot_predictions, rec, preds, f"{name}: measured vs predicted", out_dir / fig)
        figures.append(fig)
        phase_tables.append(dg.phase_errors(rec, pb, name).assign(model="baseline"))
        if named not in ("none", OUTSIDE):
            phase_tables.append(dg.phase_errors(rec, pe, name).assign(model="extended"))
        if sim is not None:
            phase_tables.append(dg.phase_errors(rec, sim, name).assign(model="other simulator"))
        char_tables.append(dg.characteristic_table(rec, preds, name))
    if phase_tables:
        sections.append(("Prediction error per manoeuvre phase (u, v in m/s, r in deg/s)",
                         pd.concat(phase_tables, ignore_index=True)))
    for table in char_tables:
        if not table.empty:
            sections.append((f"Manoeuvre characteristics: {table.index.name}", table))
    draw(plot_evidence, result.evidence, result.threshold, result.second_threshold, named, out_dir / "ranking.png",
                  _measure(on_tracks))
    figures.append("ranking.png")
    return sections, figures
