"""Posterior predictive bands of a replayed record, and how well they are calibrated.

A band is built from replays of a validation record's measured rudder from
its measured initial state (:func:`predictive_draws`): each replay takes one
coefficient set drawn from the posterior and, with a model discrepancy
(:class:`studies.identification.discrepancy.Discrepancy`), its own realisation of
the missing accelerations and an initial state drawn from the sensor's
uncertainty (its noise, and the size of the sensor biases found on the
training records). Quantiles of the replayed ``x0, y0, psi`` per sample, widened
by the measurement noise of each channel, are the bands
(:func:`band_statistics`). Their calibration is judged on the measurement:

coverage
    fraction of the samples where the measurement lies inside the band, for
    the nominal levels of :data:`LEVELS` (``coverage_xy_<level>``: ``x0``
    and ``y0`` both inside the band of that level); serial correlation makes
    one record's coverage nearly all or nothing (the Mariner with its true
    coefficients and its true process noise: 17 of 24 held-out records
    covered all the time by the 90 % band, 2 between 80 and 97 %, 4 below
    80 %). Both channels inside their 5-95 % bands is a smaller region
    than 90 % of the ensemble: for a calibrated ensemble 81 % when the two
    errors are independent, 77 % with 50 replays, 0.70-0.74 measured on
    zig-zags of the KVLCC2 MMG model. ``coverage_joint_<level>``
    (:func:`joint_coverage`) is the calibrated check: the rectangle of
    ``x0`` and ``y0`` that holds the level's share of the replays jointly,
    the measurement ranked as one more replay (0.90-0.91 on those zig-zags);
    :func:`trust_verdict` judges it.
width
    mean band width [m] of ``x0`` and ``y0`` (``width_xy_m``: their mean),
    compared with the extent of the manoeuvre (the larger range of the
    measured ``x0`` and ``y0``): a band as wide as the manoeuvre says nothing.
interval score
    of the 90 % band (Gneiting & Raftery 2007, eq. 43), mean over the
    samples [m]: ``(u - l) + (2 / alpha) (l - y) 1{y < l} + (2 / alpha)
    (y - u) 1{y > u}`` with ``alpha = 0.1``; lower is better, and it
    punishes both width and misses.
CRPS
    continuous ranked probability score of the ensemble of replays (with
    measurement noise) for ``x0`` and ``y0``, mean over the samples [m];
    lower is better.

:func:`trust_verdict` turns these into one sentence: the bands are trusted
on a record when the joint 90 % band covers between :data:`TRUSTED_COVERAGE`
of it, is narrower than the manoeuvre and fewer than 10 % of the replays
diverged.

The replays run on the model's own simulator
(:func:`studies.simulate.simulator.replay_plan`: the MMG one for MMG
particulars).

References
----------
Gneiting, T., Raftery, A.E. (2007). Strictly proper scoring rules,
prediction, and estimation. J. Am. Stat. Assoc. 102(477), 359-378.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..plotting import pyplot

# the filter, the regression's primes and the simulator are imported where they are used:
# the levels and the trust verdict are read by `studies report`, which simulates nothing

__all__ = ["LEVELS", "Z_SCORES", "TRUSTED_COVERAGE", "interval_score", "crps_ensemble", "joint_coverage",
           "predictive_draws", "point_replay", "band_statistics", "pit_values", "training_envelope",
           "outside_fraction", "trust_verdict", "plot_calibration"]

#: nominal levels of the calibration check
LEVELS = (0.5, 0.8, 0.9, 0.95)
#: standard normal quantile of each central level (the measurement-noise widening)
Z_SCORES = {0.5: 0.674, 0.8: 1.282, 0.9: 1.645, 0.95: 1.960}
#: 90 % band coverage taken as calibrated on a held-out record
TRUSTED_COVERAGE = (0.8, 0.97)
#: integrator columns of x0, y0, psi
_COLUMNS = (("x0", 3), ("y0", 4), ("psi", 5))


def interval_score(lower, upper, y, alpha: float = 0.1) -> np.ndarray:
    """Interval score of central ``(1 - alpha)`` intervals (Gneiting & Raftery 2007, eq. 43)."""
    lower, upper, y = (np.asarray(a, float) for a in (lower, upper, y))
    return ((upper - lower) + (2.0 / alpha) * np.maximum(lower - y, 0.0)
            + (2.0 / alpha) * np.maximum(y - upper, 0.0))


def crps_ensemble(samples, y) -> np.ndarray:
    """CRPS of an ensemble ``samples`` (m, n) for observations ``y`` (n,).

    ``E|X - y| - E|X - X'| / 2`` of the ensemble's empirical distribution,
    the second term from the sorted members in O(m log m).
    """
    x = np.sort(np.asarray(samples, float), axis=0)
    y = np.asarray(y, float)
    m = x.shape[0]
    first = np.mean(np.abs(x - y[None, :]), axis=0)
    weights = (2.0 * np.arange(1, m + 1) - m - 1.0)[:, None]
    second = 2.0 * np.sum(weights * x, axis=0) / (m * m)
    return first - 0.5 * second


def _initial_spread(record: pd.DataFrame, settings: KalmanSettings, bias_sd) -> dict:
    """Standard deviations of the initial ``u, v, r``: measurement noise at the
    first sample and the sensor biases ``bias_sd`` (3,) found on the training records."""
    from ..identification.kalman import measurement_variance

    head = record.iloc[: min(len(record), 2000)]
    var = measurement_variance(head, ("u", "v", "r"), settings.noise_window, settings.noise_span)[0]
    return {ch: float(np.sqrt(var[j] + float(bias_sd[j]) ** 2)) for j, ch in enumerate(("u", "v", "r"))}


def _mean_along_centre(plan, centre: np.ndarray, discrepancy, vessel, record: pd.DataFrame,
                       passes: int = 2) -> np.ndarray:
    """The discrepancy's mean accelerations (steps, 3) on the integration grid,
    evaluated along the replay of the coefficients ``centre`` that carries
    them (``passes`` fixed-point passes from the uncorrected replay); zeros
    without a mean or when that replay diverges. Every replay of the band
    adds the same series: the mean is smooth in the state, and the replays
    stay near their centre."""
    mean = np.zeros((plan.steps, 3))
    if getattr(discrepancy, "mean_coef", None) is None:
        return mean
    t = record["t"].to_numpy(float)
    grid = np.arange(plan.steps) * plan.step
    for _ in range(passes):
        states, diverged = plan.run_one(centre, plan.external_accelerations(mean), None,
                                        discrepancy.rate_gain)
        if diverged >= 0:
            return np.zeros((plan.steps, 3))
        n = min(len(states), len(t))
        on_grid = [np.interp(grid, t[:n] - t[0], states[:n, j]) for j in range(3)]
        mean = discrepancy.mean_along(on_grid[0] + float(vessel.speed), on_grid[1], on_grid[2], vessel.length)
    return mean


def predictive_draws(model, vectors: np.ndarray, vessel, record: pd.DataFrame, discrepancy=None,
                     seed: int = 0, settings: KalmanSettings | None = None, modules=None,
                     steer: bool = False):
    """Replays of ``record`` for the posterior predictive band.

    The replays run on the model's own simulator
    (:func:`~studies.simulate.simulator.replay_plan`: the MMG simulator for
    an MMG vessel, ``modules`` its propeller and rudder parameters, the
    record's ``n`` its propeller rate; the compiled Abkowitz-type integrator
    otherwise). Without a ``discrepancy`` every coefficient vector is
    replayed from the measured initial state. With one, each replay also
    takes a realisation of the discrepancy accelerations and an initial
    ``u, v, r`` drawn around the measured one (:func:`_initial_spread`: the
    sensor noise and the sensor biases found on the training records).
    With ``steer`` a zig-zag record is replayed as it was run, the rudder
    reversed when each replay's own heading reaches the test's angle
    (:func:`~studies.simulate.manoeuvres.zigzag_of_record`): its heading
    error corrects itself as the ship's did, where a replay of the measured
    rudder turns yaw noise into heading drift; other records follow their
    measured rudder. A discrepancy with a mean that depends on the state
    (``mean_coef``) adds it to every replay along the replay of the
    coefficients' median that carries it (:func:`_mean_along_centre`).
    Returns ``(states (n_draws, n, 7), diverged (n_draws,))`` as
    :func:`~studies.simulate.simulator.replay_many` (columns 3-5: ``x0, y0,
    psi``).
    """
    from ..identification.kalman import KalmanSettings
    from ..simulate.simulator import replay_plan

    vectors = np.atleast_2d(vectors)
    plan = replay_plan(model, vessel, record, modules, steer=steer)
    if discrepancy is None:
        return plan.run(vectors)
    settings = settings or KalmanSettings()
    rng = np.random.default_rng(seed)
    spread = _initial_spread(record, settings, discrepancy.initial_sd)
    first = record.iloc[0]
    mean = _mean_along_centre(plan, np.median(vectors, axis=0), discrepancy, vessel, record)
    states, diverged = [], []
    for vector in vectors:
        ext = plan.external_accelerations(discrepancy.realise(plan.steps, plan.step, rng) + mean)
        initial = {ch: float(first[ch]) + spread[ch] * rng.standard_normal() for ch in ("u", "v", "r")}
        s, d = plan.run_one(vector, ext, initial, discrepancy.rate_gain)
        states.append(s)
        diverged.append(d)
    return np.asarray(states), np.asarray(diverged)


def point_replay(model, vector: np.ndarray, vessel, record: pd.DataFrame, modules=None,
                 steer: bool = False) -> tuple[pd.DataFrame, bool]:
    """The replay of one coefficient vector as the band's replays run
    (:func:`predictive_draws` without a discrepancy): ``(track, steered)``,
    the track a frame of ``t`` [s, the record's], ``x0``, ``y0`` [m] and
    ``psi`` [rad] (all NaN from the step it diverged), ``steered`` whether a
    zig-zag was run by its rule."""
    from ..simulate.simulator import replay_plan

    plan = replay_plan(model, vessel, record, modules, steer=steer)
    states, diverged = plan.run(np.atleast_2d(np.asarray(vector, float)))
    states = states[0]
    n = min(states.shape[0], len(record))
    track = pd.DataFrame({"t": record["t"].to_numpy(float)[:n], "x0": states[:n, 3], "y0": states[:n, 4],
                          "psi": states[:n, 5]})
    if int(diverged[0]) >= 0:
        track.loc[:, ["x0", "y0", "psi"]] = np.nan
    track.attrs["name"] = record.attrs.get("name", "record")
    return track, bool(getattr(plan, "steered", False))


def band_statistics(states: np.ndarray, diverged: np.ndarray, record: pd.DataFrame, noise: bool = True,
                    quantiles=(0.05, 0.5, 0.95), levels=LEVELS, seed: int = 0) -> dict:
    """Bands of ``x0, y0, psi`` from replays, and their calibration on the measurement.

    Returns ``{"t", "x0", "y0", "psi"}`` (each channel (len(quantiles), n):
    lower, ..., upper of the main band), ``"paths"`` (``x0, y0`` of every
    replay, thinned to at most 500 samples), ``"diverged"`` (share of the
    replays that left the physical range; their rows are ignored) and the
    numbers of the module docstring: ``coverage_<ch>``, ``coverage_xy``,
    ``coverage_all``, ``covered_until_s`` of the main band,
    ``coverage_xy_<level>`` per level, ``width_x0_m``, ``width_y0_m``,
    ``width_xy_m``, ``width_psi_deg``, ``extent_m``, ``width_over_extent``,
    ``interval_score_{x0,y0,xy}_m``, ``crps_{x0,y0,xy}_m``. With ``noise``
    the bands are widened by the standard normal quantile of their level
    times the measurement noise of the channel
    (:func:`~studies.identification.kalman.measurement_variance`), which matters
    at the start where every replay begins at the measured state.
    """
    n = min(states.shape[1], len(record))
    out = {"t": record["t"].to_numpy(float)[:n], "diverged": float(np.mean(diverged >= 0))}
    sd = {ch: np.zeros(n) for ch, _ in _COLUMNS}
    if noise:
        from ..identification.kalman import measurement_variance

        var = measurement_variance(record.iloc[:n], ("x0", "y0", "psi"))
        for j, (ch, _) in enumerate(_COLUMNS):
            sd[ch] = np.sqrt(var[:, j])
    values, measured, inside = {}, {}, {}
    for ch, j in _COLUMNS:
        vals = states[:, :n, j]
        ok = np.isfinite(vals).all(axis=1)
        values[ch] = vals[ok]
        measured[ch] = record[ch].to_numpy(float)[:n]
        if ok.any():
            q = np.quantile(values[ch], quantiles, axis=0)
        else:
            q = np.full((len(quantiles), n), np.nan)
        q[0] = q[0] - 1.645 * sd[ch]
        q[-1] = q[-1] + 1.645 * sd[ch]
        out[ch] = q
        inside[ch] = (measured[ch] >= q[0]) & (measured[ch] <= q[-1])
        out[f"coverage_{ch}"] = float(np.mean(inside[ch]))
    step = max(1, n // 500)
    out["paths"] = states[:, :n:step, 3:5]
    both = inside["x0"] & inside["y0"]
    out["coverage_xy"] = float(np.mean(both))
    out["coverage_all"] = float(np.mean(both & inside["psi"]))
    out["covered_until_s"] = covered_until(out["t"], both)
    # calibration: the band of every nominal level
    for level in levels:
        hit = np.ones(n, bool)
        for ch in ("x0", "y0"):
            if len(values[ch]):
                lo, hi = np.quantile(values[ch], (0.5 - level / 2, 0.5 + level / 2), axis=0)
            else:
                lo = hi = np.full(n, np.nan)
            z = Z_SCORES.get(level, 1.645)
            hit &= (measured[ch] >= lo - z * sd[ch]) & (measured[ch] <= hi + z * sd[ch])
        out[f"coverage_xy_{int(round(100 * level))}"] = float(np.mean(hit))
    # the joint check: the measured position as one more member of the ensemble (with the
    # measurement noise on every member), inside when its central rectangle is no larger than
    # the one that holds the level's share of the members jointly
    if len(values["x0"]) and len(values["y0"]) and len(values["x0"]) == len(values["y0"]):
        jitter = np.random.default_rng([seed, 1])
        noisy = [values[ch] + sd[ch][None, :] * jitter.standard_normal(values[ch].shape) for ch in ("x0", "y0")]
        joint = joint_coverage(noisy[0], noisy[1], measured["x0"], measured["y0"], levels)
    else:
        joint = {level: float("nan") for level in levels}
    for level in levels:
        out[f"coverage_joint_{int(round(100 * level))}"] = joint[level]
    out["coverage_joint"] = joint.get(0.9, float("nan"))
    width = {ch: out[ch][-1] - out[ch][0] for ch in ("x0", "y0", "psi")}
    out["width_x0_m"] = float(np.nanmean(width["x0"]))
    out["width_y0_m"] = float(np.nanmean(width["y0"]))
    out["width_xy_m"] = 0.5 * (out["width_x0_m"] + out["width_y0_m"])
    out["width_psi_deg"] = float(np.rad2deg(np.nanmean(width["psi"])))
    out["extent_m"] = float(max(np.ptp(measured["x0"]), np.ptp(measured["y0"])))
    out["width_over_extent"] = out["width_xy_m"] / max(out["extent_m"], 1e-9)
    rng = np.random.default_rng(seed)
    for ch in ("x0", "y0"):
        score = interval_score(out[ch][0], out[ch][-1], measured[ch], 0.1)
        out[f"interval_score_{ch}_m"] = float(np.nanmean(score))
        if len(values[ch]):
            noisy = values[ch] + sd[ch][None, :] * rng.standard_normal(values[ch].shape)
            out[f"crps_{ch}_m"] = float(np.mean(crps_ensemble(noisy, measured[ch])))
        else:
            out[f"crps_{ch}_m"] = float("nan")
    out["interval_score_xy_m"] = 0.5 * (out["interval_score_x0_m"] + out["interval_score_y0_m"])
    out["crps_xy_m"] = 0.5 * (out["crps_x0_m"] + out["crps_y0_m"])
    out.update(pit_values(values, measured, sd, seed))
    return out


#: most samples per record kept for the PIT (one record's neighbouring samples are nearly the same)
PIT_SAMPLES = 200


def pit_values(values: dict, measured: dict, sd: dict, seed: int = 0, samples: int = PIT_SAMPLES) -> dict:
    """Probability integral transforms of the measurement in the replays, at most ``samples`` per record.

    ``values[ch]`` (m, n) are the finite replays of ``x0`` and ``y0``,
    ``measured[ch]`` (n,) the measurement and ``sd[ch]`` (n,) its noise [m],
    added to every replay. Returns ``pit_x0`` and ``pit_y0``: the share of
    the replays below the measurement at evenly spaced samples, ties split
    at random (uniform on [0, 1] for a calibrated ensemble; a U shape is an
    overconfident band, a hump a band wider than needed, a slope a bias);
    and ``joint_level``: the smallest level of the joint band
    (:func:`joint_coverage`) that holds the measurement, uniform for a
    calibrated ensemble, so that its share at or below ``p`` is the joint
    coverage at level ``p``. Empty arrays without replays.
    """
    if not len(values["x0"]) or len(values["x0"]) != len(values["y0"]):
        return {"pit_x0": np.zeros(0), "pit_y0": np.zeros(0), "joint_level": np.zeros(0)}
    n = values["x0"].shape[1]
    rows = np.unique(np.linspace(0, n - 1, min(samples, n)).astype(int))
    rng = np.random.default_rng([seed, 2])
    noisy = {ch: values[ch][:, rows] + sd[ch][None, rows] * rng.standard_normal((len(values[ch]), len(rows)))
             for ch in ("x0", "y0")}
    out = {}
    for ch in ("x0", "y0"):
        y = measured[ch][rows]
        below = np.sum(noisy[ch] < y[None, :], axis=0)
        ties = np.sum(noisy[ch] == y[None, :], axis=0)
        out[f"pit_{ch}"] = (below + rng.uniform(size=len(rows)) * (ties + 1)) / (len(noisy[ch]) + 1)
    pool = [np.vstack([noisy[ch], measured[ch][None, rows]]) for ch in ("x0", "y0")]
    score = np.maximum(central_rank_level(pool[0]), central_rank_level(pool[1]))
    members, mine = score[:-1], score[-1]
    smaller = np.sum(members < mine[None, :], axis=0)
    equal = np.sum(members == mine[None, :], axis=0)
    out["joint_level"] = (smaller + rng.uniform(size=len(rows)) * (equal + 1)) / (len(members) + 1)
    return out


def central_rank_level(pool: np.ndarray) -> np.ndarray:
    """Per member of ``pool`` (m, n) the level of the smallest central interval of
    the pool's ranks at each sample that holds it: ``|2 (rank + 1/2) / m - 1|``."""
    m = pool.shape[0]
    ranks = np.argsort(np.argsort(pool, axis=0, kind="stable"), axis=0, kind="stable")
    return np.abs(2.0 * (ranks + 0.5) / m - 1.0)


def joint_coverage(x0, y0, measured_x0, measured_y0, levels=LEVELS) -> dict:
    """Share of the samples where the measured ``(x0, y0)`` lies in the joint
    band of each level: ``{level: coverage}``.

    ``x0``, ``y0`` (m, n) are the replays. The measurement joins them as one
    more member; each member's score is the larger of its central rank levels
    in ``x0`` and ``y0`` (:func:`central_rank_level`), and the measurement is
    inside the band of level ``p`` when its score is no larger than the
    ``ceil(p (m + 1))``-th smallest score of the replays: the rectangle of
    ``x0`` and ``y0`` quantiles that holds ``p`` of the replays *jointly*
    (split-conformal ranks: a measurement exchangeable with the replays is
    inside with probability at least ``p``). The 5-95 % band of each channel
    (``coverage_xy``) holds both channels of a calibrated ensemble less often
    than 90 %: 81 % when their errors are independent, about 77 % with 50
    replays (whose 5-95 % quantiles hold a further replay 88 % of the time).
    """
    m = x0.shape[0]
    pool_x = np.vstack([x0, np.asarray(measured_x0, float)[None, :]])
    pool_y = np.vstack([y0, np.asarray(measured_y0, float)[None, :]])
    score = np.maximum(central_rank_level(pool_x), central_rank_level(pool_y))
    members = np.sort(score[:-1], axis=0)
    out = {}
    for level in levels:
        k = int(np.ceil(level * (m + 1))) - 1
        threshold = members[min(k, m - 1)] if k < m else np.full(score.shape[1], np.inf)
        out[level] = float(np.mean(score[-1] <= threshold))
    return out


def covered_until(t: np.ndarray, inside: np.ndarray, grace: float = 10.0) -> float:
    """Time from the start until the measurement first stays outside the band
    for longer than ``grace`` seconds (the whole record when it never does)."""
    outside = ~inside
    start = None
    for i in range(len(t)):
        if outside[i]:
            if start is None:
                start = i
            if t[i] - t[start] >= grace:
                return float(t[start] - t[0])
        else:
            start = None
    return float(t[-1] - t[0])


#: prime states whose training range is compared
ENVELOPE_STATES = ("u'", "v'", "r'")


def training_envelope(records, vessel) -> dict:
    """Range ``{state: (low, high)}`` of the prime ``u', v', r'`` over the training records."""
    from ..identification.regression import prime_states

    primes = np.vstack([prime_states(r["u"], r["v"], r["r"], r["delta"], vessel)[:, :3] for r in records])
    return {name: (float(np.min(primes[:, j])), float(np.max(primes[:, j])))
            for j, name in enumerate(ENVELOPE_STATES)}


def outside_fraction(record: pd.DataFrame, envelope: dict, vessel) -> tuple[float, dict]:
    """Share of the record's samples whose prime ``u', v', r'`` leave the
    training envelope, and the record's own range ``{state: (low, high)}``."""
    from ..identification.regression import prime_states

    primes = prime_states(record["u"], record["v"], record["r"], record["delta"], vessel)[:, :3]
    out = np.zeros(len(primes), bool)
    ranges = {}
    for j, name in enumerate(ENVELOPE_STATES):
        lo, hi = envelope[name]
        span = hi - lo
        out |= (primes[:, j] < lo - 0.05 * span) | (primes[:, j] > hi + 0.05 * span)
        ranges[name] = (float(np.min(primes[:, j])), float(np.max(primes[:, j])))
    return float(np.mean(out)), ranges


def trust_verdict(name: str, stats: dict, outside: float | None = None, ranges: dict | None = None,
                  envelope: dict | None = None) -> tuple[bool, str]:
    """Whether the bands can be trusted on a record, and one sentence saying why.

    Judged on the joint band (``coverage_joint``, :func:`joint_coverage`)
    when the statistics have it: the 5-95 % bands of ``x0`` and ``y0``
    (``coverage_xy``) hold both channels of a calibrated ensemble less often
    than 90 %.
    """
    joint = "coverage_joint" in stats and np.isfinite(stats["coverage_joint"])
    key = "coverage_joint" if joint else "coverage_xy"
    cov = stats[key]
    low, high = TRUSTED_COVERAGE
    wide = stats["width_over_extent"] >= 1.0
    diverged = stats["diverged"] >= 0.1
    trusted = low <= cov <= high and not wide and not diverged
    text = (f"{name}: the {'joint ' if joint else ''}90 % band holds the measured track (x0 and y0) "
            f"{100 * cov:.0f} % of the time (50/80/95 % bands: {100 * stats[key + '_50']:.0f}/"
            f"{100 * stats[key + '_80']:.0f}/{100 * stats[key + '_95']:.0f} %"
            + (f"; the 5-95 % bands of x0 and y0 both: {100 * stats['coverage_xy']:.0f} %" if joint else "")
            + f"), mean width "
            f"{stats['width_xy_m']:.0f} m ({100 * stats['width_over_extent']:.0f} % of the manoeuvre's "
            f"{stats['extent_m']:.0f} m), first lost after {stats['covered_until_s']:.0f} s; ")
    if trusted:
        text += (f"the bands can be trusted on this record (90 % coverage within "
                 f"{100 * low:.0f}-{100 * high:.0f} %).")
    else:
        why = []
        if cov < low:
            why.append("overconfident (the measurement leaves the band more often than nominal)")
        if cov > high:
            why.append("wider than needed")
        if wide:
            why.append("as wide as the manoeuvre itself")
        if diverged:
            why.append(f"{100 * stats['diverged']:.0f} % of the replays diverged")
        text += "the bands cannot be trusted on this record: " + ", ".join(why) + "."
    if outside and ranges and envelope:
        worst = max(ENVELOPE_STATES, key=lambda s: max(envelope[s][0] - ranges[s][0],
                                                       ranges[s][1] - envelope[s][1]))
        text += (f" {100 * outside:.0f} % of the record lies outside the states of the training "
                 f"records ({worst} in [{ranges[worst][0]:.2f}, {ranges[worst][1]:.2f}] against "
                 f"[{envelope[worst][0]:.2f}, {envelope[worst][1]:.2f}] in training): there the model "
                 "extrapolates and the discrepancy estimated on the training records may not hold.")
    return trusted, text


def plot_calibration(stats: dict, path, title: str,
                     series=(("coverage_xy", "x0 and y0 inside their bands"),
                             ("coverage_joint", "inside the joint band"))) -> None:
    """Coverage of the measurement against the nominal level (50/80/90/95 %).

    ``series`` lists ``(key, label)``: the curve of ``stats["<key>_<level>"]``
    per level (the manoeuvring bands: the measured track, each channel in its
    own band, ``coverage_xy``, and in the joint band, ``coverage_joint``;
    the roll bands: the angle and the peak envelope).
    """
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5.5, 5.0))
    ax.plot([0, 1], [0, 1], color="0.6", lw=1, ls="--", label="calibrated")
    ax.plot([0.9, 0.9], TRUSTED_COVERAGE, color="tab:green", lw=8, alpha=0.3, solid_capstyle="butt",
            label="accepted at 90 %")
    for (key, label), color in zip(series, ("tab:orange", "tab:blue", "tab:purple")):
        levels = [lv for lv in LEVELS if np.isfinite(stats.get(f"{key}_{int(round(100 * lv))}", np.nan))]
        cover = [stats[f"{key}_{int(round(100 * lv))}"] for lv in levels]
        ax.plot(levels, cover, "o-", color=color, label=label)
        for lv, c in zip(levels, cover):
            ax.annotate(f"{100 * c:.0f} %", (lv, c), textcoords="offset points", xytext=(4, -12), fontsize=8,
                        color=color)
    ax.set_xlim(0.4, 1.0)
    ax.set_ylim(0.0, 1.02)
    ax.set_xlabel("nominal level of the band")
    ax.set_ylabel("share of the record inside the band")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
