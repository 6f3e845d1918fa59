"""Numerical tolerances and the stability tests of the adaptive procedure (JCGM 101 7.9)."""

import numpy as np
import pytest

from mtmetrology.uncertainty.sample_statistics import Moments
from mtmetrology.uncertainty.stability import (
    NumericalTolerance,
    check_tolerance,
    numerical_tolerance,
    sequence_statistics,
    stability_checks,
)


def test_numerical_tolerance_of_jcgm101_7_9_2():
    """u = 0.0123 to 2 significant digits: 12 × 10⁻³, δ = ½ × 10⁻³ = 0.0005."""
    assert numerical_tolerance(0.0123, 2) == pytest.approx(0.0005)
    assert numerical_tolerance(0.0123, 1) == pytest.approx(0.005)
    np.testing.assert_allclose(numerical_tolerance([31.7, 1.2e-6, 0.0], 2), [0.5, 5e-8, 0.0])
    # JCGM 101 7.9.2 example: u(y) = 1.0 (2 digits) -> δ = 0.05; Sepahi Boroujeni (2021) k_p =
    # 3.55 -> 0.05.
    assert numerical_tolerance(1.0, 2) == pytest.approx(0.05)
    assert numerical_tolerance(3.55, 2) == pytest.approx(0.05)
    with pytest.raises(ValueError, match="digits"):
        numerical_tolerance(1.0, 0)


def test_check_tolerance_wraps_numbers_and_refuses_non_positive_fields():
    wrapped = check_tolerance([0.1, 0.2])
    assert isinstance(wrapped, NumericalTolerance) and wrapped.eigenvalue is None
    np.testing.assert_array_equal(wrapped.for_outputs(2), [0.1, 0.2])
    assert check_tolerance(None) is None
    with pytest.raises(ValueError, match="tolerance has 2 entries for 3"):
        wrapped.for_outputs(3)
    with pytest.raises(ValueError, match="coverage_factor"):
        check_tolerance(NumericalTolerance(0.1, coverage_factor=0.0))


def _table(per_sequence_estimates):
    """Per-sequence rows [y, u, low, high] of one output with only y varying."""
    y = np.asarray(per_sequence_estimates, dtype=float)
    return [np.array([v, 1.0, v - 2.0, v + 2.0]) for v in y]


@pytest.mark.parametrize(("criterion", "factor"), [("jcgm", 2.0 / 3.0), ("strict", 1.0)])
def test_spread_is_twice_the_standard_deviation_of_the_average_or_s_itself(criterion, factor):
    """h = 9 sequence estimates 0, 1, ..., 8: s = sqrt(7.5); "jcgm" tests 2·s/√9, "strict"
    tests s (Sepahi Boroujeni 2021, eq. 5-12); the interval ends move with y, u does not."""
    moments = Moments()
    moments.add(np.array([[0.0], [2.0]]))  # u(y) of all values = sqrt(2): δ = 0.05 (2 digits)
    checks, applied = stability_checks(_table(range(9)), moments, 1, None, 2, criterion)
    by_quantity = {c.quantity: c for c in checks}
    s = np.sqrt(7.5)
    assert by_quantity["estimate"].spread == pytest.approx(factor * s)
    assert by_quantity["interval low"].spread == pytest.approx(factor * s)
    assert by_quantity["standard uncertainty"].spread == 0.0
    assert by_quantity["standard uncertainty"].passed and not by_quantity["estimate"].passed
    np.testing.assert_allclose(applied.output, [0.05])
    assert [c.tolerance for c in checks] == [0.05] * 4


def test_joint_quantities_are_tested_for_several_outputs_with_given_tolerances():
    rng = np.random.default_rng(5)
    values = [rng.normal(size=(2_000, 2)) for _ in range(3)]
    moments = Moments()
    for v in values:
        moments.add(v)
    table = [sequence_statistics(v, 0.95) for v in values]
    given = NumericalTolerance([0.5, 0.5], eigenvalue=0.25, coverage_factor=0.125)
    checks, applied = stability_checks(table, moments, 2, given, 2, "jcgm")
    assert [c.quantity for c in checks[-2:]] == ["largest eigenvalue", "coverage factor"]
    assert [c.tolerance for c in checks[-2:]] == [0.25, 0.125]
    spread = 2.0 * np.std([t[8] for t in table], ddof=1) / np.sqrt(3)
    assert checks[-2].spread == pytest.approx(spread)
    assert applied.eigenvalue == 0.25 and len(checks) == 4 * 2 + 2


def test_sequence_statistics_are_the_sample_quantities_of_one_sequence():
    values = np.random.default_rng(2).normal(3.0, 2.0, size=(5_000, 1))
    stats = sequence_statistics(values, 0.9)
    assert stats.shape == (4,)
    assert stats[0] == pytest.approx(values.mean()) and stats[1] == pytest.approx(
        values.std(ddof=1)
    )
    inside = np.mean((values >= stats[2]) & (values <= stats[3]))
    assert inside == pytest.approx(0.9, abs=1e-3)
