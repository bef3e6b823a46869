"""Which verdict predicts unseen stretches of the records: cross-validation
over time blocks, and the probabilities a user reads.

The comparison of :mod:`studies.discovery.inference` is linear: with the
baseline's columns projected out, a model is a set of cause columns and a
least-squares fit. Here every model is fitted with one time block of the
records left out and judged on that block (leave-one-block-out
cross-validation), so noise that the smoother took for signal, coloured
sensor noise or a cause fitted to one manoeuvre's quirks, which does not
repeat in another block, earns nothing; an effect that acts throughout
the records (a current, a sensor offset, a missing force) predicts every
block better.

- **Blocks** are consecutive rows of one record, several correlation times
  of the error long (the caller's choice: :func:`row_blocks` takes their
  length), shared by the three DOFs, so that blocks are nearly independent.
- **A verdict's gain** in a block is the fall in that block's weighted
  residual sum of squares (half of it: a log-likelihood at unit variance)
  when the verdict's model, fitted on every other block, predicts it. A
  cause with variants (a missing term from the library, a wind from one of
  16 directions) picks its variant on the other blocks, by their fit, so
  that its gain is the honest gain of "this cause, its variant chosen from
  the data".
- **Uncertainty** of the total gain over blocks comes from the Bayesian
  bootstrap over blocks (Rubin 1981): Dirichlet weights on the blocks give
  draws of every verdict's total gain at once, so probabilities such as
  "this verdict predicts unseen blocks better than that one" are read off
  the draws.

References
----------
Rubin, D. B. (1981). The Bayesian bootstrap. Ann. Statist. 9(1), 130-134.
Arlot, S., Celisse, A. (2010). A survey of cross-validation procedures for
model selection. Statistics Surveys 4, 40-79.
Roberts, D. R. et al. (2017). Cross-validation strategies for data with
temporal, spatial, hierarchical, or phylogenetic structure. Ecography 40.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["row_blocks", "BlockGrams", "BlockGains", "bayesian_bootstrap", "name_per_draw", "t_values", "DRAWS"]

#: Bayesian-bootstrap draws of the verdicts' total gains
DRAWS = 4000
#: ridge (relative to the Gram diagonal) that keeps a fold's normal equations solvable
RIDGE = 1e-10


def row_blocks(record: np.ndarray, dof: np.ndarray, block_rows: int) -> np.ndarray:
    """Block id of every row: data rows of one record cut into runs of
    ``block_rows`` consecutive rows (the remainder joins the record's last
    block), the same id for the same rows of every DOF; ``-1`` for rows
    that belong to no record (the MMG regression's prior rows, ``dof`` 3).

    ``record``: the record index of every row; ``dof``: its DOF (0-2, 3 for prior rows).
    """
    record = np.asarray(record, int)
    dof = np.asarray(dof, int)
    out = np.full(len(record), -1, int)
    block_rows = max(int(block_rows), 1)
    keys = {}
    for k in range(3):
        rows = np.flatnonzero(dof == k)
        for r in np.unique(record[rows]):
            idx = rows[record[rows] == r]
            n_blocks = max(len(idx) // block_rows, 1)
            pos = np.minimum(np.arange(len(idx)) // block_rows, n_blocks - 1)
            for j in range(n_blocks):
                keys.setdefault((int(r), j), len(keys))
            out[idx] = [keys[(int(r), int(j))] for j in pos]
    return out


class BlockGrams:
    """Per-block Gram matrices of residualised columns ``x`` (N, c) and target ``y`` (N,).

    ``g``, ``b``: the totals over every row (prior rows included:
    they are always fitted, never held out); ``gk`` (K, c, c), ``bk``
    (K, c), ``yyk`` (K,): each block's own rows.
    """

    def __init__(self, x: np.ndarray, y: np.ndarray, blocks: np.ndarray):
        self.g, self.b = x.T @ x, x.T @ y
        ids = np.unique(blocks[blocks >= 0])
        self.n_blocks = len(ids)
        c = x.shape[1]
        self.gk = np.empty((len(ids), c, c))
        self.bk = np.empty((len(ids), c))
        self.yyk = np.empty(len(ids))
        for j, k in enumerate(ids):
            rows = blocks == k
            xk, yk = x[rows], y[rows]
            self.gk[j] = xk.T @ xk
            self.bk[j] = xk.T @ yk
            self.yyk[j] = float(yk @ yk)

    def folds(self, index: np.ndarray) -> "FoldFits":
        """Fits of the models ``index`` (m, s) (column sets of equal size) with each block left out."""
        return FoldFits(self, np.asarray(index, int))


@dataclass
class FoldFits:
    """Leave-one-block-out fits of ``m`` models of ``s`` columns each.

    ``beta`` (K, m, s): coefficients fitted without block k;
    ``train`` (K, m): half the fall in the other blocks' residual sum of squares;
    ``held`` (K, m): half the fall in block k's residual sum of squares (its gain).
    """

    beta: np.ndarray
    train: np.ndarray
    held: np.ndarray

    def __init__(self, grams: BlockGrams, index: np.ndarray):
        m, s = index.shape
        k = grams.n_blocks
        if s == 0:
            self.beta = np.zeros((k, m, 0))
            self.train = np.zeros((k, m))
            self.held = np.zeros((k, m))
            return
        gk = grams.gk[:, index[:, :, None], index[:, None, :]]           # (K, m, s, s)
        bk = grams.bk[:, index]                                            # (K, m, s)
        g_all = grams.g[index[:, :, None], index[:, None, :]]              # (m, s, s)
        b_all = grams.b[index]                                             # (m, s)
        gt = g_all[None] - gk
        bt = b_all[None] - bk
        diag = np.einsum("kmii->kmi", gt)
        ridge = RIDGE * np.maximum(diag.mean(axis=-1), 1e-300)
        gt = gt + ridge[..., None, None] * np.eye(s)
        try:
            beta = np.linalg.solve(gt, bt[..., None])[..., 0]
        except np.linalg.LinAlgError:
            beta = np.einsum("kmij,kmj->kmi", np.linalg.pinv(gt), bt)
        self.beta = beta
        self.train = 0.5 * np.einsum("kmi,kmi->km", beta, bt)
        self.held = np.einsum("kmi,kmi->km", beta, bk) - 0.5 * np.einsum("kmi,kmij,kmj->km", beta, gk, beta)


@dataclass
class BlockGains:
    """Every verdict's held-out gain per block, its variant chosen on the other blocks.

    ``ids``: verdict ids; ``held`` (v, K): gain per block.
    """

    ids: list
    held: np.ndarray

    @classmethod
    def of(cls, grams: BlockGrams, verdict_models: dict) -> "BlockGains":
        """``verdict_models``: ``{verdict id: list of column-index arrays}`` (its variants)."""
        ids, held = [], []
        for vid, models in verdict_models.items():
            by_size = {}
            for j, idx in enumerate(models):
                by_size.setdefault(len(idx), []).append(j)
            train = np.full((grams.n_blocks, len(models)), -np.inf)
            gain = np.zeros((grams.n_blocks, len(models)))
            for size, js in by_size.items():
                fits = grams.folds(np.array([models[j] for j in js], int).reshape(len(js), size))
                train[:, js] = fits.train
                gain[:, js] = fits.held
            pick = np.argmax(train, axis=1)
            ids.append(vid)
            held.append(gain[np.arange(grams.n_blocks), pick])
        return cls(ids, np.array(held).reshape(len(ids), grams.n_blocks))


def bayesian_bootstrap(n_blocks: int, draws: int = DRAWS, seed: int = 0) -> np.ndarray:
    """Dirichlet(1, ..., 1) weights on ``n_blocks`` blocks, scaled to sum to
    ``n_blocks`` (draws, K): a draw's weighted sum of per-block gains is a
    draw of the total gain (Rubin 1981)."""
    rng = np.random.default_rng(seed)
    return rng.dirichlet(np.ones(max(n_blocks, 1)), size=int(draws)) * max(n_blocks, 1)


def t_values(held: np.ndarray) -> np.ndarray:
    """Each candidate's summed held-out gain over its standard error (rows of
    ``held`` (c, K): gains per block), the statistic :func:`name_per_draw`
    compares with its threshold on the records as measured."""
    return name_statistics(held, np.ones((1, held.shape[1])))[1][0]


def name_statistics(held: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(mean, t)`` (draws, c) of every candidate's block gains under each weighting."""
    k = held.shape[1]
    mean = weights @ held.T / k
    var = np.maximum(weights @ (held ** 2).T / k - mean ** 2, 1e-300)
    return mean, mean / np.sqrt(var / k)


def name_per_draw(held: np.ndarray, weights: np.ndarray, threshold: float,
                  log_variants: np.ndarray | None = None) -> np.ndarray:
    """The verdict each weighting of the blocks names: among the candidates
    (rows of ``held`` (c, K), their gains per block) whose weighted mean gain
    exceeds ``threshold`` standard errors (the weighted spread of the blocks'
    gains over the square root of their number), the one of largest total
    gain less the log of its number of variants (``log_variants`` (c,): a
    uniform prior over a cause's variants, so that a missing term picked from
    the whole library must predict better than a cause of one form to be
    preferred to it); ``-1`` when none does. ``weights`` (draws, K), each row
    summing to K (:func:`bayesian_bootstrap`; a row of ones is the records as
    measured).
    """
    weights = np.atleast_2d(weights)
    k = held.shape[1]
    if held.shape[0] == 0 or k < 2:
        return np.full(len(weights), -1)
    mean, t = name_statistics(held, weights)                          # (draws, c)
    penalty = np.zeros(held.shape[0]) if log_variants is None else np.asarray(log_variants, float)
    score = np.where(t > threshold, mean * k - penalty, -np.inf)
    pick = np.argmax(score, axis=1)
    return np.where(np.isfinite(score[np.arange(len(score)), pick]), pick, -1)
