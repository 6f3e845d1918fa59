"""One validation at the door: least-squares and Chebyshev fits refuse a point set alike."""

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.fitting.least_squares import fit_circle, fit_plane
from mtmetrology.fitting.minimum_zone import flatness, roundness
from mtmetrology.fitting.validation import FitError, check_points, require_spread


def _refusal(fit, points) -> str:
    with pytest.raises(FitError) as err:
        fit(points)
    return str(err.value)


@pytest.mark.parametrize(
    ("least_squares", "zone", "points", "expected"),
    [
        (fit_circle, roundness, [[0.0, 0.0], [1.0, 0.0]], "2 points are fewer than the 3 needed"),
        (
            fit_plane,
            flatness,
            [[0.0, 0, 0], [1, 0, 0], [0, np.inf, 0], [1, np.nan, 1]],
            "point 2 is not finite (NaN or inf; 2 such point(s))",
        ),
        (fit_plane, flatness, [[0.0, 0], [1, 0], [0, 1]], "points must have shape (n, 3)"),
        (fit_circle, roundness, [[0.0, 0], [1, 1], [2, 2], [3, 3]], "the 4 points are collinear"),
    ],
)
def test_least_squares_and_zone_fits_give_the_same_refusal(least_squares, zone, points, expected):
    """The message differs only in the label that names the fit."""
    ls, mz = _refusal(least_squares, points), _refusal(zone, points)
    ls_label, ls_text = ls.split(": ", 1)
    mz_label, mz_text = mz.split(": ", 1)
    assert (ls_label, mz_label) == (least_squares.__name__[4:], zone.__name__)
    assert ls_text == mz_text
    assert ls_text.startswith(expected)


def test_spread_threshold_is_relative_to_the_largest_singular_value():
    """s_rank / s_1 = 1e-10 is refused, just above it passes; FitError is an InputError."""
    require_spread("plane", np.array([1.0, 1.0001e-10, 0.0]), 3, 2, "collinear")
    with pytest.raises(InputError, match=r"^plane: the 3 points are collinear \(relative "):
        require_spread("plane", np.array([1.0, 1e-10, 0.0]), 3, 2, "collinear")
    p = check_points([[1, 2, 3]], "sphere", (3,), 1)
    assert p.dtype == float and p.shape == (1, 3)
