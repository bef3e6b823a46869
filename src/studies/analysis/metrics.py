"""Error measures between a simulated and a reference record.

Fitness is thesis eq. 3.43: ``sum over k in (u, v, r) of mean((k - k_ref)^2)``
in SI units (m/s, rad/s). A prediction that diverged gets
:data:`~studies.simulate.simulator.DIVERGED_PENALTY` instead of NaN, and a
``diverged`` flag.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..simulate.simulator import DIVERGED_PENALTY

__all__ = ["DIVERGED_PENALTY", "fitness", "error_metrics"]

CHANNELS = ("u", "v", "r")


def _aligned(pred: pd.DataFrame, ref: pd.DataFrame, col: str) -> tuple[np.ndarray, np.ndarray]:
    n = min(len(pred), len(ref))
    return pred[col].to_numpy(float)[:n], ref[col].to_numpy(float)[:n]


def fitness(pred: pd.DataFrame, ref: pd.DataFrame) -> float:
    """Thesis eq. 3.43 (sum of the mean squared u, v, r errors)."""
    total = 0.0
    for col in CHANNELS:
        a, b = _aligned(pred, ref, col)
        err = np.mean((a - b) ** 2)
        if not np.isfinite(err):
            return DIVERGED_PENALTY
        total += err
    return float(total)


def error_metrics(pred: pd.DataFrame, ref: pd.DataFrame, prefix: str) -> dict:
    """``<prefix>/fitness``, ``rmse_*``, ``mae_*`` for u, v, r and ``diverged``.

    Units: m/s for u, v; rad/s for r; position RMSE ``rmse_position`` in m.
    """
    diverged = bool(pred.attrs.get("diverged_at") is not None) or not np.all(
        np.isfinite(pred[list(CHANNELS)].to_numpy()))
    out = {f"{prefix}/fitness": fitness(pred, ref), f"{prefix}/diverged": float(diverged)}
    for col in CHANNELS:
        a, b = _aligned(pred, ref, col)
        e = a - b
        out[f"{prefix}/rmse_{col}"] = float(np.sqrt(np.mean(e ** 2))) if not diverged else DIVERGED_PENALTY
        out[f"{prefix}/mae_{col}"] = float(np.mean(np.abs(e))) if not diverged else DIVERGED_PENALTY
    if not diverged:
        out[f"{prefix}/rmse_position"] = position_rmse(pred, ref)
    return out


def position_rmse(pred: pd.DataFrame, ref: pd.DataFrame) -> float:
    """Position RMSE [m] of ``pred`` against ``ref`` (``x0, y0``) over their
    common samples; nan when ``pred`` holds NaN (a diverged replay)."""
    ax, bx = _aligned(pred, ref, "x0")
    ay, by = _aligned(pred, ref, "y0")
    return float(np.sqrt(np.mean((ax - bx) ** 2 + (ay - by) ** 2)))
