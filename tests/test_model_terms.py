"""The term set is the single description of a model."""

import numpy as np

from studies.models import candidate_terms, monomial_name
from studies.simulate.monomials import CUBIC_BASIS, cubic_forces, dense_coefficients, scaled_forces
from studies.vessels import MARINER_COEFFICIENTS


def test_abkowitz_has_the_40_thesis_coefficients(model):
    assert len(model.names) == 40
    assert [len(model.terms_of(d)) for d in "XYN"] == [10, 15, 15]
    assert set(model.names) == set(MARINER_COEFFICIENTS)


def test_compiled_force_basis_equals_term_features(model, vessel):
    """The simulator's straight-line force code and the regression features agree."""
    rng = np.random.default_rng(3)
    primes = rng.uniform(-0.5, 0.5, size=(50, 4))
    values = vessel.coefficients
    expected = model.forces(primes, values)
    dense = dense_coefficients(model.vector(values), model.powers_array(), model.dof_array())[0]
    got = np.array([cubic_forces(dense.ravel(), *row) for row in primes])
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-15)
    assert len(CUBIC_BASIS) == 35


def test_every_monomial_of_the_compiled_basis_and_its_speed_scaling():
    """All 105 coefficients of the dense basis, each monomial written out by hand in
    monomials.py, against numpy powers; and the U^2 scaling of the dimensional form."""
    rng = np.random.default_rng(5)
    c = rng.normal(size=(3, 35))
    powers = np.array(CUBIC_BASIS)
    for _ in range(20):
        du, v, rl, delta = rng.uniform(-2.0, 2.0, size=4)
        speed = float(np.hypot(7.0 + du, v))
        primes = np.array([du / speed, v / speed, rl / speed, delta])
        monomials = np.prod(primes[None, :] ** powers, axis=1)
        expected = c @ monomials
        np.testing.assert_allclose(cubic_forces(c.ravel(), *primes), expected, rtol=1e-12, atol=1e-14)
        scaled = scaled_forces(c.ravel(), du, v, rl, delta, speed, 1.0 / speed)
        np.testing.assert_allclose(np.array(scaled) / speed**2, expected, rtol=1e-12, atol=1e-14)


def test_candidate_library_names_follow_the_pattern():
    names = {t.name for t in candidate_terms("N", 3)}
    assert {"Nrrr", "Nvvr", "N0", "N0u", "Nd", "Nddd"} <= names
    assert len(names) == 35
    assert monomial_name("Y", (0, 1, 2, 0)) == "Yvrr"
    assert monomial_name("X", (1, 2, 0, 0)) == "Xuvv"


def test_extended_and_subset_models_keep_dof_order(model):
    extra = [t for t in candidate_terms("N", 3) if t.name == "Nrrr"]
    ext = model.extended(extra, "abkowitz+Nrrr")
    assert ext.names_of("N")[-1] == "Nrrr" and len(ext.names) == 41
    sub = model.subset(["Xu", "Yv", "Nr"], "tiny")
    assert sub.names == ["Xu", "Yv", "Nr"]
