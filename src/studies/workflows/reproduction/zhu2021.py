"""What the reproduction of the thesis (Zhu 2021) computes beside the runs it reads.

The page (:mod:`studies.report.reproduction.thesis`) explains a disagreement
between the project's coefficient and the thesis' by how well the
condition's training record determines that coefficient: the record is
simulated again and identified by least squares quarter by quarter
(:func:`spread_by_condition`). Deviations are in percentage points of the
published coefficient (Mariner, prime system).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ...environment.conditions import Environment
from ...identification import build_problems
from ...identification.ls import LeastSquares
from ...models.abkowitz import abkowitz
from ...simulate import simulate
from ...simulate.manoeuvres import zigzag
from ...vessels import get_vessel

__all__ = ["QUARTERS", "spread_by_condition"]

#: the thesis' record is cut into this many parts to see how well it pins each coefficient down
QUARTERS = 4


def spread_by_condition(key: str, value: float, setup: str) -> dict:
    """How well the condition's training record pins each coefficient down:
    the standard deviation [percentage points] of its least-squares deviation
    over the four 1000 s quarters of the thesis' 20/20 zig-zag (4000 s at
    0.1 s, simulated here with the published coefficients in the
    condition's wind, the anemometer off by the condition's error, by the
    set-up's scheme and differenced as the set-up does). A
    coefficient the record determines moves little between its quarters; an
    ill-determined one takes up the wind-error force in proportions that the
    details of the data decide.

    ``key`` is the setting the condition varies (``wind.speed`` [m/s],
    ``wind.direction`` [deg, from which it blows], ``noise.wind_speed_error``
    [fraction]) and ``value`` its value; the others are the thesis' 12 m/s
    from 45 deg with a -5 % anemometer error. ``setup``: the set-up string of
    the reproduction page (wind convention, validation, scheme, derivative,
    first rudder sign, rudder execute time [s]). Returns ``{coefficient: sd
    [percentage points]}``."""
    speed, direction, error = 12.0, 45.0, -0.05
    if key == "wind.speed":
        speed = value
    elif key == "wind.direction":
        direction = value
    else:
        error = value
    vessel = get_vessel("mariner")
    convention, _, scheme, derivative, first, execute = setup.split(", ")
    if vessel.wind is not None and vessel.wind.convention != convention:
        vessel = dataclasses.replace(vessel, wind=dataclasses.replace(vessel.wind, convention=convention))
    derivative = "central" if derivative == "auto" else derivative
    model = abkowitz()
    truth = {n: vessel.coefficients[n] for n in model.names}
    manoeuvre = dataclasses.replace(zigzag(20.0, 20.0, duration=4000.0), first_sign=int(first),
                                    execute=float(execute))
    record = simulate(model, truth, vessel, manoeuvre, Environment(speed, np.deg2rad(direction)), scheme=scheme)
    record["wind_speed"] = speed * (1.0 + error)
    n = len(record)
    deviations = []
    for part in range(QUARTERS):
        piece = record.iloc[part * n // QUARTERS:(part + 1) * n // QUARTERS].reset_index(drop=True)
        params = LeastSquares().fit(build_problems(model, vessel, [piece], derivative)).params
        deviations.append([100 * (params[c] - truth[c]) / truth[c] for c in model.names])
    return dict(zip(model.names, np.std(np.array(deviations), axis=0)))
