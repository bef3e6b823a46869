"""Cubic monomial basis of the prime states, evaluated without allocation.

Every term of the manoeuvring models in `studies` is a monomial of
``u', v', r', delta`` of order at most three. The compiled integrator maps a
model's coefficients onto the 35 monomials of this basis (a dense ``(3, 35)``
matrix, zero where the model has no term) and evaluates all three forces as
straight-line code, which is several times faster than looping over terms.
The order of :data:`CUBIC_BASIS` is the order of the columns.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["CUBIC_BASIS", "dense_coefficients", "cubic_forces"]

#: exponents of (u', v', r', delta) of the 35 monomials, column order
CUBIC_BASIS = [(0, 0, 0, 0), (1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1), (2, 0, 0, 0), (1, 1, 0, 0), (0, 2, 0, 0), (1, 0, 1, 0), (0, 1, 1, 0), (0, 0, 2, 0), (1, 0, 0, 1), (0, 1, 0, 1), (0, 0, 1, 1), (0, 0, 0, 2), (3, 0, 0, 0), (2, 1, 0, 0), (1, 2, 0, 0), (0, 3, 0, 0), (2, 0, 1, 0), (1, 1, 1, 0), (0, 2, 1, 0), (1, 0, 2, 0), (0, 1, 2, 0), (0, 0, 3, 0), (2, 0, 0, 1), (1, 1, 0, 1), (0, 2, 0, 1), (1, 0, 1, 1), (0, 1, 1, 1), (0, 0, 2, 1), (1, 0, 0, 2), (0, 1, 0, 2), (0, 0, 1, 2), (0, 0, 0, 3)]

_INDEX = {p: j for j, p in enumerate(CUBIC_BASIS)}


def dense_coefficients(vectors, powers, dofs) -> np.ndarray:
    """Coefficient rows (n_sets, n_terms) -> dense matrices (n_sets, 3, 35).

    Raises ``ValueError`` for a term of order above three.
    """
    vectors = np.atleast_2d(np.asarray(vectors, dtype=float))
    out = np.zeros((vectors.shape[0], 3, len(CUBIC_BASIS)))
    for k, (p, dof) in enumerate(zip(powers, dofs)):
        key = tuple(int(x) for x in p)
        if key not in _INDEX:
            raise ValueError(f"term with exponents {key} is above third order; the simulator supports cubic models")
        out[:, int(dof), _INDEX[key]] += vectors[:, k]
    return out


@njit(cache=True, inline="always")
def cubic_forces(c, up, vp, rp, dp, m):
    """Prime (X', Y', N') = c @ monomials(u', v', r', delta); ``c`` is (3, 35),
    ``m`` a work array of 35 that receives the monomials."""
    m_1 = 1.0
    m_u = up
    m_v = vp
    m_r = rp
    m_d = dp
    m_uu = m_u * up
    m_uv = m_v * up
    m_vv = m_v * vp
    m_ur = m_r * up
    m_vr = m_r * vp
    m_rr = m_r * rp
    m_ud = m_d * up
    m_vd = m_d * vp
    m_rd = m_d * rp
    m_dd = m_d * dp
    m_uuu = m_uu * up
    m_uuv = m_uv * up
    m_uvv = m_vv * up
    m_vvv = m_vv * vp
    m_uur = m_ur * up
    m_uvr = m_vr * up
    m_vvr = m_vr * vp
    m_urr = m_rr * up
    m_vrr = m_rr * vp
    m_rrr = m_rr * rp
    m_uud = m_ud * up
    m_uvd = m_vd * up
    m_vvd = m_vd * vp
    m_urd = m_rd * up
    m_vrd = m_rd * vp
    m_rrd = m_rd * rp
    m_udd = m_dd * up
    m_vdd = m_dd * vp
    m_rdd = m_dd * rp
    m_ddd = m_dd * dp
    m[0] = m_1
    m[1] = m_u
    m[2] = m_v
    m[3] = m_r
    m[4] = m_d
    m[5] = m_uu
    m[6] = m_uv
    m[7] = m_vv
    m[8] = m_ur
    m[9] = m_vr
    m[10] = m_rr
    m[11] = m_ud
    m[12] = m_vd
    m[13] = m_rd
    m[14] = m_dd
    m[15] = m_uuu
    m[16] = m_uuv
    m[17] = m_uvv
    m[18] = m_vvv
    m[19] = m_uur
    m[20] = m_uvr
    m[21] = m_vvr
    m[22] = m_urr
    m[23] = m_vrr
    m[24] = m_rrr
    m[25] = m_uud
    m[26] = m_uvd
    m[27] = m_vvd
    m[28] = m_urd
    m[29] = m_vrd
    m[30] = m_rrd
    m[31] = m_udd
    m[32] = m_vdd
    m[33] = m_rdd
    m[34] = m_ddd
    fx = 0.0
    for j in range(35):
        fx += c[0, j] * m[j]
    fy = 0.0
    for j in range(35):
        fy += c[1, j] * m[j]
    fn = 0.0
    for j in range(35):
        fn += c[2, j] * m[j]
    return fx, fy, fn
