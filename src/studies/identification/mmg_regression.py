"""Inverse-dynamics regression of the MMG hull, with the propeller and rudder known.

For each record the state and acceleration estimates (from the Kalman
smoother or a derivative filter) give the rigid-body and added-mass side of
the MMG equations (:mod:`studies.models.mmg`); the propeller and rudder
forces (:func:`~studies.models.mmg.module_forces`, at the measured rudder
angle and propeller rate ``n``) are subtracted, and what is left is the hull
force, made non-dimensional by ``0.5 rho L d U^2`` (moment by ``0.5 rho
L^2 d U^2``)::

    X'_H = [(m + m_x) u_dot - (m + m_y) v r - x_G m r^2 - X_P - X_R] / (0.5 rho L d U^2)
    Y'_H = [(m + m_y) v_dot + (m + m_x) u r + x_G m r_dot - Y_R] / (0.5 rho L d U^2)
    N'_H = [(I_zG + x_G^2 m + J_z) r_dot + x_G m (v_dot + u r) - N_R] / (0.5 rho L^2 d U^2)

Each DOF is then a linear problem ``y = Theta c`` in the hull terms of the
model (a :class:`~studies.identification.regression.RegressionProblem`), so least
squares, emcee, SINDy, the SVM and the GA's start all fit it unchanged.

Priors
------
Zig-zags excite the drift and yaw rate of a tight turn only weakly: alone,
the higher-order hull terms are poorly determined (the KVLCC2 zig-zags give
``Y'_vvv = -6.3`` against a captive-test value of -1.6). The regression
therefore carries a Gaussian prior on every hull coefficient, centred on
prior values (the vessel's published ones) with a standard deviation of
``max(scale |c0|, floor)``, as pseudo-observation rows appended to each
DOF's problem::

    (sigma / s_j) c_j = (sigma / s_j) c0_j

with ``sigma`` the residual RMS of the unregularised fit: least squares on
the augmented problem is then the posterior mode (ridge regression towards
``c0``), and the other identifiers see the prior as data of the same kind.
``scale = inf`` (or no prior values) leaves the problem as measured.

References
----------
Yasukawa, H., Yoshimura, Y. (2015). J. Mar. Sci. Technol. 20, 37-52, eq. 4.
"""

from __future__ import annotations

import numpy as np

from ..data.captive import captive_motion
from ..data.derivatives import DerivativeEstimate
from ..models.abkowitz import ManoeuvringModel
from ..models.mmg import MMGParameters, hull_primes, module_constants, module_forces
from .regression import RegressionProblem, assemble_problems

__all__ = ["hull_force_targets", "captive_targets", "mmg_problems", "tied_values", "add_prior_rows", "MMG_PRIOR_RECORD",
           "MMG_CAPTIVE_RECORD"]

#: the ``record`` index of the prior's pseudo-observation rows
MMG_PRIOR_RECORD = -1
#: the ``record`` index of the captive tests' rows
MMG_CAPTIVE_RECORD = -2


def captive_targets(vessel, modules: MMGParameters, tests) -> tuple[np.ndarray, np.ndarray]:
    """Prime states ``(0, v', 0, delta)`` and MMG prime hull forces (k, 3) of captive tests.

    The hull force of a test is its measured total force (captive primes over
    ``0.5 rho L^2 U^2``, moment ``0.5 rho L^3 U^2``; :mod:`studies.data.captive`)
    less the propeller and rudder modules at its speed, drift, rudder angle
    and propeller rate, over ``0.5 rho L d U^2`` (moment ``0.5 rho L^2 d U^2``).
    ``vessel`` at the tests' scale.
    """
    m = captive_motion(tests)
    speed, v, r = m["U"], m["v"], m["r"]
    xm, ym, nm = module_forces(m["u"], v, r, m["delta"], m["n"], module_constants(vessel, modules))
    primes = hull_primes(m["u"], v, r, m["delta"], m["n"], vessel, modules)
    qd = 0.5 * vessel.rho * vessel.length * vessel.draught * speed ** 2
    q2 = 0.5 * vessel.rho * vessel.length ** 2 * speed ** 2
    lhs = np.column_stack([(np.asarray(tests["X"], float) * q2 - xm) / qd,
                           (np.asarray(tests["Y"], float) * q2 - ym) / qd,
                           (np.asarray(tests["N"], float) * q2 * vessel.length - nm) / (qd * vessel.length)])
    return primes, lhs


def hull_force_targets(vessel, modules: MMGParameters, estimate: DerivativeEstimate,
                       n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """MMG primes (k, 5) (:func:`~studies.models.mmg.hull_primes`: ``u/U, v/U, r L/U, delta`` and
    the propeller module's thrust loading) and prime hull forces (k, 3) of one record.

    Parameters
    ----------
    vessel : MMGVessel
        Particulars at the record's scale.
    modules : MMGParameters
        Propeller and rudder parameters.
    estimate : DerivativeEstimate
        Smoothed ``u, v, r, delta`` and ``u_dot, v_dot, r_dot`` (SI, rad).
    n : ndarray
        Propeller rate [rps] on the estimate's rows.
    """
    s, a = estimate.states, estimate.rates
    u, v, r, delta = (np.asarray(s[k], float) for k in ("u", "v", "r", "delta"))
    mx, my, jz = vessel.added_masses()
    m = vessel.mass
    xgm = vessel.xg * m
    fx = (m + mx) * a["u_dot"] - (m + my) * v * r - xgm * r * r
    fy = (m + my) * a["v_dot"] + (m + mx) * u * r + xgm * a["r_dot"]
    fn = (vessel.iz + vessel.xg ** 2 * m + jz) * a["r_dot"] + xgm * (a["v_dot"] + u * r)
    xm, ym, nm = module_forces(u, v, r, delta, np.asarray(n, float), module_constants(vessel, modules))
    speed2 = u * u + v * v
    q = 0.5 * vessel.rho * vessel.length * vessel.draught * speed2
    lhs = np.column_stack([(fx - xm) / q, (fy - ym) / q, (fn - nm) / (q * vessel.length)])
    return hull_primes(u, v, r, delta, n, vessel, modules), lhs


def mmg_problems(model: ManoeuvringModel, vessel, modules: MMGParameters, records, estimates,
                 prior: dict | None = None, prior_scale: float = 0.5, prior_floor: float = 0.005,
                 weights: str = "none", captive=None, ties=()) -> dict:
    """``{dof: RegressionProblem}`` of the MMG hull terms from estimated states.

    Parameters
    ----------
    model : ManoeuvringModel
        The hull terms (:func:`studies.models.mmg.mmg` or a subset).
    vessel, modules
        Particulars (at the records' scale) and propeller/rudder parameters.
    records : list of DataFrame
        Records with the propeller rate ``n`` [rps].
    estimates : list of DerivativeEstimate
        One per record.
    prior : dict, optional
        Prior values of the hull coefficients (see the module docstring).
    prior_scale, prior_floor : float
        Prior standard deviation ``max(prior_scale |c0|, prior_floor)``.
    weights : str
        ``none`` or ``speed``: rows weighted by ``(U / U0)^4`` (the prime
        force of a slow sample is a small SI force divided by a small
        ``U^2``; see :func:`studies.workflows.measured.problems_from_estimates`).
    captive : tuple, optional
        ``(vessel at the tests' scale, tests, weight)``: the captive tests'
        hull forces (:func:`captive_targets`) as rows of the regression, each
        scaled by ``weight sqrt(n / k)`` (``n`` record rows, ``k`` tests), so
        that ``weight = 1`` gives the tests as much say as the records.
    ties : tuple of (str, str, float)
        ``(sway term, yaw term, lever)``: the yaw coefficient is the sway one
        times ``lever`` (:func:`studies.models.mmg.family_ties`). Each pair is
        one coefficient of a joint regression of the sway and yaw rows
        (:func:`tied_values`); the problems returned hold both members as
        known coefficients (``problem.fixed``, moved into ``y``), so that
        every method fits the other terms with them.
    """
    primes, lhs, which, times, speed2, states = [], [], [], [], [], []
    for i, (rec, est) in enumerate(zip(records, estimates)):
        if "n" not in rec:
            raise ValueError(f"record '{rec.attrs.get('name', i)}' has no propeller rate 'n' [rps]")
        n = rec["n"].to_numpy(float)[est.index]
        p, y = hull_force_targets(vessel, modules, est, n)
        primes.append(p)
        lhs.append(y)
        which.append(np.full(len(y), i))
        times.append(rec["t"].to_numpy(float)[est.index])
        speed2.append(np.asarray(est.states["u"], float) ** 2 + np.asarray(est.states["v"], float) ** 2)
        states.append({k: np.asarray(est.states[k], float) for k in ("u", "v", "r", "delta", "psi")
                       if k in est.states})
    primes, lhs = np.vstack(primes), np.vstack(lhs)
    which, times = np.concatenate(which), np.concatenate(times)
    root = None
    if weights == "speed":
        w = (np.concatenate(speed2) / vessel.speed ** 2) ** 2
        root = np.sqrt(w / w.mean())
    elif weights != "none":
        raise ValueError(f"MMG regression weights must be 'none' or 'speed', got '{weights}'")
    n_records = len(which)
    if captive is not None:
        cap_vessel, tests, weight = captive
        cp, cy = captive_targets(cap_vessel, modules, tests)
        w = float(weight) * np.sqrt(n_records / len(cy))
        if root is not None:
            root = np.concatenate([root, np.full(len(cy), w)])
        else:
            root = np.concatenate([np.ones(n_records), np.full(len(cy), w)])
        primes, lhs = np.vstack([primes, cp]), np.vstack([lhs, cy])
        which = np.concatenate([which, np.full(len(cy), MMG_CAPTIVE_RECORD)])
        times = np.concatenate([times, times[-1] + 1.0 + np.arange(len(cy))])
        motion = captive_motion(tests)
        states.append({k: motion[k] for k in ("u", "v", "r", "delta")})
    keys = [k for k in states[0] if all(k in s for s in states)]
    joined = {k: np.concatenate([s[k] for s in states]) for k in keys}
    problems = assemble_problems(model, primes, lhs, {}, which, times, joined, row_weights=root)
    ties = tuple(t for t in ties if t[0] in model.names and t[1] in model.names)
    if ties:
        fixed = tied_values(problems, ties)
        problems = assemble_problems(model, primes, lhs, fixed, which, times, joined, row_weights=root)
    if prior and np.isfinite(prior_scale):
        for problem in problems.values():
            add_prior_rows(problem, prior, prior_scale, prior_floor)
    for problem in problems.values():
        problem.n_data = n_records            # the records' rows come first
    for problem in problems.values():
        problem.meta = {"derivative": estimates[0].method if estimates else "none", "weights": weights}
    return problems


def tied_values(problems: dict, ties) -> dict:
    """``{name: value}`` of the tied terms: the sway and yaw rows regressed together
    with each tied pair as one coefficient ``c`` (sway ``c``, yaw ``lever c``).

    The two DOFs' rows are in different units and noise: each is divided by the
    residual RMS of its own unconstrained least-squares fit, so that the joint
    fit weighs them as the separate fits would. Given the tied values, each
    DOF's other coefficients minimise its own rows alone: the fits of the
    problems with the tied terms known are those of the joint regression.
    """
    from .ls import LeastSquares

    py, pn = problems["Y"], problems["N"]
    ls = LeastSquares()
    scale = {}
    for dof, p in (("Y", py), ("N", pn)):
        resid = p.y - p.theta @ ls.fit_one(p)
        scale[dof] = float(np.sqrt(np.mean(resid ** 2))) or 1.0
    ny, nn = list(py.names), list(pn.names)
    shared = [(a, b, float(lever)) for a, b, lever in ties if a in ny and b in nn]
    only_y = [n for n in ny if n not in {a for a, _, _ in shared}]
    only_n = [n for n in nn if n not in {b for _, b, _ in shared}]
    rows_y, rows_n = len(py.y), len(pn.y)
    columns = [np.r_[py.theta[:, ny.index(n)] / scale["Y"], np.zeros(rows_n)] for n in only_y]
    columns += [np.r_[np.zeros(rows_y), pn.theta[:, nn.index(n)] / scale["N"]] for n in only_n]
    columns += [np.r_[py.theta[:, ny.index(a)] / scale["Y"], lever * pn.theta[:, nn.index(b)] / scale["N"]]
                for a, b, lever in shared]
    joint = RegressionProblem("YN", np.column_stack(columns), np.r_[py.y / scale["Y"], pn.y / scale["N"]],
                              only_y + only_n + [a for a, _, _ in shared])
    coef = ls.fit_one(joint)[len(only_y) + len(only_n):]
    out = {}
    for (a, b, lever), c in zip(shared, coef):
        out[a] = float(c)
        out[b] = float(lever * c)
    return out


def add_prior_rows(problem, prior: dict, scale: float, floor: float) -> None:
    """Append the Gaussian prior of each coefficient as a pseudo-observation row (in place).

    The rows are weighted by ``sigma / s_j``, ``sigma`` the residual RMS of
    the unregularised least-squares fit of ``problem``: the augmented least
    squares is the posterior mode. Coefficients without a prior value get
    no row. Records the prior under ``problem.prior`` (names, means, sds).
    """
    theta, y = problem.theta, problem.y
    names = [n for n in problem.names if n in prior]
    if not names or theta.shape[1] == 0:
        return
    norms = np.linalg.norm(theta, axis=0)
    norms[norms == 0] = 1.0
    coef, *_ = np.linalg.lstsq(theta / norms, y, rcond=None)
    sigma = float(np.sqrt(np.mean((y - (theta / norms) @ coef) ** 2))) or 1e-12
    rows = np.zeros((len(names), theta.shape[1]))
    target = np.zeros(len(names))
    sds = []
    for k, name in enumerate(names):
        c0 = float(prior[name])
        sd = max(scale * abs(c0), floor)
        rows[k, problem.names.index(name)] = sigma / sd
        target[k] = sigma / sd * c0
        sds.append(sd)
    problem.theta = np.vstack([theta, rows])
    problem.y = np.concatenate([y, target])
    if problem.record is not None:
        problem.record = np.concatenate([problem.record, np.full(len(names), MMG_PRIOR_RECORD)])
    if problem.time is not None:
        last = float(np.max(problem.time)) if len(problem.time) else 0.0
        problem.time = np.concatenate([problem.time, last + 1.0 + np.arange(len(names))])
    problem.prior = {"names": names, "mean": [float(prior[n]) for n in names], "sd": sds,
                     "sigma": sigma}
