"""Sensor noise, wind-speed measurement error and disturbance forces. All seeded.

Measurement noise (Sutulo & Guedes Soares 2014; Li et al. 2023 eq. 22)::

    zeta_i = zeta_0i + zeta_max * k0 * k_zeta * xi_i,   xi_i ~ N(0, 1)

for the recorded ``u`` (about U0), ``v``, ``r`` and ``delta``, the outputs
that eq. 22 names (the speed U follows from u and v; the heading and the
track are not polluted); ``zeta_max`` is the largest absolute clean value
(``u - U0`` for surge), the reduction factor ``k_zeta`` is 0.05 for the
rudder angle and the surge velocity and 1 for the others.

Wind-speed measurement error (thesis eq. 4.1): the record carries
``V_p = V_w (1 + accuracy)`` while the true ``V_w`` acted on the ship.

Disturbance (Wang et al. 2021 eq. 12-14): an earth-fixed slowly varying
bias ``b`` (a Wiener process, ``db = w1``) and body-fixed process noise
``w2`` added to the prime forces, each sized by eq. 14, ``max|clean prime
force| * k0 * k_i * zeta``, with ``k_i`` = 0.2 for surge and 1.0 for sway
and yaw and the noise levels NL0-NL3 of its Table 2 (k0 = 0, 5, 10, 20 %).
The process noise is white, of that standard deviation, held over one
integration step. Eq. 14 sizes the bias in one of two readings
(:data:`BIAS_SCALINGS`, ``disturbance.scaling``):

``record`` (default)
    eq. 14 is the size of the bias: the Wiener path is normalised so that
    its standard deviation at the end of the record equals the eq. 14 size
    (increments of standard deviation ``size * sqrt(dt / T)``, ``T`` the
    record's length); over the record it grows as ``size * sqrt(t / T)``.
    This is the reading of the paper's words (k0 "used to label the noisy
    extent") and of the rule it borrows, Sutulo & Guedes Soares' sizing of
    measurement noise, which sets the size of the signal, not a rate.
``per_second``
    eq. 14 is the intensity of the Wiener process per square-root second
    (increments ``size * sqrt(dt)``): the standard deviation at time ``t``
    is ``size * sqrt(t / 1 s)``, 24.5 times the eq. 14 size after 600 s,
    so that the NL1 bias already exceeds the largest clean sway force and
    yaw moment (kept for comparison; the project's reading before the
    ``record`` one).

References
----------
Sutulo, S., Guedes Soares, C. (2014). An algorithm for offline identification
of ship manoeuvring mathematical models from free-running tests. Ocean
Engineering 79, 10-25. doi:10.1016/j.oceaneng.2014.01.007

Wang, T., Li, G., Wu, B., Aesoy, V., Zhang, H. (2021). Parameter
identification of ship manoeuvring model under disturbance using support
vector machine method. Ships and Offshore Structures 16(S1), 13-21.

Zhu, M. (2021). MSc thesis, NTNU, eq. 4.1.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..config import DISTURBANCE_SCALINGS
from ..errors import ConfigError

__all__ = ["NOISE_LEVELS", "REDUCTION_FACTORS", "DISTURBANCE_FACTORS", "BIAS_SCALINGS",
           "add_measurement_noise", "record_wind", "disturbance_forces", "noise_level"]

#: k0 of the SVM paper's noise levels NL0-NL3
NOISE_LEVELS = {0: 0.0, 1: 0.05, 2: 0.10, 3: 0.20}

#: k_zeta of Li et al. (2023) eq. 22 per recorded channel
REDUCTION_FACTORS = {"u": 0.05, "v": 1.0, "r": 1.0, "delta": 0.05}

#: k_i of Wang et al. (2021) eq. 14 per DOF (surge, sway, yaw)
DISTURBANCE_FACTORS = np.array([0.2, 1.0, 1.0])

#: how eq. 14 sizes the Wiener bias (``disturbance.scaling``; the module's docstring)
BIAS_SCALINGS = DISTURBANCE_SCALINGS


def noise_level(level) -> float:
    """k0 of a noise level given as NL number (0-3) or ``"NL2"``."""
    key = level
    if isinstance(level, str):
        key = level.upper().removeprefix("NL")
    try:
        return NOISE_LEVELS[int(key)]
    except (KeyError, ValueError):
        raise ConfigError(f"disturbance level must be one of NL0-NL3 (0-3), got {level!r}") from None


def add_measurement_noise(record: pd.DataFrame, k0: float, speed0: float,
                          rng: np.random.Generator) -> pd.DataFrame:
    """Copy of ``record`` with Sutulo & Guedes Soares noise of degree ``k0``.

    Parameters
    ----------
    k0 : float
        Degree of noise as a fraction (0.05 = 5 %); must be in [0, 1].
    speed0 : float
        Nominal speed U0 [m/s]; surge noise scales with ``max|u - U0|``.
    """
    if not (0.0 <= k0 <= 1.0):
        raise ConfigError(f"noise.measurement is a fraction in [0, 1] (0.05 = 5 %), got {k0}")
    out = record.copy()
    if k0 == 0:
        return out
    for col, k in REDUCTION_FACTORS.items():
        x = record[col].to_numpy(float)
        ref = x - speed0 if col == "u" else x
        scale = np.max(np.abs(ref)) * k0 * k
        out[col] = x + scale * rng.standard_normal(len(x))
    return out


def record_wind(record: pd.DataFrame, accuracy: float) -> pd.DataFrame:
    """Record the wind speed with anemometer error: ``V_p = V_w (1 + accuracy)``."""
    if not (-1.0 < accuracy < 1.0):
        raise ConfigError(f"noise.wind_speed_error is a fraction in (-1, 1) (-0.05 = -5 %), got {accuracy}")
    out = record.copy()
    if "wind_speed" in out:
        out["wind_speed"] = out["wind_speed"] * (1.0 + accuracy)
    return out


def disturbance_forces(n_steps: int, dt: float, force_scale: np.ndarray, bias_level: float,
                       process_level: float, rng: np.random.Generator,
                       scaling: str = "record") -> np.ndarray:
    """External prime forces per integration step (n_steps, 6).

    Columns 0-2: earth-fixed bias ``b`` (Wiener process, zero in the first
    row); columns 3-5: body-fixed process noise ``w2``. Row ``i`` acts
    during the step that starts at ``t_i = i dt``. All values are prime
    forces and moment (X', Y', N', divided by ``0.5 rho L^2 U^2`` and
    ``0.5 rho L^3 U^2``), as ``force_scale``.

    Parameters
    ----------
    n_steps : int
        Integration steps of the record (rows returned).
    dt : float
        Integration step [s].
    force_scale : ndarray (3,)
        ``max |clean prime force|`` per DOF (X', Y', N') of the clean run [-].
    bias_level, process_level : float
        k0 of the bias and of the process noise, fractions
        (:data:`NOISE_LEVELS`: 0.05 = NL1). The eq. 14 size per DOF is
        ``force_scale * k_i * k0`` [-].
    rng : numpy Generator
    scaling : str
        How eq. 14 sizes the bias (:data:`BIAS_SCALINGS`). ``record``: the
        bias's standard deviation in the last row (at ``T = (n_steps - 1)
        dt``) is the eq. 14 size [-], increments ``size sqrt(dt / T)``.
        ``per_second``: the eq. 14 size is the intensity [1/sqrt(s)],
        increments ``size sqrt(dt)``, standard deviation ``size sqrt(t)``
        at ``t`` [s]. The process noise is the same in both: white, of
        standard deviation the eq. 14 size, one draw per step.
    """
    if scaling not in BIAS_SCALINGS:
        raise ConfigError(f"disturbance.scaling must be one of {', '.join(BIAS_SCALINGS)}, "
                          f"got {scaling!r}")
    scale = np.asarray(force_scale, float) * DISTURBANCE_FACTORS
    out = np.zeros((n_steps, 6))
    if bias_level > 0 and n_steps > 1:
        if scaling == "record":
            step_sd = scale * bias_level / np.sqrt(n_steps - 1)      # sqrt(dt / T), T = (n_steps - 1) dt
        else:
            step_sd = scale * bias_level * np.sqrt(dt)
        steps = rng.standard_normal((n_steps, 3)) * step_sd
        out[:, :3] = np.cumsum(steps, axis=0) - steps[0]
    if process_level > 0:
        out[:, 3:] = rng.standard_normal((n_steps, 3)) * (scale * process_level)
    return out
