"""vessel=kvlcc2: particulars and the prime system (README of the shared data folder)."""

from __future__ import annotations

import numpy as np
import pytest
from omegaconf import OmegaConf

from studies.vessels import get_vessel
from studies.workflows.settings import CONF_DIR

RHO = 1025.0
L, T, DISP = 320.0, 20.8, 312_600.0


@pytest.fixture(scope="module")
def kvlcc2():
    return get_vessel("kvlcc2")


def test_main_particulars(kvlcc2):
    assert kvlcc2.name == "kvlcc2"
    assert kvlcc2.length == L
    assert kvlcc2.speed == pytest.approx(7.97)          # measured approach speed, 15.5 kn
    assert kvlcc2.speed == pytest.approx(15.5 * 1852 / 3600, abs=0.005)
    assert kvlcc2.rho == RHO
    assert kvlcc2.wind is None
    assert kvlcc2.coefficients == {}                     # nothing to simulate from: measured data only


def test_prime_masses(kvlcc2):
    # masses by 0.5 rho L^3, inertia by 0.5 rho L^5 (studies.vessels.base)
    m = RHO * DISP
    assert kvlcc2.m == pytest.approx(m / (0.5 * RHO * L**3), rel=1e-12)
    assert kvlcc2.m == pytest.approx(0.019080, abs=1e-6)
    assert kvlcc2.xg == pytest.approx(11.2 / L)
    kzz = 0.25 * L
    iz_origin = m * (kzz**2 + 11.2**2)                  # about midship (parallel axes)
    assert kvlcc2.iz == pytest.approx(iz_origin / (0.5 * RHO * L**5), rel=1e-12)


def test_added_masses_converted_from_the_mmg_system(kvlcc2):
    # MMG: masses by 0.5 rho L^2 T, inertia by 0.5 rho L^4 T -> multiply by T / L
    assert -kvlcc2.x_udot == pytest.approx(0.022 * T / L)
    assert -kvlcc2.y_vdot == pytest.approx(0.223 * T / L)
    assert -kvlcc2.n_rdot == pytest.approx(0.011 * T / L)
    assert kvlcc2.y_rdot == 0.0 and kvlcc2.n_vdot == 0.0
    # the same factor turns m' into the MMG value of this displacement
    assert kvlcc2.m * L / T == pytest.approx(DISP / (0.5 * L**2 * T))
    M = kvlcc2.mass_matrix()
    assert np.all(np.linalg.eigvals(M) > 0)
    assert M[1, 2] == pytest.approx(kvlcc2.m * kvlcc2.xg)


def test_rudder_limits(kvlcc2):
    assert np.rad2deg(kvlcc2.rudder_max) == pytest.approx(35.0)
    assert np.rad2deg(kvlcc2.rudder_rate) == pytest.approx(2.32)


def test_config_group():
    node = OmegaConf.load(CONF_DIR / "vessel" / "kvlcc2.yaml")
    assert node.name == "kvlcc2"
    assert get_vessel(str(node.name)).name == "kvlcc2"
