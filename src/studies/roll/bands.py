"""Posterior predictive bands of a roll decay and of its peak envelope, and their calibration.

A band is built from replays of a held-out decay (later cycles of a
training decay, or another record) from its own initial state
(:func:`predictive_replays`): every replay takes one coefficient set drawn
from the posterior of ``method=bayes`` (:mod:`studies.roll.bayes`), an
initial state drawn from the error of the record's initial-state fit
(:func:`studies.roll.records.initial_state_covariance`) and, with a model
discrepancy, its own realisation of the coefficient wander
(:class:`studies.roll.discrepancy.RollDiscrepancy`). The replays are scored
against the measurement (:func:`band_statistics`): the bands are quantiles
of the predicted measurement, every replay with draws of the record's
measurement noise (its roughness, :func:`studies.roll.discrepancy.noise_level`),
which matters where the replays agree (the start, a right model); the
scores are those of the manoeuvring bands (:mod:`studies.analysis.bands`):

coverage
    share of the samples where the measured ``phi`` lies inside the central
    band of each nominal level of :data:`~studies.analysis.bands.LEVELS`
    (``coverage_<level>``; ``coverage_90`` is the main band);
width
    mean width of the 90 % band [deg], against the record's amplitude (its
    largest ``|phi|``): a band as wide as the decay says nothing;
interval score, CRPS
    of the 90 % band and of the ensemble (Gneiting & Raftery 2007) [deg];
covered_until_s
    time from the start to the first whole roll period in which the
    measurement is outside the 90 % band more than half of the time (an
    oscillation passes through any band near its zero crossings, so the
    manoeuvring rule, outside for a stretch of time, would never fire);
envelope
    the peak angle of every half-cycle (:func:`studies.roll.decay.find_extrema`)
    of each replay, matched to the measured half-cycles by their order: the
    same coverage, width, interval score and CRPS for the measured peaks
    (``envelope_...``).

:func:`trust_verdict` turns them into one sentence, with the same rule as
the manoeuvring bands: trusted when the 90 % band covers between
:data:`~studies.analysis.bands.TRUSTED_COVERAGE` of the record, is narrower
than its amplitude and fewer than 10 % of the replays diverged; it also says
when the record's peak amplitudes lie outside those of the training decays
(:func:`outside_amplitudes`), where the model extrapolates.

References
----------
Gneiting, T., Raftery, A.E. (2007). Strictly proper scoring rules,
prediction, and estimation. J. Am. Stat. Assoc. 102(477), 359-378.
"""

from __future__ import annotations

import math
from typing import Mapping, Sequence

import numpy as np
import pandas as pd

from studies.analysis.bands import LEVELS, TRUSTED_COVERAGE, crps_ensemble, interval_score
from studies.plotting import pyplot
from studies.roll.comparison import DIVERGED_ROLL_RAD
from studies.roll.decay import find_extrema
from studies.roll.discrepancy import noise_level
from studies.roll.model import RollModel
from studies.roll.records import initial_state_covariance

__all__ = ["BAND_KEYS", "predictive_replays", "band_statistics", "peak_amplitudes", "covered_until_period",
           "outside_amplitudes",
           "trust_verdict", "plot_band", "band_table"]

#: ``<record>/band/<key>`` metrics of a roll band
BAND_KEYS = tuple(
    [f"coverage_{int(round(100 * lv))}" for lv in LEVELS]
    + ["covered_until_s", "diverged", "width_deg", "amplitude_deg", "width_over_amplitude",
       "interval_score_deg", "crps_deg", "noise_deg"]
    + [f"envelope_coverage_{int(round(100 * lv))}" for lv in LEVELS]
    + ["envelope_width_deg", "envelope_interval_score_deg", "envelope_crps_deg", "envelope_peaks"])


def predictive_replays(samples: np.ndarray, names: Sequence[str], terms: Sequence[str], record: pd.DataFrame,
                       n_draws: int, discrepancy=None, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Replays of ``record`` for its posterior predictive band.

    Parameters
    ----------
    samples : ndarray (n_samples, len(names))
        Posterior samples of the coefficients.
    names : sequence of str
        ``omega0`` and the terms, the columns of ``samples``.
    terms : sequence of str
        Model terms.
    record : DataFrame
        Prepared decay; replayed from its initial state on its own time axis.
    n_draws : int
        Replays (draws without replacement when there are enough samples).
    discrepancy : RollDiscrepancy, optional
        Coefficient wander, a realisation per replay; None: the model as exact.
    seed : int
        Seed of the draws, initial states and wander.

    Returns
    -------
    replays : ndarray (n_draws, len(record))
        Replayed ``phi`` [rad] (without measurement noise).
    diverged : ndarray of bool (n_draws,)
        Replays that left +-90 deg.
    """
    rng = np.random.default_rng(seed)
    t = record["t"].to_numpy(float)
    model = RollModel(tuple(terms))
    samples = np.atleast_2d(np.asarray(samples, float))
    pick = rng.choice(len(samples), size=n_draws, replace=len(samples) < n_draws)
    mean, cov = initial_state_covariance(record, noise_level(record))
    chol = np.linalg.cholesky(cov + np.eye(2) * 1e-30)
    step = float(t[1] - t[0]) if t.size > 1 else 1.0
    out = np.empty((n_draws, t.size))
    diverged = np.zeros(n_draws, bool)
    for i, j in enumerate(pick):
        params = dict(zip(names, samples[j]))
        phi0, dphi0 = mean + chol @ rng.standard_normal(2)
        wander = discrepancy.realise(t.size - 1, step, rng) if discrepancy is not None else None
        phi, _ = model.simulate(params, phi0, dphi0, t, wander=wander)
        out[i] = phi
        diverged[i] = not np.all(np.abs(phi) < DIVERGED_ROLL_RAD)
    return out, diverged


def peak_amplitudes(t: np.ndarray, phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Times [s] and absolute peak angles [rad] of the half-cycles of a decay."""
    ex = find_extrema(np.asarray(t, float), np.asarray(phi, float), 0.0)
    return ex.t, ex.amplitude


#: noise draws per replay in the predictive ensemble
NOISE_DRAWS = 4


def _scores(ensemble: np.ndarray, measured: np.ndarray, noise: float, rng) -> dict:
    """Coverage per level, the 90 % band, its width, interval score and CRPS of an
    ensemble (n, k) of replays for ``measured`` (k,): every replay with
    :data:`NOISE_DRAWS` draws of the measurement noise, so that the bands are
    quantiles of the predicted measurement."""
    noisy = np.repeat(ensemble, NOISE_DRAWS, axis=0)
    noisy = noisy + noise * rng.standard_normal(noisy.shape)
    # numpy's nanquantile works column by column: only where there are gaps (missing peaks)
    quantile = np.quantile if np.all(np.isfinite(noisy)) else np.nanquantile
    out: dict = {}
    for level in LEVELS:
        lo, hi = quantile(noisy, (0.5 - level / 2, 0.5 + level / 2), axis=0)
        inside = (measured >= lo) & (measured <= hi)
        out[f"coverage_{int(round(100 * level))}"] = float(np.mean(inside))
        if level == 0.9:
            out["lower"], out["upper"], out["inside"] = lo, hi, inside
    out["median"] = (np.median if quantile is np.quantile else np.nanmedian)(ensemble, axis=0)
    out["width"] = float(np.nanmean(out["upper"] - out["lower"]))
    out["interval_score"] = float(np.nanmean(interval_score(out["lower"], out["upper"], measured, 0.1)))
    ok = np.all(np.isfinite(noisy), axis=0)
    out["crps"] = float(np.mean(crps_ensemble(noisy[:, ok], measured[ok]))) if ok.any() else float("nan")
    return out


def band_statistics(replays: np.ndarray, diverged: np.ndarray, record: pd.DataFrame,
                    noise: float | None = None, seed: int = 0) -> dict:
    """Bands of ``phi`` and of the peak envelope from replays, and their calibration.

    Returns the numbers of the module docstring under the keys of
    :data:`BAND_KEYS` (angles in degrees) and, for figures and tables,
    ``t``, ``phi`` (3, n: the 5 and 95 % quantiles of the predicted
    measurement and the replays' median, rad), ``peaks_t``, ``peaks``
    (measured peak angles, rad) and ``envelope`` (3, n_peaks; the peaks of
    the replays, each with noise draws). Diverged replays are left out of
    the bands.
    """
    rng = np.random.default_rng(seed)
    t = record["t"].to_numpy(float)
    y = record["phi"].to_numpy(float)
    noise = noise_level(record) if noise is None else float(noise)
    ok = ~np.asarray(diverged, bool)
    kept = replays[ok] if ok.any() else np.full((1, t.size), np.nan)
    deg = math.degrees
    out: dict = {"t": t, "diverged": float(np.mean(diverged)) if len(diverged) else 0.0, "noise_deg": deg(noise)}
    s = _scores(kept, y, noise, rng)
    for level in LEVELS:
        key = f"coverage_{int(round(100 * level))}"
        out[key] = s[key]
    out["phi"] = np.vstack((s["lower"], s["median"], s["upper"]))
    out["covered_until_s"] = covered_until_period(t, s["inside"], float(record.attrs.get("period", np.nan)))
    amplitude = float(np.max(np.abs(y)))
    out["width_deg"] = deg(s["width"])
    out["amplitude_deg"] = deg(amplitude)
    out["width_over_amplitude"] = s["width"] / max(amplitude, 1e-12)
    out["interval_score_deg"] = deg(s["interval_score"])
    out["crps_deg"] = deg(s["crps"])
    # the peak envelope: half-cycle k of every replay against the measured half-cycle k
    peaks_t, peaks = peak_amplitudes(t, y)
    n = peaks.size
    table = np.full((kept.shape[0], n), np.nan)
    for i, phi in enumerate(kept):
        if not np.all(np.isfinite(phi)):
            continue
        _, amp = peak_amplitudes(t, phi)
        m = min(n, amp.size)
        table[i, :m] = amp[:m]
    out["peaks_t"], out["peaks"], out["envelope_peaks"] = peaks_t, peaks, float(n)
    if n and np.isfinite(table).any():
        cols = np.isfinite(table).sum(axis=0) >= max(2, kept.shape[0] // 2)
        e = _scores(table[:, cols], peaks[cols], noise, rng)
        for level in LEVELS:
            key = f"coverage_{int(round(100 * level))}"
            out[f"envelope_{key}"] = e[key]
        env = np.full((3, n), np.nan)
        env[:, cols] = np.vstack((e["lower"], e["median"], e["upper"]))
        out["envelope"] = env
        out["envelope_width_deg"] = deg(e["width"])
        out["envelope_interval_score_deg"] = deg(e["interval_score"])
        out["envelope_crps_deg"] = deg(e["crps"])
    else:
        out["envelope"] = np.full((3, n), np.nan)
        for key in BAND_KEYS:
            if key.startswith("envelope_") and key != "envelope_peaks":
                out[key] = float("nan")
    return out


def covered_until_period(t: np.ndarray, inside: np.ndarray, period: float) -> float:
    """Time from the start to the first whole roll period (consecutive periods
    from the start) in which fewer than half of the samples are ``inside``;
    the whole record when there is none (or no period)."""
    t = np.asarray(t, float)
    if not (np.isfinite(period) and period > 0):
        return float(t[-1] - t[0])
    block = np.floor((t - t[0]) / period).astype(int)
    for k in range(int(block[-1]) + 1):
        part = inside[block == k]
        if part.size and np.mean(part) < 0.5 and (t[block == k][-1] - t[block == k][0]) >= 0.9 * period:
            return float(k * period)
    return float(t[-1] - t[0])


def outside_amplitudes(record: pd.DataFrame, training: Sequence[pd.DataFrame]) -> tuple[float, tuple, tuple]:
    """Share of the record's half-cycle peaks outside the training decays' range
    (5 % margin), and both ranges ``(low, high)`` [rad]."""
    train = np.concatenate([peak_amplitudes(r["t"].to_numpy(float), r["phi"].to_numpy(float))[1]
                            for r in training] or [np.zeros(1)])
    lo, hi = float(np.min(train)), float(np.max(train))
    _, peaks = peak_amplitudes(record["t"].to_numpy(float), record["phi"].to_numpy(float))
    if peaks.size == 0:
        return 0.0, (lo, hi), (float("nan"), float("nan"))
    out = (peaks < 0.95 * lo) | (peaks > 1.05 * hi)
    return float(np.mean(out)), (lo, hi), (float(np.min(peaks)), float(np.max(peaks)))


def trust_verdict(name: str, stats: Mapping, outside: float | None = None, training_range=None,
                  record_range=None) -> tuple[bool, str]:
    """Whether the bands can be trusted on a record, and one sentence saying why."""
    cov = stats["coverage_90"]
    low, high = TRUSTED_COVERAGE
    wide = stats["width_over_amplitude"] >= 1.0
    diverged = stats["diverged"] >= 0.1
    trusted = low <= cov <= high and not wide and not diverged
    env = stats.get("envelope_coverage_90", float("nan"))
    text = (f"{name}: the 90 % band holds the measured roll angle {100 * cov:.0f} % of the time "
            f"(50/80/95 % bands: {100 * stats['coverage_50']:.0f}/{100 * stats['coverage_80']:.0f}/"
            f"{100 * stats['coverage_95']:.0f} %) and the peak envelope at "
            f"{'no' if not np.isfinite(env) else f'{100 * env:.0f} % of the'} half-cycles, mean width "
            f"{stats['width_deg']:.2g} deg ({100 * stats['width_over_amplitude']:.0f} % of the record's "
            f"{stats['amplitude_deg']:.2g} deg), first lost after {stats['covered_until_s']:.0f} s; ")
    if trusted:
        text += f"the bands can be trusted on this record (90 % coverage within {100 * low:.0f}-{100 * high:.0f} %)."
    else:
        why = []
        if cov < low:
            why.append("overconfident (the measurement leaves the band more often than nominal)")
        if cov > high:
            why.append("wider than needed")
        if wide:
            why.append("as wide as the decay itself")
        if diverged:
            why.append(f"{100 * stats['diverged']:.0f} % of the replays diverged")
        text += "the bands cannot be trusted on this record: " + ", ".join(why) + "."
    if outside and outside >= 0.05 and training_range is not None and record_range is not None:
        text += (f" {100 * outside:.0f} % of its half-cycles peak outside the training decays' amplitudes "
                 f"({math.degrees(record_range[0]):.2g}-{math.degrees(record_range[1]):.2g} deg against "
                 f"{math.degrees(training_range[0]):.2g}-{math.degrees(training_range[1]):.2g} deg): there "
                 "the model extrapolates and the discrepancy estimated on the training decays may not hold.")
    return trusted, text


def band_table(stats: Mapping, max_rows: int = 2000) -> pd.DataFrame:
    """The band of ``phi`` as a table (``t``, ``phi_q05``, ``phi_q50``, ``phi_q95`` [rad]),
    thinned to at most ``max_rows`` rows."""
    t = stats["t"]
    step = max(1, len(t) // max_rows)
    return pd.DataFrame({"t": t, "phi_q05": stats["phi"][0], "phi_q50": stats["phi"][1],
                         "phi_q95": stats["phi"][2]}).iloc[::step]


def plot_band(record: pd.DataFrame, stats: Mapping, path, title: str) -> None:
    """The decay with its 5-95 % band (top) and the peak envelope with its band (bottom)."""
    plt = pyplot()
    fig, (ax, ax_env) = plt.subplots(2, 1, figsize=(11, 7.5), sharex=True)
    k = 180.0 / math.pi
    t = stats["t"]
    ax.fill_between(t, stats["phi"][0] * k, stats["phi"][2] * k, color="tab:orange", alpha=0.35,
                    lw=0, label="5-95 % band")
    ax.plot(t, stats["phi"][1] * k, color="tab:orange", lw=0.8, label="median of the replays")
    ax.plot(record["t"], record["phi"] * k, "k", lw=0.7, label="measured")
    ax.set_ylabel("phi [deg]")
    ax.legend(fontsize=8, loc="upper right")
    env = stats["envelope"]
    pt = stats["peaks_t"]
    if len(pt):
        ax_env.fill_between(pt, env[0] * k, env[2] * k, color="tab:orange", alpha=0.35, lw=0, label="5-95 % band")
        ax_env.plot(pt, env[1] * k, color="tab:orange", lw=1.0, label="median")
        ax_env.plot(pt, stats["peaks"] * k, "ko", ms=3, label="measured peaks")
    ax_env.set_xlabel("t [s]")
    ax_env.set_ylabel("peak |phi| per half-cycle [deg]")
    ax_env.legend(fontsize=8, loc="upper right")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
