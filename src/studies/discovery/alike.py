"""Whether the records can tell two causes apart at all: how alike their signatures are.

A cause acts on the records through its signature: the columns by which its
parameters change the baseline's residual (the inverse-dynamics forces on the
MMG baseline, the Kalman filter's innovations on the tracks), with the
directions of the baseline's own coefficients projected out, since those are
re-identified beside every cause. Two causes whose signatures span nearly
the same directions are told apart only by the small part where they differ:
the records cannot decide between them however the naming is done, and a
verdict naming one of them says as much about the other.

The measure is the first canonical correlation of the two signatures (the
cosine of the smallest angle between the spaces their columns span; 1: one
cause does exactly what the other does, 0: nothing in common). A cause with
several variants (a missing term from the library, a wind from 16
directions) is taken at its variant most alike the other cause. It depends on
the records and the baseline, not on the noise or the effect's size: on the
MARIN zig-zags the MMG baseline's rudder offset is 0.98 alike a propeller's
side force and 0.95 alike an earth-fixed force (both a nearly constant yaw
moment in a zig-zag), a current 0.88; on HSVA's zig-zags, 0.85, 0.81 and 0.17
(docs/discovery.md).
"""

from __future__ import annotations

import numpy as np

__all__ = ["first_canonical_correlation", "signature_alike"]


def _basis(columns: np.ndarray) -> np.ndarray | None:
    """Orthonormal basis of the span of ``columns`` (N, k), or None when they span nothing."""
    columns = np.nan_to_num(np.asarray(columns, float))
    if columns.ndim != 2 or columns.shape[1] == 0:
        return None
    u, s, _ = np.linalg.svd(columns, full_matrices=False)
    if not len(s) or s[0] <= 0.0:
        return None
    keep = s > s[0] * 1e-8
    return u[:, keep]


def _cosine(qa: np.ndarray, qb: np.ndarray) -> float:
    """Largest singular value of ``qa^T qb`` for orthonormal bases: the first canonical correlation."""
    return float(min(np.linalg.svd(qa.T @ qb, compute_uv=False)[0], 1.0))


def first_canonical_correlation(a: np.ndarray, b: np.ndarray) -> float:
    """Cosine of the smallest angle between the spans of the columns of ``a`` and ``b``
    (same rows); NaN when either spans nothing."""
    qa, qb = _basis(a), _basis(b)
    if qa is None or qb is None:
        return float("nan")
    return _cosine(qa, qb)


def signature_alike(variants: list, projected: list) -> dict:
    """How alike every pair of causes' signatures is on these records.

    Parameters
    ----------
    variants : list of Variant
        The causes' variants compared by the discovery (``cause.id``, ``label``).
    projected : list of ndarray (N, k)
        Each variant's signature columns on the same rows, the baseline's
        coefficients' directions projected out.

    Returns
    -------
    dict
        ``{cause id: {other cause id: {"correlation": first canonical
        correlation, "variant": the other cause's variant most alike,
        "as": this cause's variant most alike}}}``, symmetric in its
        correlations; causes whose signature spans nothing on these records
        are left out.
    """
    bases = {}
    for v, cols in zip(variants, projected):
        q = _basis(cols)
        if q is not None:
            bases.setdefault(v.cause.id, []).append((v.label, q))
    out = {cid: {} for cid in bases}
    ids = list(bases)
    for i, a in enumerate(ids):
        for b in ids[i + 1:]:
            best = (-1.0, "", "")
            for la, qa in bases[a]:
                for lb, qb in bases[b]:
                    c = _cosine(qa, qb)
                    if c > best[0]:
                        best = (c, la, lb)
            out[a][b] = {"correlation": best[0], "variant": best[2], "as": best[1]}
            out[b][a] = {"correlation": best[0], "variant": best[1], "as": best[2]}
    return out
