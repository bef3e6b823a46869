"""``studies discover model=roll``: what a roll-decay simulation gets wrong.

The baseline is the linear decay model fitted to the other simulator's run
(``simulation.path``, with ``omega0`` and ``b1`` then held) or to the
training decays; every roll cause of :mod:`studies.discovery.causes.roll_decay` extends it
and is judged on the held-out decays: the last of two or more records, or,
with one record, its later cycles (time-blocked, the last
``discover.holdout`` share of the half-cycles, predicted from the start
that fits their first periods). :func:`prepare_roll_discovery` loads every decay before any
tracked run exists; :func:`execute_roll_discovery` writes ``discovery.json``,
``report.md``/``report.html``, the peak envelopes, the decay curves, the
equivalent linear damping at 5 and 10 deg, the periods at model and full
scale and, given decays at two or more speeds, the damping against speed.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pandas as pd

from ...config import DiscoverConfig
from ...discovery.diagnostics import explains
from ...discovery.confidence import certainty
from ...discovery.report import indistinguishable, write_discovery, write_report
from ...discovery.causes.roll_decay import PARAMETER_UNITS
from .search import peak_decay, predict_from_fitted_start, roll_interval, roll_search
from ...errors import ConfigError
from ..decay import decay_curve, fit_decay_curve
from ..figures import plot_decay_curves, plot_peak_envelope
from ..model import damping_ratio, equivalent_linear_damping, froude_scale_params
from ..records import load_roll_decay, record_vessel, split_cycles
from ..speed import fit_speed_dependence, speeds_of
from ...workflows.settings import as_path_list
from ...workflows.protocol import PreparedDiscovery, Recorder, StudyKind, gain_pct

__all__ = ["prepare_roll_discovery", "execute_roll_discovery", "damping_table"]

#: roll amplitudes [deg] at which the equivalent linear damping is reported
DAMPING_AMPLITUDES_DEG = (5.0, 10.0)


def prepare_roll_discovery(cfg: DiscoverConfig, root: Path, kind: StudyKind,
                           record: Recorder | None = None) -> PreparedDiscovery:
    """Load every decay (raises ConfigError/DataError). Without ``validate.path``
    the last of two or more decays is held out; of a single decay its later
    cycles (the last ``discover.holdout`` share of its half-cycles)."""
    data = as_path_list(cfg.data.path)
    if not data:
        raise ConfigError("discover needs measured records: data.path=FILE or data.path=[a,b]")
    validate = as_path_list(cfg.validate.path)
    simulation = cfg.simulation.path
    train = [load_roll_decay(p) for p in data]
    val = [load_roll_decay(p) for p in validate]
    sim = load_roll_decay(str(simulation)) if simulation else None
    prepared = PreparedDiscovery(cfg, kind, None, None, train, val, sim, records=train + val)
    if not val:
        if len(train) >= 2:
            prepared.train, prepared.validation = train[:-1], train[-1:]
            prepared.notes.append(f"held out the decay {train[-1].attrs.get('name')}")
        else:
            share = cfg.discover.holdout
            try:
                first, last = split_cycles(train[0], share)
            except ValueError as error:
                raise ConfigError(f"roll discover on one decay holds out its later cycles: {error}; "
                                  "give a second decay (validate.path)") from None
            prepared.train, prepared.validation = [first], [last]
            n = int(train[0].attrs.get("n_extrema", 0))
            prepared.notes.append(
                f"one decay: held out its later cycles (time-blocked), the last {last.attrs['n_extrema']} of "
                f"{first.attrs['n_extrema'] + last.attrs['n_extrema']} half-cycles of {train[0].attrs.get('name')} "
                f"(discover.holdout={share:g}) from {last.attrs['t_from_release']:.1f} s after the release, "
                f"predicted from the start that fits their first periods; the causes are fitted to the first "
                f"{first.attrs['n_extrema']} ({n} extrema in the record)")
    return prepared


def _scale(records) -> tuple[float | None, dict | None]:
    """Geometric scale of the records (1 = full scale) and the full-scale particulars, when known."""
    for rec in records:
        part = rec.attrs.get("particulars")
        if part and part.get("full"):
            return float(part.get("scale", 1.0)), dict(part["full"])
    return None, None


def damping_table(models: dict, scale: float | None, full: dict | None) -> pd.DataFrame:
    """Equivalent linear damping of each model at 5 and 10 deg, and its natural period.

    Parameters
    ----------
    models : dict
        Label -> parameters at the records' scale (``omega0`` [rad/s], ``b1``
        [1/s], optional ``b2`` [-], ``b3`` [s]).
    scale : float or None
        Geometric scale of the records (68 = model 1:68, 1 = full scale).
    full : dict or None
        Full-scale particulars (``displacement`` [m^3], ``gm`` [m], ``rho``
        [kg/m^3], ``g`` [m/s^2]); without them no dimensional damping.

    Returns
    -------
    DataFrame
        One row per model: ``T0_model_s`` (2 pi / omega0 at the records'
        scale), with the scale ``T0_full_s`` (Froude-scaled), ``zeta_<a>deg`` [-] (the
        equivalent linear damping ratio b_eq / (2 omega0)), and with the
        particulars ``B44_<a>deg_full_Nms`` and ``B44_<a>deg_model_Nms``
        [N m s/rad] (b_eq times the total roll inertia C44 / omega0^2, with
        C44 = rho g V GM at each scale).
    """
    rows = {}
    lam = scale if scale else 1.0
    for label, p in models.items():
        w0 = float(p["omega0"])
        row = {"T0_model_s": 2 * math.pi / w0}
        if scale:
            row["T0_full_s"] = 2 * math.pi / w0 * math.sqrt(lam)
        for a in DAMPING_AMPLITUDES_DEG:
            row[f"zeta_{a:g}deg"] = damping_ratio(p, math.radians(a))
        if full:
            pf = froude_scale_params(p, lam, "full")
            c44_full = full["rho"] * full["g"] * full["displacement"] * full["gm"]
            c44_model = c44_full / lam ** 4
            for a in DAMPING_AMPLITUDES_DEG:
                row[f"B44_{a:g}deg_full_Nms"] = (equivalent_linear_damping(pf, math.radians(a))
                                                 * c44_full / pf["omega0"] ** 2)
                row[f"B44_{a:g}deg_model_Nms"] = (equivalent_linear_damping(p, math.radians(a))
                                                  * c44_model / w0 ** 2)
        rows[label] = row
    table = pd.DataFrame(rows).T
    table.index.name = "model"
    return table


def _measured_damping(records) -> dict | None:
    """``omega0``, ``b1``, ``b2`` of the decay curves of ``records`` (linear least squares), None
    when too short."""
    curves = [decay_curve(r) for r in records]
    curve = pd.concat([c for c in curves if len(c)], ignore_index=True) if any(len(c) for c in curves) else None
    if curve is None or len(curve) < 4:
        return None
    return fit_decay_curve(curve, ("b1", "b2"))


def _baseline_text(prepared: PreparedDiscovery, base: dict) -> str:
    p = base["params"]
    values = f"omega0 = {p['omega0']:.4g} rad/s, b1 = {p['b1']:.4g} 1/s"
    if prepared.simulation is not None:
        return (f"The baseline is the linear model phi'' + b1 phi' + omega0^2 phi = 0 fitted (simulation least "
                f"squares) to the other simulator's run {prepared.simulation.attrs.get('name')} "
                f"(simulation.path): {values}. omega0 and b1 are held there; each cause adds its terms, fitted "
                "to the measured training decays, so the causes say what that simulation misses "
                "(roll_linear_damping's b1_added is added to its b1).")
    return (f"The baseline is the linear model phi'' + b1 phi' + omega0^2 phi = 0 fitted to the measured "
            f"training decays: {values}. Each cause adds its terms and is fitted with omega0 and b1 again free "
            "(the linear-damping causes are therefore not tried: the baseline's own b1 already holds them).")


def _units_table(discovery: dict, best: dict) -> pd.DataFrame:
    rows = []
    unc = discovery.get("uncertainty") or {}
    for name, value in best["added"].items():
        lo, hi = (unc.get(name) or [np.nan, np.nan])
        rows.append({"parameter": name, "value": value, "5 %": lo, "95 %": hi,
                     "unit": PARAMETER_UNITS.get(name, "")})
    for name, value in best["params"].items():
        rows.append({"parameter": f"{name} (extended model)", "value": value, "5 %": np.nan, "95 %": np.nan,
                     "unit": PARAMETER_UNITS.get(name, "")})
    return pd.DataFrame(rows).set_index("parameter")


def _predictions(prepared: PreparedDiscovery, base: dict, best: dict, extended: str) -> tuple[list, list]:
    """Every record (validation first) and its predictions ``{label: (t, phi)}``, simulated once,
    each from the record's fitted start (as the search judges them)."""
    records = prepared.validation + prepared.train
    predicted = []
    for rec in records:
        t = rec["t"].to_numpy(float)
        preds = {"baseline": (t, predict_from_fitted_start(base["params"], base["terms"], rec))}
        if best is not base:
            preds[extended] = (t, predict_from_fitted_start(best["params"], best["terms"], rec))
        if prepared.simulation is not None:
            # the other simulator's run on the record's own time since the release
            shift = float(rec.attrs.get("t_from_release", 0.0))
            ts = prepared.simulation["t"].to_numpy(float) - shift
            keep = ts >= -1e-9
            preds["other simulator"] = (ts[keep], prepared.simulation["phi"].to_numpy(float)[keep])
        predicted.append(preds)
    return records, predicted


def execute_roll_discovery(prepared: PreparedDiscovery, out_dir: Path) -> tuple[dict, dict]:
    """Run the discovery on roll decays; ``(discovery, metrics)``."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    res = roll_search(prepared.train, prepared.validation, prepared.simulation)
    best, base = res["best"], res["baseline"]
    params = {k: float(v) for k, v in best["added"].items()}
    interval = roll_interval(best, prepared.train, res["simulation_params"],
                             seed=prepared.cfg.seed) if params else {}
    b, e = base["validation_rmse_deg"], best["validation_rmse_deg"]
    b_train, e_train = (float(np.degrees(np.sqrt(np.mean(f["resid"] ** 2)))) for f in (base, best))
    release = float(np.degrees(np.mean([abs(r["phi"].iloc[0]) for r in prepared.validation])))
    explained = explains(e, e_train, release)
    ranked = sorted(res["fits"], key=lambda f: f["score"])
    extended = f"extended ({best['cause']})"
    records, predicted = _predictions(prepared, base, best, extended)
    peaks = [peak_decay(rec, preds) for rec, preds in zip(records, predicted)]
    explanation = best["explanation"] if explained or params else (
        "No roll term in the catalogue gains on the held-out decay, yet the model does not explain it: its "
        "error there is many times that on the decay it was fitted to.")
    scale, full = _scale(prepared.records + ([prepared.simulation] if prepared.simulation is not None else []))
    vessel, vessel_source = record_vessel(next((r.attrs.get("particulars") for r in prepared.records
                                                if r.attrs.get("particulars")), None))
    models = {"baseline": base["params"]}
    if best is not base:
        models[extended] = best["params"]
    measured = _measured_damping(prepared.train)
    damping = damping_table({**models, **({"measured (decay curve of the training decays)": measured}
                                          if measured else {})}, scale, full)
    speed = fit_speed_dependence(prepared.records)
    baseline_text = _baseline_text(prepared, base)
    discovery = {
        "cause": best["cause"], "parameters": params, "uncertainty": interval,
        "parameter_units": {k: PARAMETER_UNITS.get(k, "") for k in params},
        "explanation": explanation,
        "baseline": {"validation_rmse": b, "training_rmse": b_train, "params": base["params"],
                     "source": "simulation.path" if prepared.simulation is not None else "data",
                     "definition": baseline_text},
        "extended": {"validation_rmse": e, "training_rmse": e_train, "params": best["params"]},
        "params_units": {k: PARAMETER_UNITS.get(k, "") for k in best["params"]},
        "explains_validation": explained,
        "gain_pct": gain_pct(b, e), "units": "deg (roll angle RMSE)",
        "holdout": ("later cycles of the one decay (time-blocked)" if any("t_from_release" in r.attrs
                                                                           for r in prepared.validation)
                    else "whole decays"),
        "ranking": [{"cause": f["cause"], "score": float(f["score"] - ranked[0]["score"]),
                     "validation_rmse": f["validation_rmse_deg"]} for f in ranked],
        "second_cause": None, "notes": list(prepared.notes),
        "peak_decay": {table.index.name: table.to_dict("index") for table in peaks},
        "damping": {"scale": scale, "amplitudes_deg": list(DAMPING_AMPLITUDES_DEG),
                    "units": {"T0": "s", "zeta": "-", "B44": "N m s/rad"},
                    "models": damping.to_dict("index")},
        "vessel": {"name": vessel, "source": vessel_source},
        "scale": ("full" if scale == 1 else "model") if scale else "unknown",
        "scale_ratio": scale,
        "speeds": dict(zip([str(r.attrs.get("name")) for r in prepared.records], speeds_of(prepared.records))),
    }
    if speed is not None:
        discovery["speed_dependence"] = speed.as_dict()
    trained_at = {u for u in speeds_of(prepared.train) if u is not None}
    if len(trained_at) > 1:
        discovery["notes"].append(
            f"the training decays are at {len(trained_at)} speeds ({', '.join(f'{u:g}' for u in sorted(trained_at))} "
            "m/s): the cause's parameters are one value for all of them; the damping against speed is below")
    discovery["indistinguishable_from"] = indistinguishable(discovery["ranking"], discovery["cause"])
    certainty(discovery)
    discovery["notes"].append(f"vessel {vessel}, from the {vessel_source}" if vessel else
                              f"vessel not known from the data: {vessel_source}")
    figures = _figures(out_dir, records, predicted, prepared, models)
    sections = [("Baseline", baseline_text),
                ("Parameters (90 % interval; angles in rad)", _units_table(discovery, best)),
                ("Equivalent linear damping and natural period (zeta = b_eq / (2 omega0); B44 = b_eq C44 / "
                 "omega0^2 in N m s/rad; " + (f"model scale 1:{scale:g})" if scale else "scale of the records unknown: "
                                                       "no particulars beside them)"), damping)]
    if speed is not None:
        per = pd.DataFrame(speed.as_dict()["per_speed"]).set_index("speed")
        sections.append((f"Damping against speed: b1(U) = {speed.b1_0:.4g} + {speed.b1_U:.4g} U "
                         f"(b1 in 1/s, U in m/s), omega0 {speed.omega0:.4g} rad/s; b2 per speed", per))
    table = pd.DataFrame([{**{"cause": f["cause"], "score": f["score"] - ranked[0]["score"],
                              "validation_rmse_deg": f["validation_rmse_deg"]}, **f["params"]}
                          for f in ranked]).set_index("cause")
    sections.append(("Ranking and fitted parameters (omega0 rad/s, b1 1/s, b2 -, b3 s, c3 1/s^2)", table))
    sections += [(f"Roll peak decay: {p.index.name} (period s, peaks deg, time s)", p) for p in peaks]
    write_discovery(out_dir / "discovery.json", discovery)
    write_report(out_dir, discovery, explanation, sections, figures)
    metrics = {"discover/gain_pct": discovery["gain_pct"], "discover/baseline_validation_rmse": b,
               "discover/extended_validation_rmse": e, "discover/baseline_training_rmse": b_train,
               "discover/extended_training_rmse": e_train, "discover/explains_validation": float(explained),
               "runtime/total_s": time.perf_counter() - t0}
    return discovery, metrics


def _figures(out_dir: Path, records, predicted, prepared: PreparedDiscovery, models: dict) -> list[str]:
    """The peak envelopes and the decay curves; their file names."""
    panels = [(str(rec.attrs.get("name", "decay")) + (" (held out)" if i < len(prepared.validation) else ""),
               rec, preds) for i, (rec, preds) in enumerate(zip(records, predicted))]
    plot_peak_envelope(panels, str(out_dir / "peak_envelope.png"),
                       "Peak roll per half-cycle: measured (points), predictions from each decay's initial "
                       "state (lines)")
    curves = {f"measured {rec.attrs.get('name', 'decay')}": decay_curve(rec) for rec in records}
    if prepared.simulation is not None:
        curves["other simulator"] = decay_curve(prepared.simulation)
    plot_decay_curves(curves, str(out_dir / "decay_curves.png"), models,
                      "Decrement per half-cycle: measured (points), models (lines)")
    return ["peak_envelope.png", "decay_curves.png"]
