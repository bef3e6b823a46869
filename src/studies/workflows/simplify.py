"""``studies simplify``: derive the simplified model from data and log how.

1. simulate the training manoeuvre of the vessel's reference model once;
2. for each of ``simplify.seeds`` independent seeds, identify the full model
   by LS (Savitzky-Golay derivatives) on ``realisations`` copies of it with
   measurement noise (Li et al. eq. 22, k0 = 5 %), and simulate
   ``pawn_samples`` PAWN samples per DOF around the median of all the
   estimates; realisations and PAWN samples of all seeds are pooled;
3. stability selection (Meinshausen & Buehlmann 2010): the paper's rule
   (:mod:`studies.models.simplified`: Spearman groups, the best of each
   group by PAWN above the DOF mean, Y and N united) on ``draws`` random
   subsets of the pool, each of one seed's size; a term's selection
   frequency is the fraction of draws that keep it, and the terms kept in
   more than ``frequency`` of them are the rule's result;
4. admissibility: what the rule removed and a manoeuvring model needs is
   put back, the most sensitive candidate first (selection frequency, then
   mean PAWN index), each addition with its reason: linear surge, sway and
   yaw damping (``Xu, Yv, Yr, Nv, Nr``), a surge term in ``v'``/``r'`` for the
   speed loss in turns, then, with the model identified on the training
   realisations, a positive straight-line stability index when the full
   model has one, a bounded simulation of the training manoeuvre and a
   speed loss of at least half the recorded one;
5. the model definition that ``model=simplified`` loads, with its
   stability index, and the analysis (selection frequencies, correlation
   matrices, how often coefficients share a group, PAWN indices, the
   comparison with the paper's eq. 23-25, term by term) as artifacts of one
   MLflow run.

References
----------
Meinshausen, N., Buehlmann, P. (2010). Stability selection. Journal of the
Royal Statistical Society B 72(4), 417-473.
"""

from __future__ import annotations

import dataclasses
import fcntl
import json
import time
from collections import Counter
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..config import RunConfig
from ..plotting import pyplot
from ..analysis.correlation import co_membership, correlated_groups, spearman_matrix
from ..analysis.pawn import PawnSamples, pawn_indices, pawn_samples, subsample_pawn
from ..environment.noise import add_measurement_noise
from ..identification import LeastSquares, build_problems
from ..models.abkowitz import ManoeuvringModel, abkowitz
from ..models.simplified import (PAPER_SIMPLIFIED, SPEED_LOSS, save_definition, select_terms,
                                 stability_index, structural_needs, twin, union_sway_yaw)
from ..simulate import simulate
from ..vessels import get_vessel
from .settings import named_manoeuvre
from .protocol import Recorder
from .vessel_choice import simulated_vessel

__all__ = ["derive", "ensure_definition"]

DOFS = ("X", "Y", "N")
#: realisations of each seed on which the simplified model is identified for the checks
CHECK_REALISATIONS = 5
#: the simplified model's speed loss in the training manoeuvre must reach this
#: fraction of the recorded one [-]
MIN_SPEED_LOSS_RATIO = 0.5
#: moving-average window that takes the noise off the recorded surge speed [s]
SPEED_SMOOTHING_S = 20.0


def _options(cfg: RunConfig) -> dict:
    return asdict(cfg.simplify)


@dataclass
class SeedSet:
    """What one seed contributes: LS estimates of the full model on its noisy
    realisations, the regression problems of the first ones (for the
    checks) and its first noisy record."""

    estimates: pd.DataFrame
    problems: list
    record: pd.DataFrame


def _seed_set(full: ManoeuvringModel, vessel, clean: pd.DataFrame, opts: dict,
              seq: np.random.SeedSequence) -> SeedSet:
    rng = np.random.default_rng(seq)
    rows, kept, first = [], [], None
    for k in range(int(opts["realisations"])):
        noisy = add_measurement_noise(clean, float(opts["noise"]), vessel.speed, rng)
        problems = build_problems(full, vessel, noisy, str(opts["derivative"]))
        rows.append(LeastSquares().fit(problems).params)
        if k < CHECK_REALISATIONS:
            kept.append(problems)
        first = noisy if first is None else first
    return SeedSet(pd.DataFrame(rows)[full.names], kept, first)


def _pawn_sets(full: ManoeuvringModel, nominal: dict, vessel, man, opts: dict,
               seq: np.random.SeedSequence) -> dict:
    """PAWN samples per DOF around ``nominal``: ``pawn_samples`` per seed,
    each seed's share drawn from its own stream, pooled."""
    out = {}
    for dof, child in zip(DOFS, seq.spawn(len(DOFS))):
        parts = [pawn_samples(full, nominal, vessel, man, dof, int(opts["pawn_samples"]),
                              float(opts["pawn_spread"]), seed=int(c.generate_state(1)[0]))
                 for c in child.spawn(int(opts["seeds"]))]
        out[dof] = PawnSamples(parts[0].names, parts[0].bounds, np.vstack([p.x for p in parts]),
                               np.concatenate([p.y for p in parts]), sum(p.diverged for p in parts))
    return out


def _rule(full: ManoeuvringModel, estimates: pd.DataFrame, sensitivity: dict, threshold: float):
    """The paper's rule on one draw: groups, the kept terms per DOF before and
    after the Y/N union."""
    groups, keep = {}, {}
    for dof in DOFS:
        rho = spearman_matrix(estimates[full.names_of(dof)])
        groups[dof] = correlated_groups(rho, threshold)
        keep[dof] = select_terms(groups[dof], sensitivity[dof])
    return groups, keep, union_sway_yaw(full, keep)


def _draws(full: ManoeuvringModel, estimates: pd.DataFrame, pawn: dict, opts: dict,
           seq: np.random.SeedSequence) -> list:
    """The rule on ``draws`` random subsets of the pooled realisations and
    PAWN samples, each of the size one seed gives (``realisations``,
    ``pawn_samples``), drawn without replacement: every draw is the paper's
    analysis at the paper's sizes, and how often it keeps a term does not
    hinge on the noise of one seed (stability selection, Meinshausen &
    Buehlmann 2010).

    Returns one dict per draw: ``groups``, ``before_union``, ``keep`` and
    ``pawn`` (indices per DOF).
    """
    out = []
    threshold = float(opts["threshold"])
    rng = np.random.default_rng(seq)
    n, size = len(estimates), min(len(estimates), int(opts["realisations"]))
    for d in range(int(opts["draws"])):
        rows = np.sort(rng.choice(n, size, replace=False))
        indices = {dof: subsample_pawn(pawn[dof], rng, int(opts["pawn_samples"])) for dof in DOFS}
        groups, before, keep = _rule(full, estimates.iloc[rows], indices, threshold)
        out.append({"draw": d, "groups": groups, "before_union": before, "keep": keep, "pawn": indices})
    return out


def _selection_table(full: ManoeuvringModel, draws: list) -> pd.DataFrame:
    """Per coefficient: DOF, selection frequency over the draws, and the mean
    and standard deviation of its PAWN index over the draws."""
    kept = np.array([[t.name in set(d["keep"][t.dof]) for t in full.terms] for d in draws])
    pawn = np.array([[d["pawn"][t.dof][t.name] for t in full.terms] for d in draws])
    table = pd.DataFrame({"dof": [t.dof for t in full.terms], "frequency": kept.mean(axis=0),
                          "pawn_mean": pawn.mean(axis=0), "pawn_sd": pawn.std(axis=0)},
                         index=pd.Index(full.names, name="name"))
    table["dof_mean_pawn"] = table.groupby("dof")["pawn_mean"].transform("mean")
    return table


def _modal_groups(draws: list) -> dict:
    """The partition into groups found most often, per DOF."""
    out = {}
    for dof in DOFS:
        counts = Counter(tuple(tuple(g) for g in d["groups"][dof]) for d in draws)
        out[dof] = [list(g) for g in counts.most_common(1)[0][0]]
    return out


def _subset_problems(problems: dict, keep: dict) -> dict:
    out = {}
    for dof, problem in problems.items():
        idx = [problem.names.index(n) for n in keep[dof]]
        out[dof] = dataclasses.replace(problem, theta=problem.theta[:, idx], names=list(keep[dof]))
    return out


def _identify(problem_sets: list, keep: dict) -> dict:
    """Median over realisations of the LS coefficients of the terms ``keep``."""
    fits = [LeastSquares().fit(_subset_problems(p, keep)).params for p in problem_sets]
    return pd.DataFrame(fits).median().to_dict()


def _speed_loss(u: np.ndarray, speed0: float, dt: float) -> float:
    """Largest drop of the (moving-averaged) surge speed below ``speed0`` [m/s]."""
    n = max(1, int(round(SPEED_SMOOTHING_S / dt)))
    smooth = pd.Series(np.asarray(u, float)).rolling(n, center=True, min_periods=1).mean()
    return float(speed0 - smooth.min())


def _check(full, keep: dict, sets: list, vessel, man, c_full: float, recorded_loss: float) -> dict:
    """Identify the simplified model on the training realisations and judge it."""
    model = full.subset([n for dof in DOFS for n in keep[dof]], "simplified")
    values = _identify([p for one in sets for p in one.problems], keep)
    c = stability_index(values)
    sim = simulate(model, values, vessel, man)
    bounded = "diverged_at" not in sim.attrs
    loss = _speed_loss(sim["u"].to_numpy(), vessel.speed, man.dt) if bounded else float("nan")
    failure = None
    if not bounded:
        failure = ("bounded", f"the training manoeuvre {man.name} diverged at "
                              f"t = {sim.attrs['diverged_at']:.0f} s")
    elif c_full > 0 and not c > 0:
        failure = ("stability", f"straight-line stability index C = {c:.3g} <= 0 while the "
                                f"full model has C = {c_full:.3g} > 0")
    elif not loss >= MIN_SPEED_LOSS_RATIO * recorded_loss:
        failure = ("speed_loss", f"speed loss {loss:.3f} m/s in {man.name}, less than "
                                 f"{MIN_SPEED_LOSS_RATIO:g} x the recorded {recorded_loss:.3f} m/s")
    return {"values": values, "stability_index": c, "bounded": bounded, "speed_loss_m_s": loss,
            "failure": failure}


def _add(keep: dict, full: ManoeuvringModel, name: str) -> list:
    """Put ``name`` (and its sway/yaw twin, by the union rule) back; the names added."""
    added = []
    for n in (name, twin(name)):
        if n is None or n not in full.names:
            continue
        dof = n[0]
        if n not in keep[dof]:
            keep[dof] = [m for m in full.names_of(dof) if m in set(keep[dof]) | {n}]
            added.append(n)
    return added


def _ranked(table: pd.DataFrame, names) -> list:
    """``names`` most sensitive first: selection frequency, then mean PAWN index."""
    rows = table.loc[list(names)]
    return list(rows.sort_values(["frequency", "pawn_mean"], ascending=False).index)


def admissible(full: ManoeuvringModel, keep: dict, table: pd.DataFrame, sets: list, vessel, man,
               c_full: float, recorded_loss: float) -> tuple[dict, list, dict]:
    """Put back what the rule removed and a manoeuvring model needs.

    Returns the terms per DOF, the repairs (``term``, ``added`` with its
    twin, ``reason``, ``candidates``, ``frequency``, ``pawn_mean``) and the
    final check (stability index, bounded, speed loss; ``failure`` when no
    candidate is left to repair it).
    """
    keep = {dof: list(keep[dof]) for dof in DOFS}
    repairs = []

    def put_back(name, reason, candidates):
        added = _add(keep, full, name)
        repairs.append({"term": name, "added": added, "reason": reason, "candidates": list(candidates),
                        "frequency": float(table.loc[name, "frequency"]),
                        "pawn_mean": float(table.loc[name, "pawn_mean"])})

    needs = structural_needs(keep)
    while needs:
        candidates, reason = needs[0]
        put_back(_ranked(table, candidates)[0], reason, candidates)
        needs = structural_needs(keep)
    while True:
        check = _check(full, keep, sets, vessel, man, c_full, recorded_loss)
        if check["failure"] is None:
            break
        kind, reason = check["failure"]
        have = {n for dof in DOFS for n in keep[dof]}
        if kind == "speed_loss":
            pool = [n for n in SPEED_LOSS if n not in have] or [n for n in full.names_of("X") if n not in have]
        else:
            pool = [n for dof in ("Y", "N") for n in full.names_of(dof) if n not in have]
        if not pool:
            break
        put_back(_ranked(table, pool)[0], reason, pool)
    return keep, repairs, check


def _explain(name: str, table: pd.DataFrame, groups: dict, kept: set, repairs: list,
             frequency: float) -> str:
    """Why a term is or is not in the derived model, from the selection numbers
    and the repairs."""
    row = table.loc[name]
    dof = name[0]
    partners = next((g for g in groups[dof] if name in g), [name])
    others = [n for n in partners if n != name]
    text = (f"{name}: selected in {100 * row['frequency']:.0f} % of the draws; mean PAWN "
            f"{row['pawn_mean']:.3f} (DOF mean {row['dof_mean_pawn']:.3f})")
    if others:
        best = max(partners, key=lambda n: table.loc[n, "pawn_mean"])
        text += f"; grouped with {', '.join(others)} (most sensitive: {best})"
    reason = next((r["reason"] for r in repairs if name in r["added"]), None)
    if reason:
        return text + f"; put back: {reason}"
    if name in kept:
        return text + "; kept"
    return text + f"; not kept (selected in no more than {100 * frequency:.0f} % of the draws)"


def derive(cfg: RunConfig, out_dir: Path) -> dict:
    """Run the analysis; write artifacts into ``out_dir``; return the result.

    The result holds ``keep`` (terms per DOF of the derived model),
    ``rule_keep`` (the stability selection alone), ``selection`` (per term:
    frequency, PAWN), ``admissibility`` (the terms put back and why, the
    stability index of the derived and of the full model, the check of the
    training manoeuvre), ``groups`` (the partition found most often),
    ``before_union`` (of the first draw), ``comparison`` with eq. 23-25
    (with the reason of every difference) and ``metrics``.
    """
    opts = _options(cfg)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    vessel = get_vessel(simulated_vessel(cfg))
    full = abkowitz()
    truth = {n: vessel.coefficients[n] for n in full.names}
    man = named_manoeuvre(opts["manoeuvre"], {"duration": float(opts["duration"]), "dt": float(opts["dt"])})
    clean = simulate(full, truth, vessel, man)
    root = np.random.SeedSequence(int(opts["seed"]))
    set_seqs, pawn_seq, draw_seq = root.spawn(3)
    sets = [_seed_set(full, vessel, clean, opts, s) for s in set_seqs.spawn(int(opts["seeds"]))]
    estimates = pd.concat([s.estimates.assign(set=k) for k, s in enumerate(sets)], ignore_index=True)
    nominal_full = estimates[full.names].median().to_dict()
    t_sets = time.perf_counter() - started
    pawn = _pawn_sets(full, nominal_full, vessel, man, opts, pawn_seq)
    t_pawn = time.perf_counter() - started - t_sets
    draws = _draws(full, estimates[full.names], pawn, opts, draw_seq)
    table = _selection_table(full, draws)
    frequency = float(opts["frequency"])
    rule_keep = union_sway_yaw(full, {dof: [n for n in full.names_of(dof) if table.loc[n, "frequency"] > frequency]
                                      for dof in DOFS})
    c_full = stability_index(nominal_full)
    recorded_loss = float(np.median([_speed_loss(s.record["u"].to_numpy(), vessel.speed, man.dt) for s in sets]))
    keep, repairs, check = admissible(full, rule_keep, table, sets, vessel, man, c_full, recorded_loss)
    groups = _modal_groups(draws)
    kept = {n for dof in DOFS for n in keep[dof]}
    table["rule"] = [n in set(rule_keep[n[0]]) for n in table.index]
    table["kept"] = [n in kept for n in table.index]
    table["added"] = [any(n in r["added"] for r in repairs) for n in table.index]
    table.to_csv(out_dir / "selection.csv")
    estimates.to_csv(out_dir / "estimates.csv", index=False)
    metrics = {"simplify/realisations": float(len(estimates)), "simplify/seeds": float(len(sets)),
               "simplify/draws": float(len(draws)), "simplify/identify_s": t_sets, "simplify/pawn_s": t_pawn,
               "simplify/stability_index": float(check["stability_index"]),
               "simplify/stability_index_full": float(c_full),
               "simplify/bounded": float(check["bounded"]),
               "simplify/speed_loss_m_s": float(check["speed_loss_m_s"]),
               "simplify/recorded_speed_loss_m_s": recorded_loss,
               "simplify/added_terms": float(sum(len(r["added"]) for r in repairs))}
    for dof in DOFS:
        rho = spearman_matrix(estimates[full.names_of(dof)])
        rho.to_csv(out_dir / f"spearman_{dof}.csv")
        together = co_membership([d["groups"][dof] for d in draws], full.names_of(dof))
        together.to_csv(out_dir / f"co_membership_{dof}.csv")
        indices = pawn_indices(pawn[dof])
        indices["pawn"] = table.loc[full.names_of(dof), "pawn_mean"]
        indices["pawn_sd"] = table.loc[full.names_of(dof), "pawn_sd"]
        indices["frequency"] = table.loc[full.names_of(dof), "frequency"]
        indices.to_csv(out_dir / f"pawn_{dof}.csv")
        metrics[f"simplify/{dof}/groups"] = float(len(groups[dof]))
        metrics[f"simplify/{dof}/mean_pawn"] = float(indices["pawn"].mean())
        metrics[f"simplify/{dof}/kept"] = float(len(keep[dof]))
        _plot_dof(rho, indices, groups[dof], dof, out_dir / f"simplify_{dof}.png")
    comparison = {}
    for dof in DOFS:
        paper = PAPER_SIMPLIFIED[dof]
        differ = [n for n in full.names_of(dof) if (n in keep[dof]) != (n in paper)]
        comparison[dof] = {"tool": keep[dof], "paper": paper,
                           "only_tool": [n for n in keep[dof] if n not in paper],
                           "only_paper": [n for n in paper if n not in keep[dof]],
                           "why": [_explain(n, table, groups, kept, repairs, frequency) for n in differ]}
    admissibility = {
        "requirements": ["linear surge, sway and yaw damping Xu, Yv, Yr, Nv, Nr",
                         "a surge term in v', r' (" + ", ".join(SPEED_LOSS) + ") for the speed loss in turns",
                         "straight-line stability index C > 0 when the full model has C > 0",
                         f"a bounded simulation of the training manoeuvre {man.name}",
                         f"a speed loss in {man.name} of at least {MIN_SPEED_LOSS_RATIO:g} x the recorded one"],
        "added": repairs,
        "stability_index": float(check["stability_index"]),
        "stability_index_full": float(c_full),
        "stability_convention": "C = Yv Nr - Nv Yr = Y'v (N'r - m'x'G) - N'v (Y'r - m') "
                                "(Yr, Nr carry the rigid-body terms); C > 0: straight-line stable",
        "training_manoeuvre": man.name,
        "bounded": bool(check["bounded"]),
        "speed_loss_m_s": float(check["speed_loss_m_s"]),
        "recorded_speed_loss_m_s": recorded_loss,
        "admissible": check["failure"] is None,
        "failure": None if check["failure"] is None else check["failure"][1],
        "identified_values": {k: float(v) for k, v in check["values"].items()},
    }
    metrics["simplify/total_s"] = time.perf_counter() - started
    result = {"keep": keep, "rule_keep": rule_keep,
              "selection": {n: {"frequency": float(r.frequency), "pawn_mean": float(r.pawn_mean),
                                "pawn_sd": float(r.pawn_sd)} for n, r in table.iterrows()},
              "frequency_threshold": frequency, "admissibility": admissibility,
              "groups": groups, "before_union": draws[0]["before_union"],
              "comparison": comparison, "metrics": metrics}
    (out_dir / "simplification.json").write_text(json.dumps(result, indent=1))
    (out_dir / "metrics.json").write_text(json.dumps(metrics, indent=1))
    return result


def _plot_dof(rho, pawn, groups, dof, path) -> None:
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 5))
    im = a.imshow(rho.to_numpy(), vmin=-1, vmax=1, cmap="RdBu_r")
    a.set_xticks(range(len(rho)), rho.columns, rotation=90, fontsize=8)
    a.set_yticks(range(len(rho)), rho.index, fontsize=8)
    a.set_title(f"{dof}: Spearman correlation of LS estimates")
    fig.colorbar(im, ax=a, fraction=0.046)
    colours = {n: i for i, g in enumerate(groups) for n in g}
    b.bar(pawn.index, pawn["pawn"], yerr=pawn["pawn_sd"],
          color=[f"C{colours[n] % 10}" for n in pawn.index])
    b.axhline(pawn["pawn"].mean(), color="k", ls="--", lw=1, label="mean")
    for x, (value, freq) in enumerate(zip(pawn["pawn"], pawn["frequency"])):
        b.text(x, value, f"{100 * freq:.0f}%", ha="center", va="bottom", fontsize=7)
    b.tick_params(axis="x", rotation=90, labelsize=8)
    b.set_ylabel("PAWN index, mean over draws (colour = group; label = selection frequency)")
    b.set_title(f"{dof}: trajectory sensitivity")
    b.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


class _Unrecorded:
    """A run that is not tracked (library use without a store)."""

    run_id = None

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> bool:
        return False

    def log_outputs(self, metrics: dict, directory: Path) -> None:
        """Nothing to log: the outputs stay in ``directory``."""


def ensure_definition(cfg: RunConfig, root: Path, record: Recorder | None = None,
                      run_dir: Path | None = None, force: bool = False) -> Path:
    """The simplified model definition, derived first if missing, the
    analysis recorded as its own run by ``record`` (experiment
    ``simplification``; None: written to ``run_dir`` only).

    Parallel jobs of a sweep wait for one another on a lock file, so the
    analysis runs once.
    """
    path = Path(root) / str(cfg.simplify.output)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path.with_suffix(".lock"), "a+") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            if path.exists() and not force:
                return path
            out_dir = Path(run_dir) if run_dir else path.parent / "simplification_run"
            params = {"simplify": _options(cfg), "vessel": {"name": simulated_vessel(cfg)}}
            record = record or (lambda *args: _Unrecorded())
            with record("simplification", "simplify abkowitz", params, {"kind": "simplification"}) as run:
                result = derive(cfg, out_dir)
                save_definition(path, abkowitz(), result["keep"],
                                {"mlflow_run": run.run_id, "groups": result["groups"],
                                 "selection": result["selection"],
                                 "frequency_threshold": result["frequency_threshold"],
                                 "rule_keep": result["rule_keep"], "options": _options(cfg)},
                                admissibility={k: v for k, v in result["admissibility"].items()
                                               if k != "identified_values"})
                run.log_outputs(result["metrics"], out_dir)
            return path
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)
