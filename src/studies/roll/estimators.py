"""Identification of the roll-decay model: NLS, FLS and NLS-SVM (Chen et al., 2019).

Three estimators with the same interface, each a small class whose
constructor stores the settings and whose ``fit(record)`` returns a
:class:`RollFit` (``params``, ``cpu_s``, ``meta``). ``record`` is a prepared
decay (``DataFrame`` with ``t`` [s] from the release and ``phi`` [rad] about
equilibrium; see :func:`studies.roll.records.load_roll_decay`) or a list of
them (identified jointly). A record is predicted with the identified model
by :func:`studies.roll.simulate.predict_record`.

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

import abc
import math
import time
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
import pandas as pd
from scipy.interpolate import make_smoothing_spline
from scipy.optimize import least_squares

from studies.roll.decay import decay_curve, estimate_period, fit_decay_curve
from studies.roll.lssvm import WindowedLSSVM, cv_select
from studies.roll.model import RollModel, compiled_rk4
from studies.roll.records import initial_state
from studies.threads import single_thread_blas

__all__ = [
    "RollFit",
    "NLSEstimator",
    "FLSEstimator",
    "NLSSVMEstimator",
    "ESTIMATORS",
    "make_estimator",
    "ode_least_squares",
    "harmonic_filter",
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
        Method details (settings chosen by cross-validation, residuals, wall
        time, ...) and ``initial_states``: the method's own estimate of each
        record's initial state ``(phi0 [rad], dphi0 [rad/s])`` at its first
        sample (how it was obtained: the estimator's
        :attr:`~_Estimator.initial_state_source`).
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
    """Log-decrement initial guess: decay-curve fit of the damping terms (pooled records).

    ``omega0`` from the median half period, the damping terms from the
    decrement per half-cycle against amplitude (see
    :func:`studies.roll.decay.fit_decay_curve`), ``c3 = 0``.
    """
    curve = pd.concat([decay_curve(r) for r in records], ignore_index=True)
    damp = [t for t in model.terms if t in ("b1", "b2", "b3")]
    g = fit_decay_curve(curve, damp)
    out = {"omega0": g["omega0"]}
    for t in model.terms:
        out[t] = float(g.get(t, 0.0))
    return out


class _Estimator(abc.ABC):
    """Common part: settings, timing, record handling."""

    name = "base"
    #: how the method's own initial state of a record (``meta["initial_states"]``) is obtained
    initial_state_source = "the record's (no estimate of its own)"

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
        with single_thread_blas():
            c0, w0 = time.process_time(), time.perf_counter()
            params, meta = self._fit(records)
            cpu = time.process_time() - c0
        meta = dict(meta)
        meta.setdefault("initial_states", [initial_state(r) for r in records])
        meta.update({"method": self.name, "terms": list(self.terms), "wall_s": time.perf_counter() - w0,
                     "initial_state_source": self.initial_state_source})
        return RollFit({k: float(v) for k, v in params.items()}, float(cpu), meta)

    @abc.abstractmethod
    def _fit(self, records):
        """Identify from prepared records; returns ``(params, meta)``."""


# -------------------------------------------------------------------- NLS
class NLSEstimator(_Estimator):
    """Nonlinear least squares on the simulated trajectory (output error).

    Parameters
    ----------
    terms : sequence of str
        Model terms (see :class:`studies.roll.model.RollModel`).
    points_per_period : float, optional
        Samples per roll period kept for the residual (the record is
        subsampled); default every sample. The RK4 integration uses at least
        60 steps per period in any case.
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
    initial_state_source = "fitted with the coefficients (output error)"

    def __init__(self, terms: Sequence[str] = ("b1", "b2"), points_per_period: float | None = None,
                 fit_initial_state: bool = True, max_nfev: int = 200, seed: int = 0):
        super().__init__(terms, seed)
        self.points_per_period = None if points_per_period is None else float(points_per_period)
        self.fit_initial_state = bool(fit_initial_state)
        if not self.fit_initial_state:
            self.initial_state_source = _Estimator.initial_state_source
        self.max_nfev = int(max_nfev)

    def _prepare(self) -> None:
        compiled_rk4()

    def _fit(self, records):
        names = list(self.model.param_names)
        guess = _initial_guess(self.model, records)
        if self.points_per_period is None:
            data = [(r["t"].to_numpy(float), r["phi"].to_numpy(float)) for r in records]
        else:
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
        else:
            meta["initial_states"] = [tuple(map(float, s)) for s in inits]
        return params, meta


# ------------------------------------------------------- equation error
class _EquationErrorEstimator(_Estimator):
    """Curve fit first, analytic derivatives, then linear least squares on the ODE.

    Shared by FLS and NLS-SVM, which differ only in the smoother. For every
    record the smoother is fitted to ``n_phases`` interleaved subsamples
    (offset by one original sample each, ``points_per_period`` samples per
    period) and the values and derivatives are averaged on a uniform grid of
    ``eval_per_period`` points per period (so that a densely sampled record
    is used in full while each fit stays small). The equation rows are then
    passed through :func:`harmonic_filter` (``harmonics``) before solving:
    the ODE holds at every instant, hence for any weighted sum of instants,
    and the filter removes the higher harmonics of ``|phi'| phi'`` (and of
    the noise amplified by the second derivative) that a smoother cannot
    reproduce from noisy data. Without it (``harmonics=()``: the pointwise
    eq. 15-16 of Chen et al.) the smoothed record lacks the third harmonic
    that the quadratic term generates, and ``b2`` is biased low by tens of
    per cent at 1 % noise, with ``b1`` compensating.

    Their own initial state of a record (``meta["initial_states"]``) is the
    smoother's angle and rate at the record's first sample, averaged over
    the interleaved fits: what the curve fit says the decay starts from
    (an edge value: the regression itself leaves ``edge_periods`` out).
    """

    initial_state_source = "the curve fit (smoother) at the first sample"

    def __init__(self, terms=("b1", "b2"), points_per_period: float = 20.0, n_phases: int | None = None,
                 eval_per_period: int = 60, harmonics: Sequence[int] = (2, 3, 4, 5),
                 edge_periods: float = 0.25, fit_offset: bool = True, seed: int = 0):
        super().__init__(terms, seed)
        self.points_per_period = float(points_per_period)
        self.n_phases = None if n_phases is None else int(n_phases)
        self.eval_per_period = int(eval_per_period)
        self.harmonics = tuple(int(h) for h in harmonics)
        self.edge_periods = float(edge_periods)
        self.fit_offset = bool(fit_offset)

    MAX_PHASES = 16

    def _phases(self, step: int) -> list[int]:
        n = step if self.n_phases is None else min(self.n_phases, step)
        n = max(1, min(n, self.MAX_PHASES))
        return sorted({int(round(k * step / n)) for k in range(n)})

    @abc.abstractmethod
    def _select(self, records, T) -> dict:
        """Choose the smoother's settings (cross-validation); returns them as a dict."""

    @abc.abstractmethod
    def _smoother(self, t, y, T, settings):
        """Fitted smoother: a callable ``f(t, order)`` for order 0, 1, 2."""

    def _fit(self, records):
        T = float(np.median([_period(r) for r in records]))
        settings = self._select(records, T)
        cols = ([], [], [])
        lengths = []
        starts = []
        n_fits = 0
        for r in records:
            t_all = r["t"].to_numpy(float)
            step = _subsample(r, self.points_per_period)[2]
            edge = self.edge_periods * T
            te = np.arange(t_all[0] + edge, t_all[-1] - edge, T / self.eval_per_period)
            acc = [np.zeros(te.size) for _ in range(3)]
            start = np.zeros(2)
            phases = self._phases(step)
            for ph in phases:
                t, y, _ = _subsample(r, self.points_per_period, phase=ph)
                f = self._smoother(t, y, T, settings)
                n_fits += 1
                for k in range(3):
                    acc[k] += f(te, k)
                for k in range(2):
                    start[k] += float(f(t_all[:1], k)[0])
            for k in range(3):
                cols[k].append(acc[k] / len(phases))
            lengths.append(te.size)
            starts.append(tuple(float(v) for v in start / len(phases)))
        phi, dphi, ddphi = (np.concatenate(c) for c in cols)
        filt = harmonic_filter(self.eval_per_period, self.harmonics) if self.harmonics else None
        params, info = ode_least_squares(self.model, phi, dphi, ddphi, self.fit_offset,
                                         row_filter=filt, segments=lengths)
        info.update(settings)
        info.update({"n_fits": n_fits, "period_s": T, "harmonics_removed": list(self.harmonics),
                     "initial_states": starts})
        return params, info


# -------------------------------------------------------------------- FLS
class FLSEstimator(_EquationErrorEstimator):
    """Fitting least squares: smoothing-spline curve fit, derivatives, linear LS on the ODE.

    Parameters
    ----------
    terms : sequence of str
        Model terms.
    points_per_period : float
        Samples per roll period in each spline fit (the record is subsampled).
    n_phases : int, optional
        Interleaved subsamples fitted and averaged; default all (at most 16).
    lam : float, optional
        Smoothing parameter of ``scipy.interpolate.make_smoothing_spline``
        (for time in seconds); default chosen by interleaved k-fold
        cross-validation over ``lam_grid`` (generalised cross-validation, the
        scipy default, over-smooths the measured decays completely).
    lam_grid : sequence of float
        Candidate smoothing parameters for time in roll periods and the output
        scaled to unit standard deviation.
    n_folds : int
        Cross-validation folds.
    cv_points : int
        At most this many samples (from the middle of the first record) are
        used for the cross-validation.
    eval_per_period, harmonics, edge_periods, fit_offset
        See the equation-error notes (:class:`NLSSVMEstimator`).
    seed : int
        Unused (deterministic).

    References
    ----------
    Chen, C. et al. (2019). Ocean Engineering 191, 106479, Section 5.2, Fig. 7.
    """

    name = "fls"

    def __init__(self, terms: Sequence[str] = ("b1", "b2"), points_per_period: float = 50.0,
                 n_phases: int | None = None, lam: float | None = None,
                 lam_grid: Sequence[float] = tuple(10.0 ** np.arange(-10.0, -0.9, 0.5)),
                 n_folds: int = 5, cv_points: int = 2000, eval_per_period: int = 60,
                 harmonics: Sequence[int] = (2, 3, 4, 5), edge_periods: float = 0.25,
                 fit_offset: bool = True, seed: int = 0):
        super().__init__(terms, points_per_period, n_phases, eval_per_period, harmonics, edge_periods,
                         fit_offset, seed)
        self.lam = lam
        self.lam_grid = tuple(float(v) for v in lam_grid)
        self.n_folds = int(n_folds)
        self.cv_points = int(cv_points)

    def _select(self, records, T):
        if self.lam is not None:
            return {"smoothing_lam": float(self.lam)}
        t, y, _ = _subsample(records[0], self.points_per_period)
        if t.size > self.cv_points:
            a = (t.size - self.cv_points) // 2
            t, y = t[a:a + self.cv_points], y[a:a + self.cv_points]
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
        # the roughness penalty scales with time^-3 (output scale cancels): back to seconds
        return {"smoothing_lam": float(self.lam_grid[i]) * T**3, "smoothing_lam_periods": float(self.lam_grid[i])}

    def _smoother(self, t, y, T, settings):
        spl = make_smoothing_spline(t, y, lam=settings["smoothing_lam"])
        return lambda te, k: spl(te, k) if k else spl(te)


# ---------------------------------------------------------------- NLS-SVM
class NLSSVMEstimator(_EquationErrorEstimator):
    """NLS-SVM: LS-SVM state approximation with analytic derivatives, then LS on the ODE.

    Steps of Chen et al. (2019), Table 4: (1) samples of the decay; (2) the
    LS-SVM with RBF kernel approximates ``phi(t)`` (eq. 6-11); (3) its
    analytic time derivatives give ``phi'`` and ``phi''`` (eq. 12-14);
    (4) linear least squares on the ODE gives the coefficients (eq. 15-16).

    Parameters
    ----------
    terms : sequence of str
        Model terms.
    points_per_period : float
        Samples per roll period in each kernel fit (the record is subsampled).
    n_phases : int, optional
        Interleaved subsamples (each shifted by one original sample) fitted
        and averaged so that all of a densely sampled record is used; default
        all of them (at most 16). 1 = the paper's single fit.
    sigma_grid : sequence of float
        Kernel widths to try, in roll periods.
    gamma_grid : sequence of float
        Regularisation factors to try (outputs scaled to unit standard deviation).
    n_folds : int, optional
        Cross-validation folds for ``cv_mode`` "interleaved" or "blocked".
    cv_mode : {"loo", "interleaved", "blocked"}
        Fold layout (see :func:`studies.roll.lssvm.cv_select`); default
        exact leave-one-out (interleaved folds of one sample).
    window_periods, stride_periods : float
        Length and spacing of the overlapping LS-SVM windows [periods].
    cv_windows : int
        Number of windows (evenly spread over the records) used for the
        cross-validation.
    eval_per_period : int
        Points per period of the uniform grid on which the equation is written.
    harmonics : sequence of int
        Harmonics of the roll frequency removed from the equation rows before
        the least squares (:func:`harmonic_filter`); ``()`` = pointwise eq. 15-16.
    edge_periods : float
        Part of each record at each end left out of the regression [periods].
    fit_offset : bool
        Fit a constant heel offset in the regression.
    seed : int
        Unused (deterministic); kept for a common interface.

    Notes
    -----
    See :class:`_EquationErrorEstimator` for why the equation rows are
    filtered. Kernel fits are windowed (:class:`studies.roll.lssvm.WindowedLSSVM`)
    so that a 3-minute record at 100 Hz costs well under a second.

    References
    ----------
    Chen, C. et al. (2019). Ocean Engineering 191, 106479, eq. (6)-(16), Table 4.
    """

    name = "nls_svm"

    def __init__(self, terms: Sequence[str] = ("b1", "b2"), points_per_period: float = 20.0,
                 n_phases: int | None = None,
                 sigma_grid: Sequence[float] = (0.06, 0.08, 0.1, 0.12, 0.15, 0.18, 0.22, 0.27, 0.33),
                 gamma_grid: Sequence[float] = tuple(10.0 ** np.arange(0, 13)),
                 n_folds: int | None = None, cv_mode: str = "loo", window_periods: float = 4.0,
                 stride_periods: float = 2.0, cv_windows: int = 4, eval_per_period: int = 60,
                 harmonics: Sequence[int] = (2, 3, 4, 5), edge_periods: float = 0.25,
                 fit_offset: bool = True, seed: int = 0):
        super().__init__(terms, points_per_period, n_phases, eval_per_period, harmonics, edge_periods,
                         fit_offset, seed)
        self.sigma_grid = tuple(float(s) for s in sigma_grid)
        self.gamma_grid = tuple(float(g) for g in gamma_grid)
        self.n_folds = None if n_folds is None else int(n_folds)
        self.cv_mode = cv_mode
        self.window_periods = float(window_periods)
        self.stride_periods = float(stride_periods)
        self.cv_windows = int(cv_windows)

    def _cv_segments(self, records, T):
        """A few windows spread over the records (time in periods, outputs scaled to unit std)."""
        cands = []
        for r in records:
            t, y, _ = _subsample(r, self.points_per_period)
            L = self.window_periods * T
            n = max(1, int((t[-1] - t[0] - L) // (self.stride_periods * T)) + 1)
            for w in range(n):
                s = t[0] + w * self.stride_periods * T
                m = (t >= s) & (t <= s + L)
                if m.sum() >= 10:
                    yy = y[m]
                    cands.append((t[m] / T, yy / (np.std(yy) or 1.0)))
        if len(cands) <= self.cv_windows:
            return cands
        pick = np.unique(np.round(np.linspace(0, len(cands) - 1, self.cv_windows)).astype(int))
        return [cands[i] for i in pick]

    def _select(self, records, T):
        segs = self._cv_segments(records, T)
        s_rel, gamma, scores = cv_select(segs, self.sigma_grid, self.gamma_grid, self.n_folds, self.cv_mode)
        return {"sigma_s": s_rel * T, "sigma_periods": s_rel, "gamma": gamma,
                "cv_mse": float(np.min(scores)), "cv_mode": self.cv_mode}

    def _smoother(self, t, y, T, settings):
        ws = WindowedLSSVM(settings["sigma_s"], settings["gamma"], self.window_periods * T,
                           self.stride_periods * T).fit(t, y)
        return ws.predict


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
