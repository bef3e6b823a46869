"""Cubic monomial basis of the prime states, evaluated without allocation.

Every term of the manoeuvring models in `studies` is a monomial of
``u', v', r', delta`` of order at most three. The compiled integrator maps a
model's coefficients onto the 35 monomials of this basis (a dense ``(3, 35)``
matrix, zero where the model has no term) and evaluates all three forces as
straight-line code. The order of :data:`CUBIC_BASIS` is the order of the
columns.

The RK4 stages are sequential, so the force evaluation is bound by latency,
not by the number of operations: the sums below are written as balanced
trees (a chain of 35 additions was the integrator's bottleneck) and grouped
by velocity order so that no division by U precedes them. The integrator is
compiled without the ``reassoc`` fast-math flag, which would linearise the
trees again. ``tests/test_model_terms.py`` checks every monomial against the
model's own term evaluation.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["CUBIC_BASIS", "dense_coefficients", "scaled_forces", "cubic_forces", "coefficient_tuple"]

#: exponents of (u', v', r', delta) of the 35 monomials, column order
CUBIC_BASIS = [(0, 0, 0, 0), (1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1), (2, 0, 0, 0), (1, 1, 0, 0), (0, 2, 0, 0), (1, 0, 1, 0), (0, 1, 1, 0), (0, 0, 2, 0), (1, 0, 0, 1), (0, 1, 0, 1), (0, 0, 1, 1), (0, 0, 0, 2), (3, 0, 0, 0), (2, 1, 0, 0), (1, 2, 0, 0), (0, 3, 0, 0), (2, 0, 1, 0), (1, 1, 1, 0), (0, 2, 1, 0), (1, 0, 2, 0), (0, 1, 2, 0), (0, 0, 3, 0), (2, 0, 0, 1), (1, 1, 0, 1), (0, 2, 0, 1), (1, 0, 1, 1), (0, 1, 1, 1), (0, 0, 2, 1), (1, 0, 0, 2), (0, 1, 0, 2), (0, 0, 1, 2), (0, 0, 0, 3)]

_INDEX = {p: j for j, p in enumerate(CUBIC_BASIS)}


def dense_coefficients(vectors, powers, dofs) -> np.ndarray:
    """Coefficient rows (n_sets, n_terms) -> dense matrices (n_sets, 3, 35).

    Raises ``ValueError`` for a term of order above three.
    """
    vectors = np.atleast_2d(np.asarray(vectors, dtype=float))
    powers, dofs = np.asarray(powers), np.asarray(dofs)
    placement = _placement(powers.tobytes(), dofs.tobytes(), powers.shape, powers.dtype.str, dofs.dtype.str)
    if np.isfinite(vectors).all():
        # (n_sets, n_terms) @ (n_terms, 105): terms on the same monomial and DOF add up
        return (vectors @ placement).reshape(vectors.shape[0], 3, len(CUBIC_BASIS))
    # a non-finite coefficient must stay in its own column (0 x inf would spread NaN)
    out = np.zeros((vectors.shape[0], placement.shape[1]))
    for k, j in enumerate(np.argmax(placement, axis=1)):
        out[:, j] += vectors[:, k]
    return out.reshape(vectors.shape[0], 3, len(CUBIC_BASIS))


_PLACEMENT_CACHE: dict = {}


def _placement(powers_bytes, dofs_bytes, shape, powers_dtype, dofs_dtype) -> np.ndarray:
    """0/1 matrix (n_terms, 105) putting every term on its column of the
    flattened dense ``(3, 35)`` matrix (cached per model layout)."""
    key = (powers_bytes, dofs_bytes, shape, powers_dtype, dofs_dtype)
    if key not in _PLACEMENT_CACHE:
        powers = np.frombuffer(powers_bytes, dtype=powers_dtype).reshape(shape)
        dofs = np.frombuffer(dofs_bytes, dtype=dofs_dtype)
        out = np.zeros((len(dofs), 3 * len(CUBIC_BASIS)))
        for k, (p, dof) in enumerate(zip(powers, dofs)):
            key_p = tuple(int(x) for x in p)
            if key_p not in _INDEX:
                raise ValueError(f"term with exponents {key_p} is above third order; the simulator supports "
                                 "cubic models")
            out[k, int(dof) * len(CUBIC_BASIS) + _INDEX[key_p]] = 1.0
        if len(_PLACEMENT_CACHE) > 256:
            _PLACEMENT_CACHE.clear()
        _PLACEMENT_CACHE[key] = out
    return _PLACEMENT_CACHE[key]


@njit(cache=True, inline="always")
def scaled_forces(c, du, v, rl, delta, speed, inv_speed):
    """``U^2 (X', Y', N')`` from dimensional velocities, with no division by U.

    ``c`` holds the 105 coefficients of the dense ``(3, 35)`` matrix in
    row-major order (a flat array, or :func:`coefficient_tuple`). ``du`` is
    the surge perturbation and ``v`` the sway [m/s], ``rl`` = r L [m/s],
    ``delta`` the rudder [rad], ``speed`` = U and ``inv_speed`` = 1/U. A term
    of velocity order n (in u', v', r') carries U^(2-n), so the four sums by
    order are independent of U. With ``speed = inv_speed = 1`` and prime
    arguments it returns the prime forces.
    """
    m_u = du
    m_v = v
    m_r = rl
    m_d = delta
    m_uu = m_u * du
    m_uv = m_v * du
    m_vv = m_v * v
    m_ur = m_r * du
    m_vr = m_r * v
    m_rr = m_r * rl
    m_ud = m_d * du
    m_vd = m_d * v
    m_rd = m_d * rl
    m_dd = m_d * delta
    m_uuu = m_uu * du
    m_uuv = m_uv * du
    m_uvv = m_vv * du
    m_vvv = m_vv * v
    m_uur = m_ur * du
    m_uvr = m_vr * du
    m_vvr = m_vr * v
    m_urr = m_rr * du
    m_vrr = m_rr * v
    m_rrr = m_rr * rl
    m_uud = m_ud * du
    m_uvd = m_vd * du
    m_vvd = m_vd * v
    m_urd = m_rd * du
    m_vrd = m_rd * v
    m_rrd = m_rd * rl
    m_udd = m_dd * du
    m_vdd = m_dd * v
    m_rdd = m_dd * rl
    m_ddd = m_dd * delta
    fx0 = ((c[0] + c[4] * m_d) + (c[14] * m_dd + c[34] * m_ddd))
    fx1 = (
        ((((c[1] * m_u + c[2] * m_v) + (c[3] * m_r + c[11] * m_ud)) + ((c[12] * m_vd + c[13] * m_rd)
        + (c[31] * m_udd + c[32] * m_vdd))) + c[33] * m_rdd)
    )
    fx2 = (
        ((((c[5] * m_uu + c[6] * m_uv) + (c[7] * m_vv + c[8] * m_ur)) + ((c[9] * m_vr + c[10] *
        m_rr) + (c[25] * m_uud + c[26] * m_uvd))) + ((c[27] * m_vvd + c[28] * m_urd) + (c[29] *
        m_vrd + c[30] * m_rrd)))
    )
    fx3 = (
        ((((c[15] * m_uuu + c[16] * m_uuv) + (c[17] * m_uvv + c[18] * m_vvv)) + ((c[19] * m_uur +
        c[20] * m_uvr) + (c[21] * m_vvr + c[22] * m_urr))) + (c[23] * m_vrr + c[24] * m_rrr))
    )
    fy0 = ((c[35] + c[39] * m_d) + (c[49] * m_dd + c[69] * m_ddd))
    fy1 = (
        ((((c[36] * m_u + c[37] * m_v) + (c[38] * m_r + c[46] * m_ud)) + ((c[47] * m_vd + c[48] *
        m_rd) + (c[66] * m_udd + c[67] * m_vdd))) + c[68] * m_rdd)
    )
    fy2 = (
        ((((c[40] * m_uu + c[41] * m_uv) + (c[42] * m_vv + c[43] * m_ur)) + ((c[44] * m_vr + c[45] *
        m_rr) + (c[60] * m_uud + c[61] * m_uvd))) + ((c[62] * m_vvd + c[63] * m_urd) + (c[64] *
        m_vrd + c[65] * m_rrd)))
    )
    fy3 = (
        ((((c[50] * m_uuu + c[51] * m_uuv) + (c[52] * m_uvv + c[53] * m_vvv)) + ((c[54] * m_uur +
        c[55] * m_uvr) + (c[56] * m_vvr + c[57] * m_urr))) + (c[58] * m_vrr + c[59] * m_rrr))
    )
    fn0 = ((c[70] + c[74] * m_d) + (c[84] * m_dd + c[104] * m_ddd))
    fn1 = (
        ((((c[71] * m_u + c[72] * m_v) + (c[73] * m_r + c[81] * m_ud)) + ((c[82] * m_vd + c[83] *
        m_rd) + (c[101] * m_udd + c[102] * m_vdd))) + c[103] * m_rdd)
    )
    fn2 = (
        ((((c[75] * m_uu + c[76] * m_uv) + (c[77] * m_vv + c[78] * m_ur)) + ((c[79] * m_vr + c[80] *
        m_rr) + (c[95] * m_uud + c[96] * m_uvd))) + ((c[97] * m_vvd + c[98] * m_urd) + (c[99] *
        m_vrd + c[100] * m_rrd)))
    )
    fn3 = (
        ((((c[85] * m_uuu + c[86] * m_uuv) + (c[87] * m_uvv + c[88] * m_vvv)) + ((c[89] * m_uur +
        c[90] * m_uvr) + (c[91] * m_vvr + c[92] * m_urr))) + (c[93] * m_vrr + c[94] * m_rrr))
    )
    return (
        (fx0 * speed + fx1) * speed + (fx2 + fx3 * inv_speed),
        (fy0 * speed + fy1) * speed + (fy2 + fy3 * inv_speed),
        (fn0 * speed + fn1) * speed + (fn2 + fn3 * inv_speed),
    )


@njit(cache=True)
def cubic_forces(c, up, vp, rp, dp):
    """Prime (X', Y', N') at prime states ``u', v', r'`` and rudder ``delta``
    [rad]; ``c`` is the flat 105-vector of the dense coefficients."""
    return scaled_forces(c, up, vp, rp, dp, 1.0, 1.0)


@njit(cache=True)
def coefficient_tuple(c):
    """Dense ``(3, 35)`` coefficients as a flat 105-tuple: a value the compiled
    loops carry in registers, without array reference counting."""
    return (
        c[0, 0], c[0, 1], c[0, 2], c[0, 3], c[0, 4], c[0, 5], c[0, 6], c[0, 7], c[0, 8], c[0, 9],
        c[0, 10], c[0, 11], c[0, 12], c[0, 13], c[0, 14], c[0, 15], c[0, 16], c[0, 17], c[0, 18],
        c[0, 19], c[0, 20], c[0, 21], c[0, 22], c[0, 23], c[0, 24], c[0, 25], c[0, 26], c[0, 27],
        c[0, 28], c[0, 29], c[0, 30], c[0, 31], c[0, 32], c[0, 33], c[0, 34], c[1, 0], c[1, 1],
        c[1, 2], c[1, 3], c[1, 4], c[1, 5], c[1, 6], c[1, 7], c[1, 8], c[1, 9], c[1, 10], c[1,
        11], c[1, 12], c[1, 13], c[1, 14], c[1, 15], c[1, 16], c[1, 17], c[1, 18], c[1, 19], c[1,
        20], c[1, 21], c[1, 22], c[1, 23], c[1, 24], c[1, 25], c[1, 26], c[1, 27], c[1, 28], c[1,
        29], c[1, 30], c[1, 31], c[1, 32], c[1, 33], c[1, 34], c[2, 0], c[2, 1], c[2, 2], c[2, 3],
        c[2, 4], c[2, 5], c[2, 6], c[2, 7], c[2, 8], c[2, 9], c[2, 10], c[2, 11], c[2, 12], c[2,
        13], c[2, 14], c[2, 15], c[2, 16], c[2, 17], c[2, 18], c[2, 19], c[2, 20], c[2, 21], c[2,
        22], c[2, 23], c[2, 24], c[2, 25], c[2, 26], c[2, 27], c[2, 28], c[2, 29], c[2, 30], c[2,
        31], c[2, 32], c[2, 33], c[2, 34]
    )
