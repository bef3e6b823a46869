"""LS identification recovers the Mariner coefficients (thesis Tables 4.3-4.8)."""

import numpy as np
import pytest

from conftest import deviations
from studies.environment.noise import record_wind
from studies.identify import LeastSquares, build_problems

# Thesis Tables 4.3-4.5, columns "Original" and "LS" (clean 20/20 zig-zag).
THESIS_LS_CLEAN = {
    "Xu": -1.84e-3, "Xuu": -1.10e-3, "Xuuu": -2.15e-3, "Xvv": -8.99e-3, "Xrr": 1.80e-4,
    "Xrv": 7.98e-3, "Xdd": -9.50e-4, "Xudd": -1.90e-3, "Xvd": 9.30e-4, "Xuvd": 9.30e-4,
    "Yv": -1.16e-2, "Yr": -4.99e-3, "Yvvv": -8.08e-2, "Yvvr": 1.54e-1, "Yvu": -1.16e-2,
    "Yru": -4.99e-3, "Yd": 2.78e-3, "Yddd": -9.00e-4, "Yud": 5.56e-3, "Yuud": 2.78e-3,
    "Yvdd": -4.00e-5, "Yvvd": 1.19e-2, "Y0": -4.00e-5, "Y0u": -8.00e-5, "Y0uu": -4.00e-5,
    "Nv": -2.64e-3, "Nr": -1.66e-3, "Nvvv": 1.64e-2, "Nvvr": -5.48e-2, "Nvu": -2.64e-3,
    "Nru": -1.66e-3, "Nd": -1.39e-3, "Nddd": 4.50e-4, "Nud": -2.78e-3, "Nuud": -1.39e-3,
    "Nvdd": 1.30e-4, "Nvvd": -4.89e-3, "N0": 3.00e-5, "N0u": 6.00e-5, "N0uu": 3.00e-5,
}

# Thesis Tables 4.6-4.8, LS deviation [%] at 12 m/s from 45 deg with -5 % wind-speed error.
THESIS_LS_12MS_MINUS5 = {
    "Xu": -2.75, "Xuu": -12.49, "Xuuu": -11.57, "Xvv": -8.20, "Xrr": 44.90, "Xrv": 6.09,
    "Xdd": 4.72, "Xudd": 9.27, "Xvd": 3.38, "Xuvd": 3.77, "Yv": -0.06, "Yr": 0.08,
    "Yvvv": -1.61, "Yvvr": -1.01, "Yvu": 7.29, "Yru": 7.83, "Yd": 0.03, "Yddd": 0.27,
    "Yud": 4.35, "Yuud": 46.18, "Yvdd": 135.91, "Yvvd": -2.23, "Y0": -40.71, "Y0u": 9.05,
    "Y0uu": 117.48, "Nv": 0.37, "Nr": 0.47, "Nvvv": 10.25, "Nvvr": -1.46, "Nvu": -1.83,
    "Nru": -1.34, "Nd": 0.46, "Nddd": 0.58, "Nud": -1.58, "Nuud": -13.15, "Nvdd": -4.92,
    "Nvvd": -11.95, "N0": 9.02, "N0u": -51.52, "N0uu": -380.71,
}


def _identify(model, vessel, record, derivative="auto"):
    return LeastSquares().fit(build_problems(model, vessel, record, derivative))


@pytest.mark.slow
def test_clean_rk4_zigzag_recovers_all_40(model, vessel, zigzag_4000):
    result = _identify(model, vessel, zigzag_4000)
    dev = np.abs(list(deviations(result.params, vessel.coefficients).values()))
    assert np.median(dev) < 0.5
    assert dev.max() < 10.0


@pytest.mark.slow
def test_reproduces_thesis_tables_4_3_to_4_5(model, vessel, zigzag_4000):
    """Identified values agree with the thesis' LS column: within 0.5 % for the
    median and 10 % for every coefficient, and to the 3 printed significant
    digits for all 40."""
    result = _identify(model, vessel, zigzag_4000)
    dev = np.array([100 * (result.params[k] - v) / v for k, v in THESIS_LS_CLEAN.items()])
    assert np.median(np.abs(dev)) < 0.5 and np.abs(dev).max() < 10.0
    same_digits = sum(float(f"{result.params[k]:.2e}") == v for k, v in THESIS_LS_CLEAN.items())
    assert same_digits == 40


def test_forward_euler_difference_would_bias_rk4_data(model, vessel, zigzag_1500):
    """Why the thesis' forward difference is not used on RK4 data: central
    differences recover the coefficients where a one-sided difference does not."""
    rec = zigzag_1500
    central = _identify(model, vessel, rec, "central")
    dev = np.abs(list(deviations(central.params, vessel.coefficients).values()))
    assert np.median(dev) < 0.5
    shifted = rec.copy()
    for col in ("u", "v", "r"):
        # a forward difference is a central difference evaluated half a step late
        shifted[col] = 0.5 * (rec[col] + rec[col].shift(-1))
    shifted = shifted.iloc[:-1]
    biased = _identify(model, vessel, shifted, "central")
    dev_b = np.abs(list(deviations(biased.params, vessel.coefficients).values()))
    assert np.median(dev_b) > 2 * np.median(dev)


@pytest.mark.slow
def test_wind_compensated_with_true_wind_recovers_coefficients(model, vessel, windy_zigzag_4000):
    assert "wind_speed" in windy_zigzag_4000
    result = _identify(model, vessel, windy_zigzag_4000)
    dev = np.abs(list(deviations(result.params, vessel.coefficients).values()))
    assert np.median(dev) < 0.5 and dev.max() < 10.0


@pytest.mark.slow
def test_wind_speed_error_moves_deviations_as_in_thesis(model, vessel, windy_zigzag_4000):
    """Thesis Tables 4.6-4.8 (12 m/s, 45 deg, -5 %).

    Here ``V_p = V_w (1 + e)`` is the *recorded* speed (DESIGN: measured wind is
    off by 1 + e): with e = -5 % the compensation removes 95 % of the load.
    The thesis' deviations have the opposite signs to that, and the signs of
    e = +5 % (over-compensation), i.e. the thesis polluted the wind that acts
    and compensated with the nominal one. The deviations are linear in e, so
    the test checks both: our +5 % agrees with the thesis' -5 % on the
    coefficients the thesis shows clearly affected (|dev| > 5 %), and -5 %
    mirrors +5 %.
    """
    plus = _identify(model, vessel, record_wind(windy_zigzag_4000, +0.05))
    minus = _identify(model, vessel, record_wind(windy_zigzag_4000, -0.05))
    dev_plus = deviations(plus.params, vessel.coefficients)
    dev_minus = deviations(minus.params, vessel.coefficients)
    clear = [k for k, v in THESIS_LS_12MS_MINUS5.items() if abs(v) > 5.0]
    agree = [k for k in clear if np.sign(dev_plus[k]) == np.sign(THESIS_LS_12MS_MINUS5[k])]
    assert len(agree) >= 0.75 * len(clear), (len(agree), len(clear))
    mirrored = [k for k in clear if np.sign(dev_minus[k]) == -np.sign(dev_plus[k])]
    assert len(mirrored) == len(clear)
    # and the error matters: it moves the most sensitive coefficients by tens of percent
    assert abs(dev_minus["Xrr"]) > 20.0 and abs(dev_minus["N0uu"]) > 100.0
