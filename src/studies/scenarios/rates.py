"""Hit rates with their intervals, confusion matrices and the reliability of a
stated confidence: how the discovery bench turns single discoveries into rates.

A hit rate from ``n`` discoveries is a binomial proportion: its interval is
Wilson's score interval (better behaved than the normal one near 0 and 1 and
for small ``n``). A stated confidence is calibrated when, among verdicts
stated with confidence near ``p``, the share that is right is near ``p``: the
reliability table bins the verdicts by their confidence.

References
----------
Wilson, E. B. (1927). Probable inference, the law of succession, and
statistical inference. JASA 22(158), 209-212.
Brown, L. D., Cai, T. T., DasGupta, A. (2001). Interval estimation for a
binomial proportion. Statistical Science 16(2), 101-133.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["wilson", "rate", "confusion", "reliability", "RELIABILITY_BINS", "Z90", "calibration_error"]

#: the standard normal quantile of a two-sided 90 % interval
Z90 = 1.6448536269514722
#: edges of the confidence bins of :func:`reliability`
RELIABILITY_BINS = (0.0, 0.5, 0.7, 0.9, 1.0)


def wilson(hits: int, n: int, z: float = Z90) -> tuple[float, float]:
    """Wilson's score interval ``(low, high)`` of ``hits`` of ``n`` (90 % by default);
    ``(0, 1)`` for ``n = 0``."""
    if n <= 0:
        return 0.0, 1.0
    if not 0 <= hits <= n:
        raise ValueError(f"hits must be in [0, {n}], got {hits}")
    p = hits / n
    denominator = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / denominator
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denominator
    low, high = max(0.0, centre - half), min(1.0, centre + half)
    # rounding must not put the interval beside the proportion at 0 or 1
    return (0.0 if hits == 0 else min(low, p)), (1.0 if hits == n else max(high, p))


def rate(hits) -> dict:
    """``{"hits", "n", "rate", "low", "high"}`` of a sequence of booleans (90 % Wilson interval)."""
    hits = [bool(h) for h in hits]
    n, k = len(hits), sum(hits)
    low, high = wilson(k, n)
    return {"hits": k, "n": n, "rate": k / n if n else float("nan"), "low": low, "high": high}


def confusion(results, truth_key: str = "hidden", named_key: str = "named") -> dict:
    """``{hidden: {named: count}}`` of result dicts."""
    out = {}
    for r in results:
        row = out.setdefault(r[truth_key], {})
        row[r[named_key]] = row.get(r[named_key], 0) + 1
    return out


def reliability(results, bins=RELIABILITY_BINS, confidence_key: str = "confidence",
                right_key: str = "right") -> list[dict]:
    """Per bin of stated confidence: ``low``, ``high``, ``n``, the mean stated
    confidence, the share of right verdicts and its Wilson interval (verdicts
    without a finite confidence are left out; the last bin includes 1)."""
    rows = []
    for i, (lo, hi) in enumerate(zip(bins[:-1], bins[1:])):
        last = i == len(bins) - 2
        members = [r for r in results if r.get(confidence_key) is not None
                   and np.isfinite(r[confidence_key])
                   and lo <= r[confidence_key] and (r[confidence_key] <= hi if last else r[confidence_key] < hi)]
        stats = rate([r[right_key] for r in members])
        rows.append({"low": lo, "high": hi, "n": stats["n"],
                     "mean_confidence": float(np.mean([r[confidence_key] for r in members])) if members
                     else float("nan"),
                     "share_right": stats["rate"], "share_low": stats["low"], "share_high": stats["high"]})
    return rows


def calibration_error(rows: list) -> float:
    """Mean calibration error of a reliability table (:func:`reliability`): the
    verdicts' mean |stated confidence - share right| per bin, weighted by the
    bin's verdicts (the expected calibration error); NaN without verdicts."""
    n = sum(r["n"] for r in rows)
    if not n:
        return float("nan")
    return float(sum(r["n"] * abs(r["mean_confidence"] - r["share_right"]) for r in rows if r["n"]) / n)
