"""``studies simplify``: derive the simplified model from data and log how.

1. simulate the training manoeuvre of the vessel's reference model once;
2. identify the full model by LS (Savitzky-Golay derivatives) on many
   realisations of it with measurement noise (Li et al. eq. 22, k0 = 5 %);
3. Spearman correlation of the estimates per DOF -> strongly correlated groups;
4. PAWN sensitivity of the trajectory to each coefficient, per DOF;
5. the simplification rule (:mod:`studies.models.simplified`), written as a
   model definition that ``model=simplified`` loads, with the correlation
   matrices, groups, PAWN indices and the comparison with the paper's eq.
   23-25 as artifacts of one MLflow run.
"""

from __future__ import annotations

import fcntl
import json
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pandas as pd

from ..config import RunConfig
from ..plotting import pyplot
from ..analysis.correlation import correlated_groups, spearman_matrix
from ..analysis.pawn import trajectory_pawn
from ..environment.noise import add_measurement_noise
from ..identify import LeastSquares, build_problems
from ..models.abkowitz import abkowitz
from ..models.simplified import PAPER_SIMPLIFIED, save_definition, select_terms, union_sway_yaw
from ..simulate import simulate
from ..vessels import get_vessel
from .settings import named_manoeuvre
from .study import Recorder

__all__ = ["derive", "ensure_definition"]


def _options(cfg: RunConfig) -> dict:
    return asdict(cfg.simplify)


def derive(cfg: RunConfig, out_dir: Path) -> dict:
    """Run the analysis; write artifacts into ``out_dir``; return the result."""
    opts = _options(cfg)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    vessel = get_vessel(str(cfg.vessel.name))
    full = abkowitz()
    truth = {n: vessel.coefficients[n] for n in full.names}
    man = named_manoeuvre(opts["manoeuvre"], {"duration": float(opts["duration"]), "dt": float(opts["dt"])})
    clean = simulate(full, truth, vessel, man)
    rng = np.random.default_rng(int(opts["seed"]))
    t0 = time.perf_counter()
    rows = []
    for _ in range(int(opts["realisations"])):
        noisy = add_measurement_noise(clean, float(opts["noise"]), vessel.speed, rng)
        problems = build_problems(full, vessel, noisy, str(opts["derivative"]))
        rows.append(LeastSquares().fit(problems).params)
    estimates = pd.DataFrame(rows)[full.names]
    estimates.to_csv(out_dir / "estimates.csv", index=False)
    nominal = estimates.median().to_dict()
    metrics = {"simplify/realisations": float(len(rows)),
               "simplify/identify_s": time.perf_counter() - t0}
    keep, groups, pawn_tables = {}, {}, {}
    for dof in ("X", "Y", "N"):
        names = full.names_of(dof)
        rho = spearman_matrix(estimates[names])
        rho.to_csv(out_dir / f"spearman_{dof}.csv")
        groups[dof] = correlated_groups(rho, float(opts["threshold"]))
        table = trajectory_pawn(full, nominal, vessel, man, dof, int(opts["pawn_samples"]),
                                float(opts["pawn_spread"]), seed=int(opts["seed"]))
        table.to_csv(out_dir / f"pawn_{dof}.csv")
        pawn_tables[dof] = table
        keep[dof] = select_terms(groups[dof], table["pawn"])
        metrics[f"simplify/{dof}/groups"] = float(len(groups[dof]))
        metrics[f"simplify/{dof}/mean_pawn"] = float(table["pawn"].mean())
        _plot_dof(rho, table, groups[dof], dof, out_dir / f"simplify_{dof}.png")
    united = union_sway_yaw(full, keep)
    for dof in ("X", "Y", "N"):
        metrics[f"simplify/{dof}/kept"] = float(len(united[dof]))
    comparison = {dof: {"tool": united[dof], "paper": PAPER_SIMPLIFIED[dof],
                        "only_tool": [n for n in united[dof] if n not in PAPER_SIMPLIFIED[dof]],
                        "only_paper": [n for n in PAPER_SIMPLIFIED[dof] if n not in united[dof]]}
                  for dof in ("X", "Y", "N")}
    result = {"keep": united, "before_union": keep, "groups": groups, "comparison": comparison,
              "metrics": metrics}
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
    b.bar(pawn.index, pawn["pawn"], color=[f"C{colours[n] % 10}" for n in pawn.index])
    b.axhline(pawn["pawn"].mean(), color="k", ls="--", lw=1, label="mean")
    b.tick_params(axis="x", rotation=90, labelsize=8)
    b.set_ylabel("PAWN index (colour = correlation group)")
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
            params = {"simplify": _options(cfg), "vessel": {"name": str(cfg.vessel.name)}}
            record = record or (lambda *args: _Unrecorded())
            with record("simplification", "simplify abkowitz", params, {"kind": "simplification"}) as run:
                result = derive(cfg, out_dir)
                save_definition(path, abkowitz(), result["keep"],
                                {"mlflow_run": run.run_id, "groups": result["groups"],
                                 "options": _options(cfg)})
                run.log_outputs(result["metrics"], out_dir)
            return path
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)
