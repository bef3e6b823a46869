"""How alike two causes' signatures are (:mod:`studies.discovery.alike`): the
first canonical correlation of the spaces their columns span, a cause with
several variants taken at its variant most alike."""

from types import SimpleNamespace

import numpy as np
import pytest

from studies.discovery.alike import first_canonical_correlation, signature_alike


def _variant(cid, label=None):
    return SimpleNamespace(cause=SimpleNamespace(id=cid), label=label or cid)


def test_the_smallest_angle_between_two_signatures():
    rng = np.random.default_rng(3)
    e1, e2, e3 = np.linalg.qr(rng.normal(size=(400, 3)))[0].T
    theta = np.deg2rad(25.0)
    a = (3.0 * e1)[:, None]
    b = (np.cos(theta) * e1 + np.sin(theta) * e2)[:, None] * 0.01     # scale does not matter
    assert first_canonical_correlation(a, b) == pytest.approx(np.cos(theta), abs=1e-12)
    assert first_canonical_correlation(a, -b) == pytest.approx(np.cos(theta), abs=1e-12)   # nor the sign
    assert first_canonical_correlation(a, e3[:, None]) == pytest.approx(0.0, abs=1e-12)
    # a signature inside the span of another's two columns is exactly alike
    assert first_canonical_correlation(np.column_stack([e1, e2]), b) == pytest.approx(1.0, abs=1e-12)
    # a signature that spans nothing on these records is not compared
    assert np.isnan(first_canonical_correlation(a, np.zeros((400, 1))))


def test_every_pair_of_causes_at_their_variants_most_alike():
    rng = np.random.default_rng(4)
    e = np.linalg.qr(rng.normal(size=(300, 4)))[0].T
    variants = [_variant("rudder_offset"), _variant("missing_term", "missing_term:N0"),
                _variant("missing_term", "missing_term:Yvvv"), _variant("current"), _variant("wind_unmodelled")]
    projected = [e[0][:, None], (0.6 * e[0] + 0.8 * e[1])[:, None], e[2][:, None],
                 np.column_stack([e[2], e[3]]), np.zeros((300, 1))]
    alike = signature_alike(variants, projected)
    assert set(alike) == {"rudder_offset", "missing_term", "current"}     # the wind spans nothing
    assert alike["rudder_offset"]["missing_term"] == {"correlation": pytest.approx(0.6), "variant": "missing_term:N0",
                                                      "as": "rudder_offset"}
    assert alike["missing_term"]["rudder_offset"]["as"] == "missing_term:N0"
    # the current's plane holds Yvvv's column: the term most alike it is Yvvv, exactly
    assert alike["current"]["missing_term"]["correlation"] == pytest.approx(1.0)
    assert alike["current"]["missing_term"]["variant"] == "missing_term:Yvvv"
    assert alike["rudder_offset"]["current"]["correlation"] == pytest.approx(0.0, abs=1e-12)


def test_the_report_table_is_square_and_symmetric():
    from studies.workflows.discover_inference import alike_table

    rng = np.random.default_rng(5)
    e = np.linalg.qr(rng.normal(size=(200, 3)))[0].T
    variants = [_variant("rudder_offset"), _variant("current"), _variant("environmental_bias")]
    projected = [e[0][:, None], (0.8 * e[0] + 0.6 * e[1])[:, None], e[2][:, None]]
    table = alike_table(signature_alike(variants, projected))
    assert list(table.index) == list(table.columns) == ["rudder_offset", "current", "environmental_bias"]
    assert np.allclose(np.diag(table.to_numpy()), 1.0)
    assert np.allclose(table.to_numpy(), table.to_numpy().T)
    assert table.loc["rudder_offset", "current"] == pytest.approx(0.8)
