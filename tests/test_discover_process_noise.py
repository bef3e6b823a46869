"""Discovery when the sea pushes the ship: records of the independent SciPy
Mariner (``reference_mariner.py``) sailed under a wandering disturbance, a
force and moment that are each a sum of slow sinusoids (periods of 25 to
240 s, random phases; a swell's drift force, gusts: a push that lasts tens
of seconds, not a white noise and not the project's own autoregressive
process noise), with white sensor noise. A filter whose process noise is
white reads such a push as a constant force or a missing term and names it
beside the true cause; the filter whose process noise is coloured, its
correlation time estimated (:class:`studies.discovery.prediction_error.FilterScores`),
does not. The effects whose truth is exact are injected into the records
(:mod:`studies.scenarios.injected`).
"""

import numpy as np
import pandas as pd
import pytest
import reference_mariner as ref
from test_discover_independent import _discover, _noisy

from studies.scenarios.hidden import parameters_match
from studies.scenarios.injected import Injection, inject

pytestmark = pytest.mark.slow

#: standard deviation of the disturbance's X', Y', N' (prime): about 2 % of the Mariner's
#: largest rudder force and moment in these manoeuvres, a fifth of that in surge
PUSH = np.array([0.4e-5, 2.0e-5, 1.0e-5])


def _disturbance(seed: int):
    """X', Y', N' at time t: per DOF, six sinusoids of periods 25-240 s with
    random phases and amplitudes, scaled to :data:`PUSH`."""
    rng = np.random.default_rng(seed)
    omega = 2.0 * np.pi / rng.uniform(25.0, 240.0, (3, 6))
    phase = rng.uniform(0.0, 2.0 * np.pi, (3, 6))
    weight = rng.uniform(0.5, 1.0, (3, 6))
    weight *= (PUSH * np.sqrt(2.0) / np.sqrt((weight ** 2).sum(axis=1)))[:, None]

    def push(t):
        return tuple(float(v) for v in (weight * np.sin(omega * t + phase)).sum(axis=1))

    return push


def _measured(record: dict, rng, name: str) -> pd.DataFrame:
    """The independent simulator's tests' white sensor noise at 1 % of each
    velocity's excursion, the record named."""
    out = _noisy(record, rng, 0.01)
    out.attrs["name"] = name
    return out


@pytest.fixture(scope="module")
def pushed_runs():
    """Turning circle 35 deg, zig-zag 20/20 (training) and zig-zag 10/10 (held
    out), at 0.5 s, each under its own disturbance, as measured."""
    rng = np.random.default_rng(11)
    runs = [ref.turning_record(35.0, duration=700.0, dt=0.5, disturbance=_disturbance(21)),
            ref.zigzag_record(20.0, 20.0, duration=900.0, dt=0.5, disturbance=_disturbance(22)),
            ref.zigzag_record(10.0, 10.0, duration=600.0, dt=0.5, disturbance=_disturbance(23))]
    return [_measured(r, rng, name) for r, name in zip(runs, ("turning_35", "zigzag_20", "zigzag_10"))]


def test_the_disturbance_is_not_a_cause(tmp_path, pushed_runs):
    d = _discover(tmp_path, pushed_runs)
    assert d["cause"] == "none", (d["cause"], d["parameters"], d["ranking"][:3])
    # the user reads that the filter took the push as a coloured process noise
    (note,) = [n for n in d["notes"] if "process noise is" in n]
    assert "coloured" in note, note


@pytest.mark.parametrize("injection", [
    Injection(rudder_offset=np.deg2rad(2.0)),
    Injection(current_speed=0.5, current_direction=np.deg2rad(135.0)),
], ids=lambda x: x.label)
def test_an_effect_under_the_disturbance_is_named_alone(tmp_path, pushed_runs, injection):
    d = _discover(tmp_path, [inject(r, injection) for r in pushed_runs])
    (cause, truth), = injection.truth().items()
    assert d["cause"] == cause, (d["cause"], d["parameters"], d["ranking"][:3])
    assert parameters_match(cause, d["parameters"], truth), (d["parameters"], truth)
