"""Identification of the roll-decay model: NLS, FLS and NLS-SVM (Chen et al., 2019).

Three estimators with the same interface, each a small class whose
constructor stores the settings and whose ``fit(record)`` returns a
:class:`RollFit` (``params``, ``cpu_s``, ``meta``). ``record`` is a prepared
decay (``DataFrame`` with ``t`` [s] from the release and ``phi`` [rad] about
equilibrium; see :func:`studies.data.roll_decay.load_roll_decay`) or a list of
them (identified jointly).

- :class:`NLSEstimator` ("nls", Chen et al. Fig. 6): output-error fit of the
  RK4-simulated trajectory to the record with ``scipy.optimize.least_squares``;
  initial guess from the log decrement (decay-curve fit); the initial state of
  each record is estimated with the coefficients.
- :class:`FLSEstimator` ("fls", Fig. 7): curve fit first (a smoothing spline
  with the smoothing chosen by k-fold cross-validation), differentiated
  analytically, then linear least squares on the ODE (equation error).
- :class:`NLSSVMEstimator` ("nls_svm", eq. 6-16, Table 4): LS-SVM with RBF
  kernel fitted to ``phi(t)`` (hyper-parameters by cross-validation over a
  grid), ``phi'`` and ``phi''`` from the analytic kernel derivatives, then
  linear least squares on the ODE (eq. 15-16).

References
----------
Chen, C., Tello Ruiz, M., Delefortrie, G., Mei, T., Vantorre, M., Lataire, E.
(2019). Parameter estimation for a ship's roll response model in shallow water
using an intelligent machine learning method. Ocean Engineering 191, 106479.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
import pandas as pd

from studies.models.roll import RollModel

__all__ = [
    "RollFit",
    "NLSEstimator",
    "FLSEstimator",
    "NLSSVMEstimator",
    "ESTIMATORS",
    "make_estimator",
    "ode_least_squares",
    "harmonic_filter",
    "predict_record",
]


@dataclass
class RollFit:
    """Result of a roll identification.

    Attributes
    ----------
    params : dict
        ``omega0`` [rad/s] and the switched-on terms (``b1`` [1/s], ``b2`` [-],
        ``b3`` [s], ``c3`` [1/s^2]).
    cpu_s : float
        CPU time of the identification [s] (``time.process_time``; summed over threads).
    meta : dict
        Method details (settings chosen by cross-validation, residuals, wall time, ...).
    """

    params: dict
    cpu_s: float
    meta: dict = field(default_factory=dict)


# ---------------------------------------------------------------- helpers
def _as_records(record) -> list[pd.DataFrame]:
    recs = [record] if isinstance(record, pd.DataFrame) else list(record)
    if not recs:
        raise ValueError("no record to identify from")
    for r in recs:
        if not {"t", "phi"} <= set(r.columns):
            raise ValueError("a record needs columns 't' and 'phi'")
    return recs


def _period(rec: pd.DataFrame) -> float:
    p = rec.attrs.get("period")
    if p is None or not np.isfinite(p):
        from studies.analysis.roll_decay import estimate_period

        p = estimate_period(rec["t"].to_numpy(float), rec["phi"].to_numpy(float))
    if not np.isfinite(p):
        raise ValueError("cannot estimate the roll period of the record")
    return float(p)


def _subsample(rec: pd.DataFrame, points_per_period: float, phase: int = 0) -> tuple[np.ndarray, np.ndarray, int]:
    t = rec["t"].to_numpy(float)
    phi = rec["phi"].to_numpy(float)
    dt = t[1] - t[0]
    step = max(1, int(round(_period(rec) / points_per_period / dt)))
    return t[phase::step], phi[phase::step], step


def harmonic_filter(n_per_period: int, harmonics: Sequence[int] = (3, 5)) -> np.ndarray:
    """Zero-phase FIR that removes the given odd harmonics of the roll frequency.

    The cascade of moving averages over ``T/k`` (one per harmonic ``k``) has
    exact zeros at ``k omega``, ``2k omega``, ... and passes the fundamental
    with gain ``prod(sinc(1/k))`` (0.83 x 0.94 for 3 and 5).

    Parameters
    ----------
    n_per_period : int
        Samples per roll period of the (uniform) rows to filter.
    harmonics : sequence of int
        Harmonics to remove.

    Returns
    -------
    ndarray
        Filter taps (sum 1).
    """
    taps = np.ones(1)
    for k in harmonics:
        L = max(1, int(round(n_per_period / k)))
        taps = np.convolve(taps, np.ones(L) / L)
    return taps


def ode_least_squares(model: RollModel, phi, dphi, ddphi, fit_offset: bool = True,
                      row_filter: np.ndarray | None = None, segments: Sequence[int] | None = None
                      ) -> tuple[dict, dict]:
    """Linear least squares on the roll ODE (equation error, Chen et al. 2019 eq. 15-16).

    Solves ``-phi'' = b1 phi' + b2 |phi'| phi' + b3 phi'^3 + omega0^2 phi + c3 phi^3 [+ k]``
    for the switched-on terms, with columns scaled to unit norm.

    Parameters
    ----------
    model : RollModel
        Which terms are on.
    phi, dphi, ddphi : ndarray
        Roll angle [rad], rate [rad/s] and acceleration [rad/s^2] at the
        same instants (from a smoothed fit of the record).
    fit_offset : bool
        Also fit a constant ``k = -omega0^2 phi_offset`` (a residual heel
        offset of the record).
    row_filter : ndarray, optional
        FIR taps applied along time to every regressor column and to the
        left-hand side (``mode="valid"``) before solving; the equation holds
        at every instant, so it also holds for any linear combination of
        instants. Used to remove the harmonics of the nonlinear terms that a
        smoother cannot reproduce from noisy data (:func:`harmonic_filter`).
        Rows must then be uniformly spaced.
    segments : sequence of int, optional
        Lengths of consecutive uniformly spaced pieces of the rows (one per
        record); the filter does not cross their boundaries.

    Returns
    -------
    params : dict
        ``omega0`` and the switched-on terms.
    info : dict
        ``offset_rad``, ``residual_rms`` [rad/s^2], ``condition`` (of the scaled matrix).
    """
    X, names = model.features(phi, dphi)
    if fit_offset:
        X = np.column_stack((X, np.ones(X.shape[0])))
        names = names + ["const"]
    y = -np.asarray(ddphi, float)
    if row_filter is not None:
        lengths = list(segments) if segments is not None else [y.size]
        Xs, ys, start = [], [], 0
        for L in lengths:
            Xi, yi = X[start:start + L], y[start:start + L]
            start += L
            if L < row_filter.size:
                continue
            Xs.append(np.column_stack([np.convolve(c, row_filter, mode="valid") for c in Xi.T]))
            ys.append(np.convolve(yi, row_filter, mode="valid"))
        X, y = np.vstack(Xs), np.concatenate(ys)
    norms = np.linalg.norm(X, axis=0)
    norms[norms == 0] = 1.0
    coef, _, rank, sv = np.linalg.lstsq(X / norms, y, rcond=None)
    coef = coef / norms
    vals = dict(zip(names, coef))
    w2 = float(vals.pop("omega0_sq"))
    params = {"omega0": math.sqrt(abs(w2))}
    for n in model.terms:
        params[n] = float(vals[n])
    res = y - X @ coef
    info = {
        "residual_rms": float(np.sqrt(np.mean(res**2))),
        "condition": float(sv[0] / sv[-1]) if sv.size and sv[-1] > 0 else float("inf"),
        "n_rows": int(X.shape[0]),
    }
    if fit_offset:
        info["offset_rad"] = float(-vals["const"] / w2) if w2 != 0 else 0.0
    return params, info


def _initial_guess(model: RollModel, records: Sequence[pd.DataFrame]) -> dict:
    """Log-decrement initial guess: decay-curve fit of the damping terms (pooled records)."""
    from studies.analysis.roll_decay import decay_curve, fit_decay_curve

    curve = pd.concat([decay_curve(r) for r in records], ignore_index=True)
    damp = [t for t in model.terms if t in ("b1", "b2", "b3")]
    g = fit_decay_curve(curve, damp)
    if "b1" not in model.terms and damp:
        g = fit_decay_curve(curve, damp)
    out = {"omega0": g["omega0"]}
    for t in model.terms:
        out[t] = float(g.get(t, 0.0))
    if "b1" in model.terms and "b1" not in g:
        out["b1"] = 0.0
    return out


def predict_record(params: dict, terms: Sequence[str], record: pd.DataFrame,
                   initial: tuple[float, float] | None = None) -> np.ndarray:
    """Simulate a record from its initial state with the identified model (RK4).

    Parameters
    ----------
    params : dict
        Identified coefficients.
    terms : sequence of str
        Terms of the model.
    record : DataFrame
        Prepared decay (``t`` [s], ``phi`` [rad]).
    initial : (phi0, dphi0), optional
        Initial state [rad, rad/s]; default from the record's first samples
        (:func:`studies.data.roll_decay.initial_state`).

    Returns
    -------
    ndarray
        Predicted roll angle [rad] at ``record.t``.
    """
    from studies.data.roll_decay import initial_state

    if initial is None:
        initial = initial_state(record)
    phi, _ = RollModel(tuple(terms)).simulate(params, initial[0], initial[1], record["t"].to_numpy(float))
    return phi


class _Estimator:
    """Common part: settings, timing, record handling."""

    name = "base"

    def __init__(self, terms: Sequence[str] = ("b1", "b2"), seed: int = 0):
        self.model = RollModel(tuple(terms))
        self.seed = int(seed)

    @property
    def terms(self) -> tuple[str, ...]:
        return self.model.terms

    def _prepare(self) -> None:
        """Work done once per process and not part of the method's cost (JIT compilation)."""

    def fit(self, record) -> RollFit:
        """Identify the roll model from one prepared record or a list of them.

        Parameters
        ----------
        record : DataFrame or sequence of DataFrame
            Prepared decay(s): ``t`` [s] from the release, ``phi`` [rad] about
            equilibrium, uniform step.

        Returns
        -------
        RollFit
        """
        records = _as_records(record)
        self._prepare()
        c0, w0 = time.process_time(), time.perf_counter()
        params, meta = self._fit(records)
        cpu = time.process_time() - c0
        meta = dict(meta)
        meta.update({"method": self.name, "terms": list(self.terms), "wall_s": time.perf_counter() - w0})
        return RollFit({k: float(v) for k, v in params.items()}, float(cpu), meta)

    def _fit(self, records):  # pragma: no cover - abstract
        raise NotImplementedError


# -------------------------------------------------------------------- NLS
class NLSEstimator(_Estimator):
    """Nonlinear least squares on the simulated trajectory (output error).

    Parameters
    ----------
    terms : sequence of str
        Model terms (see :class:`studies.models.roll.RollModel`).
    points_per_period : float
        Samples per roll period kept for the residual (the record is
        subsampled; the RK4 integration uses at least 60 steps per period).
    fit_initial_state : bool
        Estimate ``phi(0)`` and ``phi'(0)`` of each record with the coefficients.
    max_nfev : int
        Limit of function evaluations of ``least_squares``.
    seed : int
        Unused (deterministic); kept for a common interface.

    Notes
    -----
    Initial guess: ``omega0`` from the mean period and ``b1``, ``b2``, ``b3``
    from the decay curve (log decrement per half-cycle against amplitude),
    ``c3 = 0``.

    References
    ----------
    Chen, C. et al. (2019). Ocean Engineering 191, 106479, Section 5.2, Fig. 6.
    """

    name = "nls"

    def __init__(self, terms: Sequence[str] = ("b1", "b2"), points_per_period: float = 25.0,
                 fit_initial_state: bool = True, max_nfev: int = 200, seed: int = 0):
        super().__init__(terms, seed)
        self.points_per_period = float(points_per_period)
        self.fit_initial_state = bool(fit_initial_state)
        self.max_nfev = int(max_nfev)

    def _prepare(self) -> None:
        from studies.models.roll import _get_kernel

        _get_kernel()

    def _fit(self, records):
        from scipy.optimize import least_squares

        from studies.data.roll_decay import initial_state

        names = list(self.model.param_names)
        guess = _initial_guess(self.model, records)
        data = [_subsample(r, self.points_per_period)[:2] for r in records]
        inits = [initial_state(r) for r in records]
        x0 = [guess[n] for n in names]
        if self.fit_initial_state:
            for p0, v0 in inits:
                x0 += [p0, v0]
        x0 = np.asarray(x0, float)
        k = len(names)
        w_ref = guess["omega0"]
        amp = max(abs(p0) for p0, _ in inits)
        scale = {"omega0": w_ref, "b1": 0.05 * w_ref, "b2": 0.1, "b3": 0.1 / w_ref, "c3": w_ref**2}
        x_scale = [scale[n] for n in names]
        if self.fit_initial_state:
            x_scale += [amp, amp * w_ref] * len(records)
        lower = np.full(x0.size, -np.inf)
        lower[0] = 1e-6
        model = self.model

        def residual(x):
            p = dict(zip(names, x[:k]))
            out = []
            for j, (t, y) in enumerate(data):
                if self.fit_initial_state:
                    s0, v0 = x[k + 2 * j], x[k + 2 * j + 1]
                else:
                    s0, v0 = inits[j]
                phi, _ = model.simulate(p, s0, v0, t)
                out.append(phi - y)
            return np.concatenate(out)

        sol = least_squares(residual, x0, x_scale=np.asarray(x_scale), bounds=(lower, np.inf),
                            method="trf", max_nfev=self.max_nfev, xtol=1e-10, ftol=1e-10)
        params = dict(zip(names, sol.x[:k]))
        r = sol.fun
        meta = {
            "initial_guess": guess,
            "nfev": int(sol.nfev),
            "status": int(sol.status),
            "fit_rmse_deg": float(np.degrees(np.sqrt(np.mean(r**2)))),
            "n_points": int(r.size),
        }
        if self.fit_initial_state:
            meta["initial_states"] = [tuple(map(float, sol.x[k + 2 * j:k + 2 * j + 2]))
                                      for j in range(len(records))]
        return params, meta


# -------------------------------------------------------------------- FLS
class FLSEstimator(_Estimator):
    """Fitting least squares: smoothing-spline curve fit, derivatives, linear LS on the ODE.

    Parameters
    ----------
    terms : sequence of str
        Model terms.
    points_per_period : float
        Samples per roll period used for the spline (the record is subsampled).
    lam : float, optional
        Smoothing parameter of ``scipy.interpolate.make_smoothing_spline``
        [rad^2 s^3 scale]; default chosen per record by interleaved k-fold
        cross-validation over ``lam_grid`` (generalised cross-validation, the
        scipy default, over-smooths the measured decays completely).
    lam_grid : sequence of float
        Candidate smoothing parameters for time in roll periods and the output
        scaled to unit standard deviation.
    n_folds : int
        Cross-validation folds.
    edge_periods : float
        Part of the record at each end left out of the regression [periods]
        (spline end effects).
    fit_offset : bool
        Fit a constant heel offset in the regression.
    seed : int
        Unused (deterministic).

    References
    ----------
    Chen, C. et al. (2019). Ocean Engineering 191, 106479, Section 5.2, Fig. 7.
    """

    name = "fls"

    def __init__(self, terms: Sequence[str] = ("b1", "b2"), points_per_period: float = 50.0,
                 lam: float | None = None,
                 lam_grid: Sequence[float] = tuple(10.0 ** np.arange(-10.0, -1.0)),
                 n_folds: int = 5, edge_periods: float = 0.25, fit_offset: bool = True,
                 seed: int = 0):
        super().__init__(terms, seed)
        self.points_per_period = float(points_per_period)
        self.lam = lam
        self.lam_grid = tuple(float(v) for v in lam_grid)
        self.n_folds = int(n_folds)
        self.edge_periods = float(edge_periods)
        self.fit_offset = bool(fit_offset)

    def _select_lam(self, t, y, T):
        """Smoothing parameter by interleaved k-fold cross-validation (time in periods, unit-std output)."""
        from scipy.interpolate import make_smoothing_spline

        tn = (t - t[0]) / T
        yn = y / (np.std(y) or 1.0)
        n = tn.size
        scores = []
        for lam in self.lam_grid:
            err = 0.0
            for k in range(self.n_folds):
                val = np.arange(k, n, self.n_folds)
                tr = np.setdiff1d(np.arange(n), val)
                inner = val[(val > tr[0]) & (val < tr[-1])]
                spl = make_smoothing_spline(tn[tr], yn[tr], lam=lam)
                err += float(np.sum((spl(tn[inner]) - yn[inner]) ** 2))
            scores.append(err)
        i = int(np.argmin(scores))
        # the penalty scales with time^-3 and output^2: back to seconds and radians
        return float(self.lam_grid[i]) * T**3, scores

    def _fit(self, records):
        from scipy.interpolate import make_smoothing_spline

        cols = ([], [], [])
        lams = []
        for r in records:
            t, y, _ = _subsample(r, self.points_per_period)
            T = _period(r)
            if self.lam is None:
                lam, _ = self._select_lam(t, y, T)
            else:
                lam = float(self.lam)
            lams.append(lam)
            spl = make_smoothing_spline(t, y, lam=lam)
            edge = self.edge_periods * T
            m = (t >= t[0] + edge) & (t <= t[-1] - edge)
            te = t[m]
            cols[0].append(spl(te))
            cols[1].append(spl(te, 1))
            cols[2].append(spl(te, 2))
        phi, dphi, ddphi = (np.concatenate(c) for c in cols)
        params, info = ode_least_squares(self.model, phi, dphi, ddphi, self.fit_offset)
        info["smoothing_lam"] = lams
        return params, info


# ---------------------------------------------------------------- NLS-SVM
class NLSSVMEstimator(_Estimator):
    """NLS-SVM: LS-SVM state approximation with analytic derivatives, then LS on the ODE.

    Parameters
    ----------
    terms : sequence of str
        Model terms.
    points_per_period : float
        Samples per roll period for the kernel fit (the record is subsampled).
    n_phases : int
        Number of interleaved subsamples fitted (each shifted by one original
        sample); their regression rows are pooled so that more of a densely
        sampled record is used. 1 = the paper's single fit.
    sigma_grid : sequence of float
        Kernel widths to try, in roll periods.
    gamma_grid : sequence of float
        Regularisation factors to try (outputs scaled to unit standard deviation).
    n_folds : int, optional
        Cross-validation folds for ``cv_mode`` "interleaved" or "blocked".
    cv_mode : {"loo", "interleaved", "blocked"}
        Fold layout (see :func:`studies.identify.lssvm.cv_select`); default
        exact leave-one-out (interleaved folds of one sample).
    window_periods, stride_periods : float
        Length and spacing of the overlapping LS-SVM windows [periods].
    cv_windows : int
        Number of windows (evenly spread over the records) used for the
        cross-validation.
    edge_periods : float
        Part of each record at each end left out of the regression [periods].
    fit_offset : bool
        Fit a constant heel offset in the regression.
    seed : int
        Seed of the choice of cross-validation windows when there are more
        candidates than ``cv_windows`` (the default spreads them evenly).

    References
    ----------
    Chen, C. et al. (2019). Ocean Engineering 191, 106479, eq. (6)-(16), Table 4.
    """

    name = "nls_svm"

    def __init__(self, terms: Sequence[str] = ("b1", "b2"), points_per_period: float = 20.0,
                 n_phases: int = 1,
                 sigma_grid: Sequence[float] = (0.06, 0.08, 0.1, 0.12, 0.15, 0.18, 0.22, 0.27, 0.33),
                 gamma_grid: Sequence[float] = tuple(10.0 ** np.arange(0, 13)),
                 n_folds: int | None = None, cv_mode: str = "loo", window_periods: float = 4.0,
                 stride_periods: float = 2.0, cv_windows: int = 4, edge_periods: float = 0.25,
                 fit_offset: bool = True, seed: int = 0):
        super().__init__(terms, seed)
        self.points_per_period = float(points_per_period)
        self.n_phases = int(n_phases)
        self.sigma_grid = tuple(float(s) for s in sigma_grid)
        self.gamma_grid = tuple(float(g) for g in gamma_grid)
        self.n_folds = None if n_folds is None else int(n_folds)
        self.cv_mode = cv_mode
        self.window_periods = float(window_periods)
        self.stride_periods = float(stride_periods)
        self.cv_windows = int(cv_windows)
        self.edge_periods = float(edge_periods)
        self.fit_offset = bool(fit_offset)

    def _cv_segments(self, records, T):
        """A few windows spread over the records, outputs scaled to unit std."""
        cands = []
        for r in records:
            t, y, _ = _subsample(r, self.points_per_period)
            L = self.window_periods * T
            n = max(1, int((t[-1] - t[0] - L) // (self.stride_periods * T)) + 1)
            for w in range(n):
                s = t[0] + w * self.stride_periods * T
                m = (t >= s) & (t <= s + L)
                if m.sum() >= 2 * (self.n_folds or 5):
                    yy = y[m]
                    cands.append((t[m] / T, yy / (np.std(yy) or 1.0)))
        if len(cands) <= self.cv_windows:
            return cands
        pick = np.unique(np.round(np.linspace(0, len(cands) - 1, self.cv_windows)).astype(int))
        return [cands[i] for i in pick]

    def _fit(self, records):
        from studies.identify.lssvm import WindowedLSSVM, cv_select

        T = float(np.median([_period(r) for r in records]))
        segs = self._cv_segments(records, T)
        s_rel, gamma, scores = cv_select(segs, self.sigma_grid, self.gamma_grid, self.n_folds, self.cv_mode)
        sigma = s_rel * T
        cols = ([], [], [])
        n_fits = 0
        for r in records:
            step = _subsample(r, self.points_per_period)[2]
            for ph in range(min(self.n_phases, step)):
                t, y, _ = _subsample(r, self.points_per_period, phase=int(round(ph * step / self.n_phases)))
                ws = WindowedLSSVM(sigma, gamma, self.window_periods * T, self.stride_periods * T).fit(t, y)
                n_fits += len(ws.models_)
                edge = self.edge_periods * T
                m = (t >= r["t"].iloc[0] + edge) & (t <= r["t"].iloc[-1] - edge)
                te = t[m]
                cols[0].append(ws.predict(te, 0))
                cols[1].append(ws.predict(te, 1))
                cols[2].append(ws.predict(te, 2))
        phi, dphi, ddphi = (np.concatenate(c) for c in cols)
        params, info = ode_least_squares(self.model, phi, dphi, ddphi, self.fit_offset)
        i, j = np.unravel_index(int(np.argmin(scores)), scores.shape)
        info.update({
            "sigma_s": sigma,
            "sigma_periods": s_rel,
            "gamma": gamma,
            "cv_mse": float(scores[i, j]),
            "n_windows": n_fits,
            "period_s": T,
        })
        return params, info


ESTIMATORS = {"nls": NLSEstimator, "fls": FLSEstimator, "nls_svm": NLSSVMEstimator}


def make_estimator(method: str, terms: Sequence[str] = ("b1", "b2"), seed: int = 0, **settings):
    """Estimator for ``method`` in ``{"nls", "fls", "nls_svm"}``.

    Raises
    ------
    ValueError
        Unknown method.
    """
    try:
        cls = ESTIMATORS[method]
    except KeyError:
        raise ValueError(f"unknown roll identification method '{method}'; choose from {sorted(ESTIMATORS)}") from None
    return cls(terms=terms, seed=seed, **settings)
