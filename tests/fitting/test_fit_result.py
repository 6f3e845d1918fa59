"""Refusals of elements and fits that name the element and its part, and the stored form
of a cone (the FitResult record itself: test_odr.py)."""

import numpy as np
import pytest

from mtmetrology.fitting.elements import Cone, Line, Plane
from mtmetrology.fitting.least_squares import fit_cone, fit_sphere
from mtmetrology.fitting.validation import FitError


@pytest.mark.parametrize(
    ("build", "message"),
    [
        (
            lambda: Cone(apex=[1.0, 2.0], direction=[0.0, 0.0, 1.0], half_angle=0.5),
            "cone apex must be a vector of length 3, got shape (2,)",
        ),
        (
            lambda: Line(point=[0.0, 0.0, 0.0], direction=[0.0, 0.0, 0.0]),
            "line direction must be a non-zero vector",
        ),
        (
            lambda: Plane(point=[0.0, 0.0], normal=[0.0, 0.0, 1.0]),
            "plane point must be a vector of length 3, got shape (2,)",
        ),
        (
            lambda: fit_cone(
                [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [2, 1, 0], [3, 3, 0], [5, 1, 0]]
            ),
            "cone: the 7 points are coplanar (relative singular value 0.0e+00 of the centred "
            "points); a cone needs points off one plane",
        ),
    ],
)
def test_element_refusals_name_the_element_and_its_part(build, message):
    with pytest.raises(ValueError) as err:
        build()
    assert str(err.value) == message


def test_a_cone_stores_its_apex_as_a_float_array():
    cone = Cone(apex=[1, 2, 3], direction=[0, 0, 2], half_angle=0.5)
    assert isinstance(cone.apex, np.ndarray) and cone.apex.dtype == float
    np.testing.assert_array_equal(cone.parameters, [1.0, 2.0, 3.0, 0.0, 0.0, 1.0, 0.5])


@pytest.mark.parametrize(
    ("radius", "message"),
    [
        (
            10.0,
            "sphere (known radius): the 4 points are coplanar (relative singular value "
            "0.0e+00 of the centred points); the mirror-image centres cannot be told apart",
        ),
        (
            None,
            "sphere: the 4 points are coplanar (relative singular value 0.0e+00 of the "
            "centred points); a sphere needs points off one plane (give the radius only if "
            "they are not)",
        ),
        (-1.0, "sphere (known radius): radius must be a positive finite number, got -1.0"),
    ],
)
def test_sphere_refusals_say_which_fit(radius, message):
    ring = [[10.0, 0.0, 0.0], [0.0, 10.0, 0.0], [-10.0, 0.0, 0.0], [0.0, -10.0, 0.0]]
    with pytest.raises(FitError) as err:
        fit_sphere(ring, radius=radius)
    assert str(err.value) == message
