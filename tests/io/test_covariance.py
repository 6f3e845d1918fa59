"""The one symmetry rule of every covariance reader (mtmetrology.io.covariance, issue 30):
symmetric to 1e-9 of the matrix's largest entry, then symmetrised; beyond, refused."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.io.covariance import SYMMETRY_TOLERANCE, symmetric, symmetric_covariance
from mtmetrology.io.files import InputFileError


def tracker_like_covariance(seed: int = 3) -> np.ndarray:
    """A 9×9 covariance in customary units (µm², µm·µrad, ...): diagonal up to ~0.3, some
    off-diagonal entries near 1e-7, the mirror entries of those off by 3e-16 (the tracker
    calibration of issue 30). Returns the asymmetric matrix as a file would hold it."""
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(9, 9))
    c = a @ a.T / 30.0
    c[0, 5] = c[5, 0] = 1.234e-7
    c[2, 7] = c[7, 2] = -0.987e-7
    c[5, 0] += 3e-16
    c[7, 2] -= 3e-16
    return c


def test_the_issue_case_is_accepted_and_comes_back_exactly_symmetric():
    c = tracker_like_covariance()
    # the old elementwise rule refused it; the scale-relative rule accepts it
    assert not np.allclose(c, c.T, rtol=1e-9, atol=0)
    out = symmetric_covariance(c, "t.json: covariance.matrix")
    np.testing.assert_array_equal(out, out.T)
    assert out[0, 5] == pytest.approx(1.234e-7 + 1.5e-16, rel=1e-12)
    np.testing.assert_array_equal(out, (c + c.T) / 2)


def test_the_tolerance_is_relative_to_the_largest_entry():
    c = np.array([[4.0, 1.0], [1.0, 1.0]])
    at = c.copy()
    at[1, 0] += SYMMETRY_TOLERANCE * 4.0 * 0.999
    symmetric_covariance(at, "f")  # just inside: accepted
    above = c.copy()
    above[1, 0] += SYMMETRY_TOLERANCE * 4.0 * 1.01
    with pytest.raises(InputFileError, match=r"^f: covariance matrix is not symmetric"):
        symmetric_covariance(above, "f")


def test_a_relative_asymmetry_of_1e_6_is_refused_naming_the_file_and_field():
    c = tracker_like_covariance()
    c[3, 1] += 1e-6 * np.abs(c).max()
    with pytest.raises(InputFileError) as err:
        symmetric_covariance(c, "cal.json: covariance.matrix")
    assert str(err.value).startswith("cal.json: covariance.matrix: covariance matrix is not")


def test_a_stack_is_checked_matrix_by_matrix():
    """A small matrix in a stack with a large one is judged on its own scale."""
    stack = np.array([np.eye(2) * 1e6, [[1e-6, 1e-7], [1.1e-7, 1e-6]]])
    with pytest.raises(InputFileError, match="not symmetric"):
        symmetric_covariance(stack, "v")
    stack[1, 1, 0] = 1e-7 * (1 + 1e-12)
    out = symmetric_covariance(stack, "v")
    np.testing.assert_array_equal(out, np.swapaxes(out, -1, -2))


def test_not_square_is_refused_and_symmetric_is_exact():
    with pytest.raises(InputFileError, match=r"^m: a covariance must be a square matrix"):
        symmetric_covariance(np.zeros((2, 3)), "m")
    c = np.random.default_rng(0).normal(size=(7, 7))
    s = symmetric(c)
    np.testing.assert_array_equal(s, s.T)
