"""The verdict ``outside_training_states``: the held-out records go where the training
records never went, and that is where the baseline departs from them.

No term fitted to the training records can be trusted in states they did
not reach, so no cause of the catalogue can be named from such a departure:
a current or a missing term fitted there would be an extrapolation dressed
as a cause. :func:`outside_training` reads the training records' envelope
of drift angle, yaw rate, speed, rudder angle and thrust loading
(:mod:`studies.analysis.state_ranges`), finds the held-out samples beyond
it, and measures which share of the baseline's departure from the held-out
records (its whole replay's errors in u, v and r, in prime units: u and v
over the approach speed U0, r over U0 / L) falls in those samples. When
most of it does (:data:`DEPARTURE_SHARE`), the verdict is this one, with
the states, their ranges and the manoeuvre that would cover them.
"""

from __future__ import annotations

import numpy as np

from ..analysis.state_ranges import STATES, beyond, training_ranges

__all__ = ["outside_training", "covering_manoeuvre", "DEPARTURE_SHARE"]

#: the verdict when at least this share of the baseline's departure (squared prime errors)
#: lies in held-out samples outside the training envelope: most of it
DEPARTURE_SHARE = 0.5


def _departure(record, prediction, vessel) -> np.ndarray | None:
    """Squared prime error of a replay per sample (u, v over U0; r over U0 / L)."""
    if prediction is None or "diverged_at" in prediction.attrs:
        return None
    n = min(len(record), len(prediction))
    out = np.zeros(n)
    for column, scale in (("u", vessel.speed), ("v", vessel.speed), ("r", vessel.speed / vessel.length)):
        e = (prediction[column].to_numpy(float)[:n] - record[column].to_numpy(float)[:n]) / scale
        out += np.where(np.isfinite(e), e, 0.0) ** 2
    return out


def covering_manoeuvre(states: dict, held_out_rudder_deg: float) -> str:
    """The manoeuvre that would bring the training records into ``states``."""
    rudder = f"{held_out_rudder_deg:.0f} deg"
    if "rudder_deg" in states:
        return (f"a turning circle with {rudder} of rudder, or a {held_out_rudder_deg:.0f}/5 zig-zag "
                "(large rudder, small heading check), in the training records")
    if "drift_deg" in states or "yaw_rate_prime" in states:
        return (f"a turning circle with {rudder} of rudder (its steady turn's drift and yaw rate) in the "
                "training records")
    if "speed_ratio" in states:
        return "a turning circle (the speed loss of a steady turn) or a run at the held-out speed in the training records"
    return "a run at the held-out propeller rate in the training records"


def outside_training(train: list, validation: list, baseline_predictions: list, vessel) -> dict | None:
    """The ``outside_training_states`` verdict's parameters, or None when the
    baseline's departure from the held-out records does not lie mostly beyond the
    training records' envelope.

    Returns ``{"states": {state: {"training": [low, high], "held_out": [low, high],
    "unit", "meaning", "share"}}, "departure_share", "records", "manoeuvre"}``:
    the states the held-out records take beyond the envelope (their ranges: the
    envelope's quantiles), the share of the baseline's departure that lies there,
    the records concerned and the manoeuvre that would cover them."""
    ranges = training_ranges(train, vessel)
    if not ranges:
        return None
    total, outside_sum = 0.0, 0.0
    states, records, rudder = {}, [], 0.0
    for record, prediction in zip(validation, baseline_predictions):
        error = _departure(record, prediction, vessel)
        if error is None:
            continue
        where = beyond(record, ranges, vessel)
        n = len(error)
        total += float(error.sum())
        if not where.states:
            continue
        outside_sum += float(error[where.outside[:n]].sum())
        records.append(where.record)
        rudder = max(rudder, float(np.max(np.abs(np.rad2deg(record["delta"].to_numpy(float))))))
        for name, info in where.states.items():
            unit, meaning = STATES[name]
            seen = states.setdefault(name, {"training": info["training"], "held_out": list(info["record"]),
                                            "unit": unit, "meaning": meaning, "share": 0.0})
            seen["held_out"] = [min(seen["held_out"][0], info["record"][0]), max(seen["held_out"][1], info["record"][1])]
            seen["share"] = max(seen["share"], info["share"])
    if not states or total <= 0.0:
        return None
    share = outside_sum / total
    if share < DEPARTURE_SHARE:
        return None
    return {"states": states, "departure_share": float(share), "records": records,
            "manoeuvre": covering_manoeuvre(states, rudder)}
