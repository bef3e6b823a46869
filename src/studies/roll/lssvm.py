"""Least-squares support vector machine (LS-SVM) in one input with analytic time derivatives.

The state is approximated by the LS-SVM regression of Chen et al. (2019),
eq. (6)-(11),

    x(t) = sum_i alpha_i K(t_i, t) + b,

with the RBF kernel ``K(t_i, t) = exp(-(t - t_i)^2 / (2 sigma^2))``. The
multipliers and bias solve the bordered system (eq. 10)

    [K + I/gamma  1] [alpha]   [y]
    [1^T          0] [  b  ] = [0],

and the time derivatives follow from differentiating the kernel (eq. 12-14):

    dK/dt   = -(u / sigma^2) K,
    d2K/dt2 = (u^2 / sigma^4 - 1 / sigma^2) K,       u = t - t_i.

Kernel width ``sigma`` and regularisation ``gamma`` are chosen by
cross-validation over a grid (exact leave-one-out, interleaved or
time-blocked folds). Long records
are fitted in overlapping windows of a few periods (each an LS-SVM of a few
dozen points): the RBF kernel is local, so a window sees the same data as a
global fit would near its centre, at a fraction of the O(n^3) cost.

References
----------
Chen, C., Tello Ruiz, M., Delefortrie, G., Mei, T., Vantorre, M., Lataire, E.
(2019). Parameter estimation for a ship's roll response model in shallow water
using an intelligent machine learning method. Ocean Engineering 191, 106479,
eq. (6)-(16).

Suykens, J.A.K., Van Gestel, T., De Brabanter, J., De Moor, B., Vandewalle, J.
(2002). Least Squares Support Vector Machines. World Scientific.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
from scipy import linalg

__all__ = ["rbf_kernel", "lssvm_fit", "lssvm_eval", "LSSVM", "cv_select", "WindowedLSSVM"]


def rbf_kernel(t_eval, t_train, sigma: float, order: int = 0) -> np.ndarray:
    """RBF kernel matrix ``K[j, i] = K(t_i, t_j)`` and its derivatives in ``t_eval``.

    Parameters
    ----------
    t_eval : array_like, shape (m,)
        Evaluation times.
    t_train : array_like, shape (n,)
        Support times ``t_i``.
    sigma : float
        Kernel width (same unit as the times).
    order : {0, 1, 2}
        Derivative order with respect to the evaluation time.

    Returns
    -------
    ndarray, shape (m, n)
    """
    u = np.asarray(t_eval, float)[:, None] - np.asarray(t_train, float)[None, :]
    s2 = sigma * sigma
    k = np.exp(-0.5 * u * u / s2)
    if order == 0:
        return k
    if order == 1:
        return -(u / s2) * k
    if order == 2:
        return (u * u / (s2 * s2) - 1.0 / s2) * k
    raise ValueError("order must be 0, 1 or 2")


def _solve_bordered(K: np.ndarray, y: np.ndarray, gamma: float) -> tuple[np.ndarray, float]:
    """Solve eq. (10) for ``alpha`` and ``b`` (Cholesky of ``K + I/gamma``)."""
    n = K.shape[0]
    A = K + np.eye(n) / gamma
    rhs = np.column_stack((y, np.ones(n)))
    try:
        c = linalg.cho_factor(A, lower=True, check_finite=False)
        sol = linalg.cho_solve(c, rhs, check_finite=False)
    except linalg.LinAlgError:
        sol = np.linalg.lstsq(A, rhs, rcond=None)[0]
    nu, eta = sol[:, 0], sol[:, 1]
    b = float(nu.sum() / eta.sum())
    return nu - eta * b, b


def lssvm_fit(t, y, sigma: float, gamma: float) -> tuple[np.ndarray, float]:
    """Fit an LS-SVM with RBF kernel (Chen et al. 2019, eq. 10).

    Parameters
    ----------
    t, y : array_like
        Training inputs and outputs.
    sigma : float
        Kernel width.
    gamma : float
        Regularisation (penalty) factor of eq. (7).

    Returns
    -------
    alpha : ndarray
        Lagrange multipliers.
    b : float
        Bias.
    """
    t = np.asarray(t, float)
    return _solve_bordered(rbf_kernel(t, t, sigma), np.asarray(y, float), gamma)


def lssvm_eval(t_train, alpha, b, sigma: float, t_eval, order: int = 0) -> np.ndarray:
    """Evaluate an LS-SVM (eq. 11) or its time derivatives (eq. 14) at ``t_eval``."""
    v = rbf_kernel(t_eval, t_train, sigma, order) @ np.asarray(alpha, float)
    return v + b if order == 0 else v


@dataclass
class LSSVM:
    """LS-SVM regression of one signal of time with analytic derivatives.

    Parameters
    ----------
    sigma : float
        Kernel width [s].
    gamma : float
        Regularisation factor [-] (for outputs scaled to unit standard deviation).

    References
    ----------
    Chen, C. et al. (2019). Ocean Engineering 191, 106479, eq. (6)-(14).
    """

    sigma: float
    gamma: float
    t_: np.ndarray | None = field(default=None, repr=False)
    alpha_: np.ndarray | None = field(default=None, repr=False)
    b_: float = 0.0
    scale_: float = 1.0

    def fit(self, t, y) -> "LSSVM":
        """Fit to samples ``(t, y)``; the output is scaled to unit standard deviation internally."""
        t = np.asarray(t, float)
        y = np.asarray(y, float)
        s = float(np.std(y)) or 1.0
        self.t_, self.scale_ = t, s
        self.alpha_, self.b_ = lssvm_fit(t, y / s, self.sigma, self.gamma)
        return self

    def predict(self, t, order: int = 0) -> np.ndarray:
        """Value (``order=0``) or time derivative (1, 2) at ``t``."""
        return self.scale_ * lssvm_eval(self.t_, self.alpha_, self.b_, self.sigma, t, order)


def _folds(n: int, n_folds: int, mode: str) -> list[np.ndarray]:
    idx = np.arange(n)
    if mode == "interleaved":
        return [idx[k::n_folds] for k in range(n_folds)]
    if mode == "blocked":
        return [a for a in np.array_split(idx, n_folds)]
    raise ValueError("mode must be 'interleaved', 'blocked' or 'loo'")


def _loo_scores(t: np.ndarray, y: np.ndarray, sigmas, gam: np.ndarray) -> np.ndarray:
    """Sum of squared exact leave-one-out residuals of the LS-SVM (with bias).

    The residual of sample ``i`` when it is left out is ``alpha_i / (C^-1)_ii``
    with ``C`` the bordered matrix of eq. (10) (Cawley and Talbot, 2004); with
    ``K = Q diag(lam) Q^T`` every ``gamma`` costs O(n^2).
    """
    out = np.zeros((len(sigmas), gam.size))
    for i, s in enumerate(sigmas):
        lam, Q = np.linalg.eigh(rbf_kernel(t, t, s))
        lam = np.clip(lam, 0.0, None)
        qy = Q.T @ y
        q1 = Q.sum(axis=0)
        Q2 = Q * Q
        for j, g in enumerate(gam):
            d = 1.0 / (lam + 1.0 / g)
            nu = Q @ (d * qy)
            eta = Q @ (d * q1)
            s1 = eta.sum()
            alpha = nu - eta * (nu.sum() / s1)
            cdiag = Q2 @ d - eta * eta / s1
            r = alpha / cdiag
            out[i, j] = float(r @ r)
    return out


def cv_select(segments: Sequence[tuple[np.ndarray, np.ndarray]], sigmas: Sequence[float],
              gammas: Sequence[float], n_folds: int | None = None, mode: str = "loo"
              ) -> tuple[float, float, np.ndarray]:
    """Choose kernel width and regularisation by cross-validation over a grid.

    For every ``sigma`` (and training fold) the kernel matrix is diagonalised
    once, ``K = Q diag(lam) Q^T``, so that all ``gamma`` of the grid cost
    only matrix-vector products.

    Parameters
    ----------
    segments : sequence of (t, y)
        Data segments (e.g. a few windows of a record); the validation error
        is summed over them. ``y`` should be scaled to unit standard deviation.
    sigmas, gammas : sequence of float
        Grid of kernel widths (unit of ``t``) and regularisation factors.
    n_folds : int, optional
        Number of folds for ``"interleaved"`` and ``"blocked"``.
    mode : {"loo", "interleaved", "blocked"}
        ``loo``: exact leave-one-out (interleaved folds of one sample, closed
        form); it judges the smoother at the density it is used at, whereas
        k-fold training sets are sparser and favour too wide kernels.
        ``interleaved``: fold ``k`` holds every ``n_folds``-th sample;
        ``blocked``: contiguous blocks of time.

    Returns
    -------
    sigma, gamma : float
        Values with the least mean squared validation error.
    scores : ndarray, shape (len(sigmas), len(gammas))
        Mean squared validation errors.

    References
    ----------
    Cawley, G.C., Talbot, N.L.C. (2004). Fast exact leave-one-out
    cross-validation of sparse least-squares support vector machines. Neural
    Networks 17, 1467-1475.
    """
    gam = np.asarray(gammas, float)
    scores = np.zeros((len(sigmas), gam.size))
    count = 0
    for t, y in segments:
        t = np.asarray(t, float)
        y = np.asarray(y, float)
        if mode == "loo":
            scores += _loo_scores(t, y, sigmas, gam)
            count += t.size
            continue
        for val in _folds(t.size, int(n_folds or 5), mode):
            tr = np.setdiff1d(np.arange(t.size), val)
            if tr.size < 3 or val.size == 0:
                continue
            count += val.size
            for i, s in enumerate(sigmas):
                K = rbf_kernel(t[tr], t[tr], s)
                lam, Q = np.linalg.eigh(K)
                lam = np.clip(lam, 0.0, None)
                Kv = rbf_kernel(t[val], t[tr], s)
                qy = Q.T @ y[tr]
                q1 = Q.sum(axis=0)  # Q^T 1
                for j, g in enumerate(gam):
                    d = 1.0 / (lam + 1.0 / g)
                    nu = Q @ (d * qy)
                    eta = Q @ (d * q1)
                    b = nu.sum() / eta.sum()
                    alpha = nu - eta * b
                    r = Kv @ alpha + b - y[val]
                    scores[i, j] += float(r @ r)
    scores /= max(count, 1)
    i, j = np.unravel_index(int(np.argmin(scores)), scores.shape)
    return float(sigmas[i]), float(gam[j]), scores


@dataclass
class WindowedLSSVM:
    """LS-SVM fitted in overlapping windows of a long, uniformly sampled signal.

    Window ``w`` covers ``[s_w, s_w + window]`` with ``s_w = w * stride``; the
    value and derivatives at a time are taken from the window whose centre is
    nearest (so that each evaluation point sits at least ``(window - stride)/2``
    from that window's edges, away from boundary effects).

    Parameters
    ----------
    sigma : float
        Kernel width [s].
    gamma : float
        Regularisation factor (outputs scaled to unit standard deviation per window).
    window : float
        Window length [s].
    stride : float
        Window spacing [s] (at most ``window``).
    """

    sigma: float
    gamma: float
    window: float
    stride: float
    models_: list = field(default_factory=list, repr=False)
    centres_: np.ndarray | None = field(default=None, repr=False)

    def fit(self, t, y) -> "WindowedLSSVM":
        """Fit one LS-SVM per window to the samples ``(t, y)``."""
        t = np.asarray(t, float)
        y = np.asarray(y, float)
        t0, t1 = t[0], t[-1]
        span = t1 - t0
        if span <= self.window:
            starts = np.array([t0])
            win = span
        else:
            n = int(np.ceil((span - self.window) / self.stride)) + 1
            starts = t0 + np.minimum(np.arange(n) * self.stride, span - self.window)
            win = self.window
        self.models_, centres = [], []
        for s in starts:
            m = (t >= s - 1e-12) & (t <= s + win + 1e-12)
            self.models_.append(LSSVM(self.sigma, self.gamma).fit(t[m], y[m]))
            centres.append(s + 0.5 * win)
        self.centres_ = np.asarray(centres)
        return self

    def predict(self, t, order: int = 0) -> np.ndarray:
        """Value or derivative (``order`` 0, 1, 2) at ``t``, from the nearest-centred window."""
        t = np.asarray(t, float)
        owner = np.argmin(np.abs(t[:, None] - self.centres_[None, :]), axis=1)
        out = np.empty(t.size)
        for w in np.unique(owner):
            m = owner == w
            out[m] = self.models_[w].predict(t[m], order)
        return out
