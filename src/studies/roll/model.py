"""One-degree-of-freedom roll-decay model (Chen et al., 2019, eq. 1-3).

The roll equation of Chen et al. (2019), eq. (3),

    (I_xx + A_44) phi'' + B_44 phi' + B_44q |phi'| phi' + int h_44 phi' dtau + C_44 phi = 0,

divided by the total inertia ``I = I_xx + A_44`` gives the form used here,

    phi'' + b1 phi' + b2 |phi'| phi' [+ b3 phi'^3] + omega0^2 phi [+ c3 phi^3] = 0,

with ``b1 = B_44 / I`` [1/s], ``b2 = B_44q / I`` [-], ``b3 = B_44c / I`` [s],
``omega0^2 = C_44 / I`` [1/s^2] and ``c3 = C_44c / I`` [1/s^2]. The memory-effect
convolution ``int h_44(t - tau) phi'(tau) dtau`` (radiation damping with a
frequency-dependent kernel) is left out: in a free decay the ship oscillates
near its natural frequency, so the radiation damping at that frequency is
absorbed into ``b1`` (and the frequency-dependent added inertia into
``omega0``). The identified coefficients are therefore *equivalent*
coefficients at the roll natural frequency, as in the paper, which also
leaves ``h_44`` out of its identification.

:meth:`RollModel.simulate` is the one integrator of the roll equation
(fixed-step RK4, :func:`compiled_rk4`); :mod:`studies.roll.simulate` predicts
records and writes synthetic decays with it. Nothing is computed at import
time; the numba kernel is compiled on the first simulation (and cached on
disk by numba).

References
----------
Chen, C., Tello Ruiz, M., Delefortrie, G., Mei, T., Vantorre, M., Lataire, E.
(2019). Parameter estimation for a ship's roll response model in shallow water
using an intelligent machine learning method. Ocean Engineering 191, 106479.
https://doi.org/10.1016/j.oceaneng.2019.106479
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

__all__ = [
    "OPTIONAL_TERMS",
    "RollModel",
    "compiled_rk4",
    "compiled_decays_sse",
    "dimensional_coefficients",
    "froude_scale_params",
    "equivalent_linear_damping",
    "damping_ratio",
]

log = logging.getLogger(__name__)

#: Optional terms in canonical order; ``omega0`` is always part of the model.
OPTIONAL_TERMS: tuple[str, ...] = ("b1", "b2", "b3", "c3")

#: Units of the non-dimensionalised (divided by inertia) coefficients.
UNITS: dict[str, str] = {"omega0": "rad/s", "b1": "1/s", "b2": "-", "b3": "s", "c3": "1/s^2"}

_CLIP = 1.0e3  # [rad] a trajectory beyond this has diverged; it is clipped to stay finite


def _rk4_kernel(phi0, dphi0, t, b1, b2, b3, w2, c3, nsub, dw2, db1):  # pragma: no cover - compiled
    """Fixed-step RK4 of the roll equation on the grid ``t`` with ``nsub`` sub-steps.

    ``dw2`` and ``db1`` are added to ``omega0^2`` and ``b1`` over each output
    interval (arrays of ``len(t) - 1``; empty arrays: no perturbation), the
    coefficient wander of a replay with a model discrepancy
    (:mod:`studies.roll.discrepancy`). Plain Python so that numba can compile
    it; also usable uncompiled.
    """
    n = t.shape[0]
    out = np.empty((n, 2))
    x = phi0
    v = dphi0
    out[0, 0] = x
    out[0, 1] = v
    wander = dw2.shape[0] > 0
    diverged = False
    for i in range(n - 1):
        if diverged:
            out[i + 1, 0] = x
            out[i + 1, 1] = v
            continue
        h = (t[i + 1] - t[i]) / nsub
        bb = b1
        ww = w2
        if wander:
            bb = b1 + db1[i]
            ww = w2 + dw2[i]
        for _ in range(nsub):
            k1x = v
            k1v = -(bb * v + b2 * abs(v) * v + b3 * v * v * v + ww * x + c3 * x * x * x)
            x2 = x + 0.5 * h * k1x
            v2 = v + 0.5 * h * k1v
            k2x = v2
            k2v = -(bb * v2 + b2 * abs(v2) * v2 + b3 * v2 * v2 * v2 + ww * x2 + c3 * x2 * x2 * x2)
            x3 = x + 0.5 * h * k2x
            v3 = v + 0.5 * h * k2v
            k3x = v3
            k3v = -(bb * v3 + b2 * abs(v3) * v3 + b3 * v3 * v3 * v3 + ww * x3 + c3 * x3 * x3 * x3)
            x4 = x + h * k3x
            v4 = v + h * k3v
            k4x = v4
            k4v = -(bb * v4 + b2 * abs(v4) * v4 + b3 * v4 * v4 * v4 + ww * x4 + c3 * x4 * x4 * x4)
            x = x + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x)
            v = v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v)
        if not (abs(x) < 1.0e3 and abs(v) < 1.0e6):  # also catches NaN
            x = 1.0e3 if not (x < 0.0) else -1.0e3
            v = 0.0
            diverged = True
        out[i + 1, 0] = x
        out[i + 1, 1] = v
    return out


#: the empty perturbation of :func:`_rk4_kernel` (no coefficient wander)
NO_WANDER = np.empty(0)


_COMPILED: dict[str, object] = {}


def compiled_rk4():
    """The RK4 kernel of the roll equation, numba-compiled on the first call.

    Later calls return the same function. Without numba (or when compilation
    fails) the plain-Python kernel is returned, about 100 times slower. Call it
    ahead of a timed identification so that the compilation is not timed.
    """
    kern = _COMPILED.get("rk4")
    if kern is None:
        kern = _rk4_kernel  # fallback: plain Python (about 100x slower)
        for cache in (True, False):  # the on-disk cache needs a writable location
            try:
                import numba  # heavy: loaded only when a decay is first simulated

                cand = numba.njit(cache=cache, nogil=True)(_rk4_kernel)
                # compile now with representative types so that callers' timings are clean
                cand(0.1, 0.0, np.array([0.0, 0.1]), 0.0, 0.0, 0.0, 1.0, 0.0, 1, NO_WANDER, NO_WANDER)
                kern = cand
                break
            except Exception as exc:  # noqa: BLE001 - numba's errors are of many types
                failure = exc
                continue
        else:
            log.warning("numba cannot compile the roll simulator (%s): it runs in plain Python, about 100 times "
                        "slower", failure)
        _COMPILED["rk4"] = kern
    return kern


def _decays_sse_factory(rk4):
    """The batched output-error sum of squares of several coefficient sets over several decays,
    calling the (compiled) RK4 kernel ``rk4``: see :func:`compiled_decays_sse`."""

    def decays_sse(coef, starts, t_all, y_all, offsets, a, autoregressive, steps_per_period,
                   no_wander):  # pragma: no cover
        n_sets = coef.shape[0]
        n_records = offsets.shape[0] - 1
        out = np.empty(n_sets)
        for w in range(n_sets):
            b1, b2, b3, w2, c3 = coef[w, 0], coef[w, 1], coef[w, 2], coef[w, 3], coef[w, 4]
            w0 = math.sqrt(abs(w2)) if w2 != 0.0 else 1.0
            a1, a2 = a[w, 0], a[w, 1]
            total = 0.0
            for j in range(n_records):
                t = t_all[offsets[j]:offsets[j + 1]]
                y = y_all[offsets[j]:offsets[j + 1]]
                nsub = max(1, int(math.ceil((t[1] - t[0]) * w0 * steps_per_period / (2.0 * math.pi) - 1e-9)))
                phi = rk4(starts[w, 2 * j], starts[w, 2 * j + 1], t, b1, b2, b3, w2, c3, nsub,
                          no_wander, no_wander)
                r2 = y[1] - phi[1, 0]
                r1 = y[0] - phi[0, 0]
                if not autoregressive:
                    total += r1 * r1 + r2 * r2
                for i in range(2, t.shape[0]):
                    r = y[i] - phi[i, 0]
                    e = r - a1 * r2 - a2 * r1
                    total += e * e
                    r1 = r2
                    r2 = r
            out[w] = total
        return out

    return decays_sse


def compiled_decays_sse():
    """``decays_sse(coef, starts, t_all, y_all, offsets, a, autoregressive, steps_per_period, no_wander)``:
    the sum of squared innovations of each coefficient set's replay of every decay, compiled.

    ``coef`` (sets x 5) holds ``(b1, b2, b3, omega0^2, c3)`` per set; ``starts``
    (sets x 2 records) the initial roll angle [rad] and rate [rad/s] of each
    record; ``t_all``, ``y_all`` the records' compared times [s] and angles
    [rad] one after the other, record ``j`` at ``offsets[j]:offsets[j + 1]``;
    with ``autoregressive``, ``a`` (sets x 2) holds the AR(2) coefficients
    ``(a1, a2)`` of the innovations ``e_i = r_i - a1 r_{i-1} - a2 r_{i-2}``
    (the first two samples of each record dropped); without, ``a`` is zeros
    and every sample's residual counts; each record is
    integrated with ``steps_per_period`` RK4 steps per natural period as
    :func:`compiled_rk4`. One call replaces a Python loop over sets and
    records (a posterior's walkers): the same arithmetic, without the call
    overhead. Falls back to plain Python like :func:`compiled_rk4`.
    """
    kern = _COMPILED.get("decays_sse")
    if kern is None:
        rk4 = compiled_rk4()
        kern = _decays_sse_factory(rk4)
        if rk4 is not _rk4_kernel:
            try:
                import numba

                cand = numba.njit(nogil=True)(kern)
                cand(np.array([[0.0, 0.0, 0.0, 1.0, 0.0]]), np.array([[0.1, 0.0]]), np.array([0.0, 0.1, 0.2]),
                     np.zeros(3), np.array([0, 3]), np.zeros((1, 2)), True, 60.0, NO_WANDER)
                kern = cand
            except Exception as exc:  # noqa: BLE001 - numba's errors are of many types
                log.warning("numba cannot compile the batched decays (%s): plain Python", exc)
        _COMPILED["decays_sse"] = kern
    return kern


@dataclass(frozen=True)
class RollModel:
    """Roll-decay model with selectable damping and restoring terms.

    Parameters
    ----------
    terms : sequence of str
        Optional terms switched on, any of ``"b1"`` (linear damping, 1/s),
        ``"b2"`` (quadratic damping ``|phi'| phi'``, -), ``"b3"`` (cubic damping
        ``phi'^3``, s) and ``"c3"`` (cubic restoring ``phi^3``, 1/s^2). ``omega0``
        (natural frequency, rad/s) is always on. Default ``("b1", "b2")``.

    Notes
    -----
    Equation (divided by the total inertia ``I = I_xx + A_44``)::

        phi'' + b1 phi' + b2 |phi'| phi' + b3 phi'^3 + omega0^2 phi + c3 phi^3 = 0

    The memory-effect convolution of Chen et al. (2019), eq. (2)-(3), is left
    out (see the module docstring).

    References
    ----------
    Chen, C. et al. (2019). Parameter estimation for a ship's roll response model
    in shallow water using an intelligent machine learning method. Ocean
    Engineering 191, 106479, eq. (1)-(3).
    """

    terms: tuple[str, ...] = ("b1", "b2")

    def __post_init__(self):
        terms = tuple(self.terms)
        unknown = [t for t in terms if t not in OPTIONAL_TERMS]
        if unknown:
            raise ValueError(f"unknown roll-model term(s) {unknown}; choose from {list(OPTIONAL_TERMS)}")
        ordered = tuple(t for t in OPTIONAL_TERMS if t in terms)
        object.__setattr__(self, "terms", ordered)

    # ------------------------------------------------------------------ names
    @property
    def param_names(self) -> tuple[str, ...]:
        """Names of the parameters: ``omega0`` then the switched-on terms."""
        return ("omega0",) + self.terms

    def coefficients(self, params: Mapping[str, float]) -> tuple[float, float, float, float, float]:
        """Return ``(b1, b2, b3, omega0**2, c3)`` with switched-off terms set to zero.

        Parameters
        ----------
        params : mapping
            ``omega0`` [rad/s] and the switched-on terms; keys of terms that are
            off are ignored.
        """
        missing = [n for n in self.param_names if n not in params]
        if missing:
            raise KeyError(f"roll parameters missing: {missing}")
        g = lambda n: float(params[n]) if n in self.terms else 0.0  # noqa: E731
        w0 = float(params["omega0"])
        return g("b1"), g("b2"), g("b3"), w0 * w0, g("c3")

    # -------------------------------------------------------------- dynamics
    def rhs(self, phi, dphi, params: Mapping[str, float]):
        """Roll acceleration ``phi''`` [rad/s^2] for roll angle and rate.

        Parameters
        ----------
        phi : float or ndarray
            Roll angle [rad].
        dphi : float or ndarray
            Roll rate [rad/s].
        params : mapping
            Model parameters (see :attr:`param_names`).

        Returns
        -------
        float or ndarray
            ``-(b1 phi' + b2 |phi'| phi' + b3 phi'^3 + omega0^2 phi + c3 phi^3)``.
        """
        b1, b2, b3, w2, c3 = self.coefficients(params)
        phi = np.asarray(phi, dtype=float)
        dphi = np.asarray(dphi, dtype=float)
        return -(b1 * dphi + b2 * np.abs(dphi) * dphi + b3 * dphi**3 + w2 * phi + c3 * phi**3)

    def features(self, phi, dphi) -> tuple[np.ndarray, list[str]]:
        """Regressors of the linear-in-parameters form ``-phi'' = X theta``.

        Parameters
        ----------
        phi, dphi : ndarray
            Roll angle [rad] and rate [rad/s].

        Returns
        -------
        X : ndarray, shape (n, k)
            Columns in the order of the returned names.
        names : list of str
            ``b1``, ``b2``, ``b3`` (when on), ``omega0_sq``, ``c3`` (when on).
        """
        phi = np.asarray(phi, dtype=float)
        dphi = np.asarray(dphi, dtype=float)
        cols, names = [], []
        feats = {
            "b1": dphi,
            "b2": np.abs(dphi) * dphi,
            "b3": dphi**3,
            "omega0_sq": phi,
            "c3": phi**3,
        }
        for name in ("b1", "b2", "b3", "omega0_sq", "c3"):
            if name == "omega0_sq" or name in self.terms:
                cols.append(feats[name])
                names.append(name)
        return np.column_stack(cols), names

    def simulate(self, params: Mapping[str, float], phi0: float, dphi0: float, t,
                 max_step: float | None = None, wander: tuple | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Simulate a free decay with fixed-step fourth-order Runge-Kutta.

        Parameters
        ----------
        params : mapping
            ``omega0`` [rad/s] and the switched-on terms.
        phi0 : float
            Initial roll angle [rad] at ``t[0]``.
        dphi0 : float
            Initial roll rate [rad/s] at ``t[0]``.
        t : array_like
            Increasing output times [s]; the integration steps from sample to
            sample.
        max_step : float, optional
            Largest integration step [s]; each output interval is split into
            ``ceil(dt / max_step)`` RK4 steps. Default: ``T0 / 60`` with
            ``T0 = 2 pi / omega0`` (global phase error below 1e-5 rad per period).
        wander : (dw2, db1), optional
            Arrays of ``len(t) - 1`` added to ``omega0^2`` [1/s^2] and ``b1``
            [1/s] over each output interval: a realisation of the coefficient
            wander of :mod:`studies.roll.discrepancy` (a replay with model
            discrepancy). Default: none.

        Returns
        -------
        phi, dphi : ndarray
            Roll angle [rad] and rate [rad/s] at ``t``. A trajectory that
            diverges (|phi| > 1000 rad) is clipped to stay finite.
        """
        t = np.ascontiguousarray(np.asarray(t, dtype=float))
        if t.ndim != 1 or t.size == 0:
            raise ValueError("t must be a non-empty 1-D array")
        b1, b2, b3, w2, c3 = self.coefficients(params)
        if max_step is None:
            w0 = math.sqrt(abs(w2)) if w2 != 0 else 1.0
            max_step = 2.0 * math.pi / w0 / 60.0
        dt_max = float(np.max(np.diff(t))) if t.size > 1 else 0.0
        nsub = max(1, int(math.ceil(dt_max / max_step - 1e-9)))
        if wander is None:
            dw2 = db1 = NO_WANDER
        else:
            dw2, db1 = (np.ascontiguousarray(np.asarray(a, dtype=float)) for a in wander)
            if dw2.shape != (t.size - 1,) or db1.shape != (t.size - 1,):
                raise ValueError("wander arrays need one value per output interval (len(t) - 1)")
        out = compiled_rk4()(float(phi0), float(dphi0), t, b1, b2, b3, w2, c3, nsub, dw2, db1)
        return out[:, 0].copy(), out[:, 1].copy()


# ---------------------------------------------------------------- damping
def equivalent_linear_damping(params: Mapping[str, float], amplitude, terms: Sequence[str] | None = None):
    """Equivalent linear damping ``b_eq`` [1/s] at roll amplitude ``phi_a``.

    Energy-equivalent linearisation over one cycle of ``phi = phi_a cos(omega0 t)``::

        b_eq = b1 + 8/(3 pi) omega0 phi_a b2 + 3/4 omega0^2 phi_a^2 b3

    Parameters
    ----------
    params : mapping
        ``omega0`` [rad/s] and any of ``b1``, ``b2``, ``b3``.
    amplitude : float or ndarray
        Roll amplitude ``phi_a`` [rad].
    terms : sequence of str, optional
        Terms to include; default all damping terms present in ``params``.

    Returns
    -------
    float or ndarray
        ``b_eq`` [1/s].

    References
    ----------
    Chen, C. et al. (2019), Ocean Engineering 191, 106479 (damping model, eq. 2).
    """
    a = np.asarray(amplitude, dtype=float)
    use = set(terms) if terms is not None else set(params)
    w0 = float(params["omega0"])
    val = np.zeros_like(a)
    if "b1" in use and "b1" in params:
        val = val + float(params["b1"])
    if "b2" in use and "b2" in params:
        val = val + 8.0 / (3.0 * math.pi) * w0 * a * float(params["b2"])
    if "b3" in use and "b3" in params:
        val = val + 0.75 * w0**2 * a**2 * float(params["b3"])
    return float(val) if np.ndim(val) == 0 else val


def damping_ratio(params: Mapping[str, float], amplitude, terms: Sequence[str] | None = None):
    """Equivalent linear damping ratio ``zeta = b_eq / (2 omega0)`` [-] at amplitude [rad]."""
    return equivalent_linear_damping(params, amplitude, terms) / (2.0 * float(params["omega0"]))


# ------------------------------------------------------------ dimensional
def froude_scale_params(params: Mapping[str, float], scale: float, to: str = "full") -> dict[str, float]:
    """Froude-scale non-dimensionalised roll coefficients between model and full scale.

    Time scales with ``sqrt(scale)``: ``omega0`` and ``b1`` [1/s] with
    ``1/sqrt(scale)``, ``b2`` [-] is unchanged, ``b3`` [s] with ``sqrt(scale)``,
    ``c3`` [1/s^2] with ``1/scale`` (all going from model to full scale).

    Parameters
    ----------
    params : mapping
        Coefficients at the source scale.
    scale : float
        Geometric scale factor ``lambda`` (e.g. 68 for a 1:68 model).
    to : {"full", "model"}
        Direction of the conversion.

    Returns
    -------
    dict
        Coefficients at the target scale.
    """
    if to not in ("full", "model"):
        raise ValueError("to must be 'full' or 'model'")
    s = math.sqrt(float(scale)) if to == "full" else 1.0 / math.sqrt(float(scale))
    factors = {"omega0": 1.0 / s, "b1": 1.0 / s, "b2": 1.0, "b3": s, "c3": 1.0 / s**2}
    return {k: float(v) * factors.get(k, 1.0) for k, v in params.items()}


def dimensional_coefficients(params: Mapping[str, float], displacement: float, gm: float,
                             kxx: float | None = None, rho: float = 1025.0,
                             g: float = 9.81) -> dict[str, float]:
    """Dimensional roll coefficients from the non-dimensionalised ones.

    The restoring coefficient is ``C44 = rho g V GM`` [N m/rad]; the total
    inertia (dry plus added) follows from the identified natural frequency,
    ``I = C44 / omega0^2`` [kg m^2], and every coefficient is multiplied by it.
    Particulars and ``params`` must be at the same scale (see
    :func:`froude_scale_params`).

    Parameters
    ----------
    params : mapping
        ``omega0`` [rad/s] and any of ``b1``, ``b2``, ``b3``, ``c3``.
    displacement : float
        Displaced volume ``V`` [m^3].
    gm : float
        Transverse metacentric height [m].
    kxx : float, optional
        Dry radius of gyration in roll [m]; gives ``I_xx = rho V kxx^2`` and
        the added inertia ``A44 = I - I_xx``.
    rho : float
        Water density [kg/m^3].
    g : float
        Gravitational acceleration [m/s^2].

    Returns
    -------
    dict
        ``C44`` [N m], ``I_total`` [kg m^2], ``B44`` [kg m^2/s] (from b1),
        ``B44q`` [kg m^2] (from b2), ``B44c`` [kg m^2 s] (from b3), ``C44c``
        [N m] (from c3), and with ``kxx``: ``I_xx``, ``A44`` [kg m^2] and
        ``A44_ratio`` = A44 / I_xx [-].

    References
    ----------
    Chen, C. et al. (2019), Ocean Engineering 191, 106479, eq. (1)-(3) and
    Tables 5-8 (coefficients given in kg m^2/s and kg m^2).
    """
    w0 = float(params["omega0"])
    c44 = rho * g * float(displacement) * float(gm)
    inertia = c44 / w0**2
    out = {"C44": c44, "I_total": inertia}
    for src, dst in (("b1", "B44"), ("b2", "B44q"), ("b3", "B44c"), ("c3", "C44c")):
        if src in params:
            out[dst] = float(params[src]) * inertia
    if kxx is not None:
        ixx = rho * float(displacement) * float(kxx) ** 2
        out["I_xx"] = ixx
        out["A44"] = inertia - ixx
        out["A44_ratio"] = (inertia - ixx) / ixx
    return out
