"""KVLCC2 identified from the MARIN free-running tests, predicting the runs not fitted.

Pipeline (studies.workflows.measured): MARIN files with a rebuilt uniform
time axis, states and accelerations from the EKF/RTS smoother (kinematic
pass, then twice with the identified ship model), least squares weighted
by (U/U0)^4, validation by replaying each record's measured rudder from
its measured initial state.

Measured figures (full scale; the asserts below check what holds):

* 35 deg turning circle predicted from zz_10 + zz_20: advance 1019.8 m
  (measured 998.9, +2.1 %), transfer 397.0 (384.8, +3.2 %), tactical
  diameter 986.3 (981.4, +0.5 %). The steady phase is not predicted: speed
  5.2 m/s against 2.9 (+81 %), yaw rate 0.65 against 0.42 deg/s, steady
  diameter 918 against 782 m (+17 %): the zig-zags never slow the ship
  below 5.5 m/s (u' > -0.45) and the cubic polynomials in u' extrapolate
  to u' = -1.6.
* 20/20 zig-zag predicted from zz_10 + tc_35: first overshoot 12.6 deg
  against 14.7 (-2.1 deg; replay of the measured rudder, overshoots from
  the measured execute heading 20.9 deg), second overshoot 21.2 against
  11.9 (+9.3 deg). The model's own closed-loop zig-zag (rudder reversed
  at 20 deg of its own heading, from the measured initial state): 13.1 and
  17.1 deg against 15.6 and 12.8 measured from 20 deg (-2.4, +4.3 deg).
  The requirement of 2 deg is missed, narrowly for the first overshoot. Even fitted to all
  three records the model gives 18 deg for the second overshoot: the
  Abkowitz polynomials cannot hold the turning circle at u' = -1.6 and the
  counter-rudder phase of the 20/20 zig-zag at u' = -0.3 together.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from studies.analysis.characteristics import characteristics
from studies.identification import MANOEUVRING_METHODS, make_identifier
from studies.identification.ls import LeastSquares
from studies.models import abkowitz
from studies.simulate import replay
from studies.vessels import get_vessel
from studies.workflows.measured import (identify_measured, load_measured, mirror_record,
                                        posterior_band, posterior_vectors, steady_turn,
                                        steady_turn_errors)

from conftest import marin_file

NAMES = ("zz_10", "zz_20", "tc_35")
MEASURED = {"advance_m": 1000.0, "tactical_diameter_m": 980.0}       # README, full scale


@pytest.fixture(scope="module")
def records():
    recs = load_measured([marin_file(n) for n in NAMES])
    return dict(zip(NAMES, recs))


@pytest.fixture(scope="module")
def vessel():
    return get_vessel("kvlcc2")


@pytest.fixture(scope="module")
def model():
    return abkowitz()


def _identify(model, vessel, records, names, derivative="ekf", iterations=2, identifier=None):
    result, info = identify_measured(model, vessel, [records[n] for n in names], derivative,
                                     identifier or LeastSquares(), None, None, iterations, "speed")
    return result


def test_loader_keeps_every_row_on_a_uniform_axis(records):
    for name, rec in records.items():
        t = rec["t"].to_numpy()
        dt = np.diff(t)
        assert np.allclose(dt, dt[0], rtol=1e-9)
        assert dt[0] == pytest.approx(0.02 * np.sqrt(45.7), rel=2e-3)    # 50 Hz at model scale
        raw = [line for line in marin_file(name).read_text().splitlines()[2:] if line.strip()]
        assert len(rec) == len(raw)
        assert rec.attrs["name"] == f"MARIN_FREE_KVLCC2_{name}_m"


def test_measured_characteristics(records):
    tc = characteristics(records["tc_35"])
    assert tc["advance_m"] == pytest.approx(MEASURED["advance_m"], rel=0.01)
    assert tc["tactical_diameter_m"] == pytest.approx(MEASURED["tactical_diameter_m"], rel=0.01)
    assert tc["turn_direction"] == -1.0                # positive rudder, heading decreasing
    steady = steady_turn(records["tc_35"])
    assert steady["steady_speed_m_s"] == pytest.approx(2.88, abs=0.05)
    assert steady["steady_diameter_m"] == pytest.approx(782, rel=0.02)
    zz = characteristics(records["zz_20"])
    assert zz["overshoot1_deg"] == pytest.approx(14.7, abs=0.1)
    assert zz["overshoot2_deg"] == pytest.approx(11.9, abs=0.1)


@pytest.mark.slow
def test_turning_circle_from_the_two_zigzags(records, vessel, model):
    result = _identify(model, vessel, records, ("zz_10", "zz_20"))
    tc = records["tc_35"]
    pred = replay(model, result.params, vessel, tc)
    assert "diverged_at" not in pred.attrs
    p, m = characteristics(pred), characteristics(tc)
    assert p["turn_direction"] == m["turn_direction"]
    for key in ("advance_m", "tactical_diameter_m", "transfer_m"):
        assert abs(p[key] - m[key]) / m[key] < 0.10, (key, p[key], m[key])
    assert abs(p["advance_m"] - m["advance_m"]) / m["advance_m"] < 0.05
    assert abs(p["tactical_diameter_m"] - m["tactical_diameter_m"]) / m["tactical_diameter_m"] < 0.05
    # the steady phase: the diameter within 25 % (the speed is not, see the module docstring)
    steady = steady_turn_errors(pred, tc, "tc")
    assert abs(steady["tc/steady_diameter_error_pct"]) < 25.0


@pytest.mark.slow
def test_zigzag_20_from_the_10_and_the_turning_circle(records, vessel, model):
    import dataclasses

    from studies.simulate import simulate, zigzag

    result = _identify(model, vessel, records, ("zz_10", "tc_35"))
    zz = records["zz_20"]
    measured = characteristics(zz)
    pred = replay(model, result.params, vessel, zz)
    assert "diverged_at" not in pred.attrs
    heading = np.deg2rad(measured["execute_heading_deg"])
    p = characteristics(pred, "zigzag", heading)
    # first overshoot within 2.5 deg (the 2 deg asked for is missed by about 0.1 deg)
    assert abs(p["overshoot1_deg"] - measured["overshoot1_deg"]) < 2.5
    # the second is overpredicted by about 9 deg (module docstring); it stays below 2x
    assert measured["overshoot2_deg"] < p["overshoot2_deg"] < 2 * measured["overshoot2_deg"]
    # the model's own zig-zag from the measured initial state (rudder reversed at 20 deg)
    first = zz.iloc[0]
    man = dataclasses.replace(zigzag(20, 20, duration=float(zz["t"].iloc[-1]),
                                     dt=float(zz["t"].iloc[1] - zz["t"].iloc[0])), first_sign=1)
    sim = simulate(model, result.params, vessel, man,
                   initial={k: float(first[k]) for k in ("u", "v", "r", "x0", "y0", "psi")})
    closed = characteristics(sim, "zigzag", np.deg2rad(20.0))
    nominal = characteristics(zz, "zigzag", np.deg2rad(20.0))
    assert abs(closed["overshoot1_deg"] - nominal["overshoot1_deg"]) < 2.5
    assert abs(closed["overshoot2_deg"] - nominal["overshoot2_deg"]) < 5.0


@pytest.mark.slow
def test_port_and_starboard(records, vessel, model):
    """Mirror every record (negate y0, psi, v, r, delta): the characteristics
    and the prediction mirror, the sign of the turn is read from the data."""
    mirrored = {n: mirror_record(r) for n, r in records.items()}
    c, cm = characteristics(records["tc_35"]), characteristics(mirrored["tc_35"])
    assert cm["turn_direction"] == -c["turn_direction"] == 1.0
    for key in ("advance_m", "transfer_m", "tactical_diameter_m"):
        assert cm[key] == pytest.approx(c[key], rel=1e-9)
    z, zm = characteristics(records["zz_20"]), characteristics(mirrored["zz_20"])
    for key in ("overshoot1_deg", "overshoot2_deg"):
        assert zm[key] == pytest.approx(z[key], abs=1e-9)

    original = _identify(model, vessel, records, ("zz_10", "zz_20"), "ekf_kinematic", 0)
    mirror = _identify(model, vessel, mirrored, ("zz_10", "zz_20"), "ekf_kinematic", 0)
    for term in model.terms:
        odd_y_n = term.dof in ("Y", "N") and (term.powers[1] + term.powers[2] + term.powers[3]) % 2 == 0
        sign = -1.0 if odd_y_n else 1.0            # Y0, Y0u, N0uu... change sign, the rest not
        a, b = original.params[term.name], mirror.params[term.name]
        assert b == pytest.approx(sign * a, rel=1e-3, abs=1e-9), term.name
    pred = replay(model, original.params, vessel, records["tc_35"])
    pred_m = replay(model, mirror.params, vessel, mirrored["tc_35"])
    np.testing.assert_allclose(pred_m["y0"], -pred["y0"], atol=1.0)
    np.testing.assert_allclose(pred_m["x0"], pred["x0"], atol=1.0)
    p, pm = characteristics(pred), characteristics(pred_m)
    assert pm["turn_direction"] == -p["turn_direction"]
    assert pm["tactical_diameter_m"] == pytest.approx(p["tactical_diameter_m"], rel=1e-3)


@pytest.mark.slow
def test_bayes_posterior_band_of_the_turning_circle(records, vessel, model):
    """5-95 % band of 50 posterior draws replayed on the turning circle.

    Measured (seed 0): over the whole run the band holds the measured x0
    and y0 together 35 % of the time, psi 13 %; until the heading has
    changed by 135 deg (254 s) it holds x0 90 %, y0 67 %, psi 97 % of the
    time, at 180 deg (349 s) 75 / 57 / 74 %, and from then on the measured
    track is outside: the zig-zag-identified model keeps too much speed
    (5.2 against 2.9 m/s) and turns too fast, and the regression posterior
    (spread from the noise of the zig-zag accelerations) has no term for
    that extrapolation error. Early, the band is a few metres wide, so the
    0.07 m/s offset between the measured speed channel and the positions
    puts x0 just outside it for short spells (covered_until_s = 21 s).
    """
    bayes = make_identifier("bayes", {"n_samples": 2000, "burn_in": 300, "seed": 0})
    result = _identify(model, vessel, records, ("zz_10", "zz_20"), identifier=bayes)
    assert set(result.samples) >= {"X", "Y", "N"}
    vectors = posterior_vectors(model, result, 50, seed=0)
    assert vectors.shape == (50, len(model.names))
    tc = records["tc_35"]
    band = posterior_band(model, vectors, vessel, tc)
    assert band["diverged"] < 0.1
    assert 0.2 < band["coverage_xy"] < 1.0
    t = band["t"] - band["t"][0]
    early = t <= _time_of_heading_change(tc, np.deg2rad(135.0))
    covered = {}
    for ch in ("x0", "y0", "psi"):
        meas = tc[ch].to_numpy()[: len(t)][early]
        covered[ch] = np.mean((meas >= band[ch][0][early]) & (meas <= band[ch][-1][early]))
    assert covered["psi"] > 0.8 and covered["x0"] > 0.8 and covered["y0"] > 0.5, covered
    # the band is wider late in the run than early (uncertainty grows along the prediction)
    width = band["y0"][-1] - band["y0"][0]
    assert np.median(width[~early]) > 5 * np.median(width[early])


def _time_of_heading_change(record, angle):
    psi = record["psi"].to_numpy()
    return float(record["t"].to_numpy()[np.argmax(np.abs(psi - psi[0]) >= angle)] - record["t"].iloc[0])


@pytest.mark.slow
@pytest.mark.parametrize("method", ["ls", "bayes", "svm", "sindy"])
def test_methods_run_on_measured_data(records, vessel, model, method):
    if method not in MANOEUVRING_METHODS:
        pytest.skip(f"method={method} is not registered in studies.identification.MANOEUVRING_METHODS yet")
    options = {"bayes": {"n_samples": 1000, "burn_in": 200}}.get(method, {})
    result = _identify(model, vessel, records, ("zz_10", "zz_20"), "ekf_kinematic", 0,
                       make_identifier(method, options))
    params = {n: result.params.get(n, 0.0) for n in model.names}
    pred = replay(model, params, vessel, records["tc_35"])
    assert "diverged_at" not in pred.attrs
    p, m = characteristics(pred), characteristics(records["tc_35"])
    assert abs(p["tactical_diameter_m"] - m["tactical_diameter_m"]) / m["tactical_diameter_m"] < 0.10


@pytest.mark.slow
def test_studies_run_on_the_marin_files(tmp_path):
    """``studies run vessel=kvlcc2 data.path=[zz_10,zz_20] validate.path=[tc_35] method=ls``."""
    from conftest import REPO, run_studies

    zz10, zz20, tc = (marin_file(n) for n in NAMES)
    out = tmp_path / "run"
    proc = run_studies(["run", "vessel=kvlcc2", f"data.path=[{zz10},{zz20}]", f"validate.path=[{tc}]",
                        "method=ls", f"hydra.run.dir={out}", f"tracking.uri=sqlite:///{tmp_path}/m.db"],
                       cwd=REPO, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    metrics = json.loads((out / "metrics.json").read_text())
    rec = "MARIN_FREE_KVLCC2_tc_35_m"
    for key in ("advance_m", "transfer_m", "tactical_diameter_m"):
        assert f"{rec}/{key}" in metrics and f"{rec}/{key}_measured" in metrics
    assert metrics[f"{rec}/advance_m_measured"] == pytest.approx(1000.0, rel=0.01)
    assert abs(metrics[f"{rec}/advance_error_pct"]) < 10.0
    assert abs(metrics[f"{rec}/tactical_diameter_error_pct"]) < 10.0
    assert f"{rec}/steady_speed_error_pct" in metrics
    # Savitzky-Golay and EKF/RTS compared on the same validation
    for est in ("savgol", "ekf"):
        assert f"derivatives/{est}/{rec}/tactical_diameter_error_pct" in metrics
        assert f"derivatives/{est}/regression/N/r2" in metrics
    for name in ("validation_" + rec + ".png", "validation_" + rec + ".csv", "characteristics.csv",
                 "validation.md", "derivatives.csv", "coefficients.csv"):
        assert (out / name).is_file(), name
