"""``studies discover model=roll``: what a roll-decay simulation gets wrong.

The baseline is the linear decay model fitted to the other simulator's run
(``simulation.path``) or to the training decays; every roll cause of
:mod:`studies.discover.roll` extends it and is judged on the held-out decay.
:func:`prepare_roll_discovery` loads every decay before any tracked run
exists; :func:`execute_roll_discovery` writes ``discovery.json``,
``report.md``/``report.html``, the decay curves and the peak decay tables.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from ..config import DiscoverConfig
from ..discover.diagnostics import explains
from ..discover.report import indistinguishable, write_discovery, write_report
from ..discover.roll import ROLL_CAUSES, peak_decay, roll_interval, roll_search
from ..errors import ConfigError
from ..plotting import pyplot
from ..roll.decay import decay_curve
from ..roll.figures import plot_decay_curves
from ..roll.records import load_roll_decay
from ..roll.simulate import predict_record
from .settings import as_path_list
from .study import DiscoverStudy, Recorder, Study, gain_pct

__all__ = ["prepare_roll_discovery", "execute_roll_discovery"]


def prepare_roll_discovery(cfg: DiscoverConfig, root: Path, kind: Study,
                           record: Recorder | None = None) -> DiscoverStudy:
    """Load every decay (raises ConfigError/DataError); without ``validate.path``
    the last of two or more decays is held out."""
    data = as_path_list(cfg.data.path)
    if not data:
        raise ConfigError("discover needs measured records: data.path=FILE or data.path=[a,b]")
    validate = as_path_list(cfg.validate.path)
    simulation = cfg.simulation.path
    train = [load_roll_decay(p) for p in data]
    val = [load_roll_decay(p) for p in validate]
    sim = load_roll_decay(str(simulation)) if simulation else None
    study = DiscoverStudy(cfg, kind, None, None, train, val, sim)
    if not val:
        if len(train) < 2:
            raise ConfigError("roll discover needs two decays (data.path=[a,b]) or validate.path")
        study.train, study.validation = train[:-1], train[-1:]
        study.notes.append(f"held out the decay {train[-1].attrs.get('name')}")
    return study


def execute_roll_discovery(study: DiscoverStudy, out_dir: Path) -> tuple[dict, dict]:
    """Run the discovery on roll decays; ``(discovery, metrics)``."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    res = roll_search(study.train, study.validation, study.simulation)
    best, base = res["best"], res["baseline"]
    term = ROLL_CAUSES[best["cause"]][0]
    params = {term: float(best["params"][term])} if term else {}
    interval = roll_interval(best, study.train, res["simulation_params"],
                             seed=int(study.cfg.seed)) if term else {}
    b, e = base["validation_rmse_deg"], best["validation_rmse_deg"]
    b_train, e_train = (float(np.degrees(np.sqrt(np.mean(f["resid"] ** 2)))) for f in (base, best))
    release = float(np.degrees(np.mean([abs(r["phi"].iloc[0]) for r in study.validation])))
    explained = explains(e, e_train, release)
    ranked = sorted(res["fits"], key=lambda f: f["score"])
    extended = f"extended ({best['cause']})"
    # every record (validation first) with its predictions, simulated once
    records = study.validation + study.train
    predicted = []
    for rec in records:
        t = rec["t"].to_numpy(float)
        preds = {"baseline": (t, predict_record(base["params"], base["terms"], rec))}
        if best is not base:
            preds[extended] = (t, predict_record(best["params"], best["terms"], rec))
        if study.simulation is not None:
            preds["other simulator"] = (study.simulation["t"].to_numpy(float),
                                        study.simulation["phi"].to_numpy(float))
        predicted.append(preds)
    peaks = [peak_decay(rec, preds) for rec, preds in zip(records, predicted)]
    explanation = best["explanation"] if explained or term else (
        "No roll term in the catalogue gains on the held-out decay, yet the model does not explain it: its "
        "error there is many times that on the decay it was fitted to.")
    discovery = {
        "cause": best["cause"], "parameters": params, "uncertainty": interval,
        "explanation": explanation,
        "baseline": {"validation_rmse": b, "training_rmse": b_train, "params": base["params"],
                     "source": "simulation.path" if study.simulation is not None else "data"},
        "extended": {"validation_rmse": e, "training_rmse": e_train, "params": best["params"]},
        "explains_validation": explained,
        "gain_pct": gain_pct(b, e), "units": "deg (roll angle RMSE)",
        "ranking": [{"cause": f["cause"], "score": float(f["score"] - ranked[0]["score"]),
                     "validation_rmse": f["validation_rmse_deg"]} for f in ranked],
        "second_cause": None, "notes": study.notes,
        "peak_decay": {table.index.name: table.to_dict("index") for table in peaks},
    }
    discovery["indistinguishable_from"] = indistinguishable(discovery["ranking"], discovery["cause"])
    figures = []
    plt = pyplot()
    for rec, preds in zip(records, predicted):
        name = str(rec.attrs.get("name", "decay"))
        fig, ax = plt.subplots(figsize=(10, 3.5))
        ax.plot(rec["t"], np.rad2deg(rec["phi"]), "k", lw=1.5, label="measured")
        for label, (t, phi) in preds.items():
            n = min(len(t), len(rec)) if label == "other simulator" else len(t)
            ax.plot(t[:n], np.rad2deg(phi[:n]), ":" if label == "other simulator" else "-", label=label)
        ax.set_xlabel("t [s]")
        ax.set_ylabel("roll [deg]")
        ax.legend(fontsize=8)
        ax.set_title(name)
        fig.tight_layout()
        fname = f"decay_{name}.png"
        fig.savefig(out_dir / fname, dpi=85)
        plt.close(fig)
        figures.append(fname)
    curves = {f"measured {rec.attrs.get('name', 'decay')}": decay_curve(rec) for rec in records}
    if study.simulation is not None:
        curves["other simulator"] = decay_curve(study.simulation)
    models = {"baseline": base["params"]}
    if best is not base:
        models[extended] = best["params"]
    plot_decay_curves(curves, str(out_dir / "decay_curves.png"), models,
                      "Decrement per half-cycle: measured (points), models (lines)")
    plt.close("all")
    figures.insert(0, "decay_curves.png")
    table = pd.DataFrame([{**{"cause": f["cause"], "score": f["score"] - ranked[0]["score"],
                              "validation_rmse_deg": f["validation_rmse_deg"]}, **f["params"]}
                          for f in ranked]).set_index("cause")
    sections = [("Ranking and fitted parameters", table)]
    sections += [(f"Roll peak decay: {p.index.name} (period s, peaks deg, time s)", p) for p in peaks]
    write_discovery(out_dir / "discovery.json", discovery)
    write_report(out_dir, discovery, explanation, sections, figures)
    metrics = {"discover/gain_pct": discovery["gain_pct"], "discover/baseline_validation_rmse": b,
               "discover/extended_validation_rmse": e, "discover/baseline_training_rmse": b_train,
               "discover/extended_training_rmse": e_train, "discover/explains_validation": float(explained),
               "runtime/total_s": time.perf_counter() - t0}
    return discovery, metrics
