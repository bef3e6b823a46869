"""Roll-decay discovery on decays that no code of the project made.

The decays are integrated here by SciPy's adaptive Runge-Kutta (``solve_ivp``,
RK45 with tight tolerances), not by the project's fixed-step RK4 roll
simulator, from the one-degree-of-freedom roll equation written out in this
file::

    phi'' + b1 phi' + b2 |phi'| phi' + b3 phi'^3 + omega0^2 phi + c3 phi^3 = 0

(``phi`` [rad], ``omega0`` [rad/s], ``b1`` [1/s], ``b2`` [-], ``b3`` [s],
``c3`` [1/s^2]), released from rest at 10 and 8 deg, sampled every 0.02 s
for 40 s, with Gaussian white noise drawn by numpy (a fraction of the
release angle). One decay trains, the other is held out. The hidden term
must be named with its coefficient within 20 %.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hydra import initialize_config_module
from scipy.integrate import solve_ivp

from studies.config import compose_settings
from studies.workflows.kinds import execute_discover, prepare_discover


def _decay(path, omega0, b1, phi0_deg, noise, seed, b2=0.0, b3=0.0, c3=0.0, dt=0.02, duration=40.0):
    def rhs(_, y):
        phi, rate = y
        return [rate, -(b1 * rate + b2 * abs(rate) * rate + b3 * rate ** 3 + omega0 ** 2 * phi + c3 * phi ** 3)]

    t = np.arange(0.0, duration + dt / 2, dt)
    sol = solve_ivp(rhs, (0.0, duration), [np.deg2rad(phi0_deg), 0.0], t_eval=t, method="RK45",
                    rtol=1e-10, atol=1e-12)
    phi = sol.y[0] + noise * np.deg2rad(phi0_deg) * np.random.default_rng(seed).standard_normal(t.size)
    pd.DataFrame({"t": t, "phi": phi}).to_csv(path, index=False, float_format="%.10g")
    return str(path)


def _discover(tmp_path, train, held_out):
    overrides = ["model=roll", f"data.path=[{train}]", f"validate.path=[{held_out}]"]
    with initialize_config_module("studies.conf", version_base="1.3"):
        cfg = compose_settings("discover", overrides=overrides)
    return execute_discover(prepare_discover(cfg, tmp_path), tmp_path / "out")[0]


CASES = [
    # cause, the hidden coefficient and its value, noise, seed
    ("roll_quadratic_damping", "b2", 0.3, 0.01, 11),
    ("roll_quadratic_damping", "b2", 0.5, 0.01, 12),
    ("roll_quadratic_damping", "b2", 0.4, 0.03, 13),
    ("roll_cubic_damping", "b3", 0.8, 0.01, 14),
    ("roll_cubic_damping", "b3", 1.0, 0.01, 15),
    ("roll_nonlinear_restoring", "c3", 5.0, 0.01, 16),
    ("roll_nonlinear_restoring", "c3", -4.0, 0.01, 17),
]


@pytest.mark.slow
@pytest.mark.parametrize("cause,term,value,noise,seed", CASES,
                         ids=[f"{c[0]}-{c[2]:g}-{100 * c[3]:g}pct" for c in CASES])
def test_a_hidden_damping_term_is_named_with_its_coefficient(tmp_path, cause, term, value, noise, seed):
    train = _decay(tmp_path / "decay_10.csv", 2.5, 0.05, 10.0, noise, seed, **{term: value})
    held = _decay(tmp_path / "decay_8.csv", 2.5, 0.05, 8.0, noise, seed + 100, **{term: value})
    d = _discover(tmp_path, train, held)
    assert d["cause"] == cause, d["ranking"][:3]
    assert d["parameters"][term] == pytest.approx(value, rel=0.2), d["parameters"]
    assert d["explains_validation"], (d["baseline"], d["extended"])


@pytest.mark.slow
@pytest.mark.parametrize("seed", [21, 30, 31, 33])
def test_a_linear_decay_names_nothing(tmp_path, seed):
    """The start of a noisy decay read off its first period is off by a part of the noise;
    that error must not be taken for a nonlinear restoring (it was, in 5 of 8 seeds)."""
    train = _decay(tmp_path / "decay_10.csv", 2.5, 0.05, 10.0, 0.01, seed)
    held = _decay(tmp_path / "decay_8.csv", 2.5, 0.05, 8.0, 0.01, seed + 100)
    d = _discover(tmp_path, train, held)
    assert d["cause"] == "none", d["ranking"][:3]
