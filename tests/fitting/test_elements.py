"""Tests of mtmetrology.fitting.elements."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize_scalar

from mtmetrology.fitting.elements import Circle, Cone, Cylinder, Element, Line, Plane, Sphere

ELEMENTS = [
    Line([1.0, 2.0], [3.0, 4.0]),
    Line([1.0, 2.0, 3.0], [0.0, 0.0, 2.0]),
    Plane([0.0, 0.0, 5.0], [0.0, 0.0, 3.0]),
    Circle([1.0, -1.0], 4.0),
    Circle([1.0, -1.0, 2.0], 4.0, [0.0, 1.0, 1.0]),
    Sphere([1.0, 2.0, 3.0], 6.0),
    Cylinder([0.0, 0.0, 0.0], [1.0, 1.0, 0.0], 2.5),
    Cone([0.0, 0.0, -10.0], [0.0, 0.0, 1.0], 0.3),
]

_coords = st.floats(-50, 50, allow_nan=False)


def _field_names(element) -> set[str]:
    return {f.name for f in dataclasses.fields(element)}


def _radial_distance(element, p: np.ndarray) -> float:
    """Distance of p from the centre (circle, sphere) or axis (cylinder, cone)."""
    if isinstance(element, Circle | Sphere):
        v = p - element.centre
        if getattr(element, "normal", None) is not None:
            v = v - (v @ element.normal) * element.normal
        return float(np.linalg.norm(v))
    origin = element.point if isinstance(element, Cylinder) else element.apex
    v = p - origin
    return float(np.linalg.norm(v - (v @ element.direction) * element.direction))


@pytest.mark.parametrize("element", ELEMENTS, ids=lambda e: f"{type(e).__name__}{e.dim}")
def test_parameters_match_their_names_and_directions_are_unit(element):
    assert isinstance(element, Element)
    assert element.parameters.shape == (len(element.parameter_names),)
    for name in ("direction", "normal"):
        vec = getattr(element, name) if name in _field_names(element) else None
        if isinstance(vec, np.ndarray):
            assert np.linalg.norm(vec) == pytest.approx(1.0, abs=1e-15)


@pytest.mark.parametrize("element", ELEMENTS, ids=lambda e: f"{type(e).__name__}{e.dim}")
def test_elements_are_frozen_with_read_only_arrays(element):
    field = dataclasses.fields(element)[0].name
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(element, field, None)
    with pytest.raises(ValueError, match="read-only"):
        getattr(element, field)[0] = 1.0


@pytest.mark.parametrize("element", ELEMENTS, ids=lambda e: f"{type(e).__name__}{e.dim}")
@settings(max_examples=30, deadline=None)
@given(data=st.data())
def test_projection_lies_on_the_element_and_is_idempotent(element, data):
    p = np.array(data.draw(st.lists(_coords, min_size=element.dim, max_size=element.dim)))
    if isinstance(element, Cone):  # stay where the foot lies on the nappe
        p[2] = abs(p[2]) + 1.0
    round_element = isinstance(element, Circle | Sphere | Cylinder | Cone)
    if round_element and _radial_distance(element, p) < 1e-6:
        return  # on the centre or axis the nearest point is not unique
    q = element.project(p[None, :])
    assert abs(element.distances(q)[0]) < 1e-9
    np.testing.assert_allclose(element.project(q), q, atol=1e-9)
    if not (isinstance(element, Circle) and element.dim == 3):
        # The projection is the nearest point: its distance equals |d(p)| (a 3-D
        # circle's distance is the in-plane radial deviation instead, by definition).
        assert np.linalg.norm(p - q[0]) == pytest.approx(abs(element.distances(p)), abs=1e-9)


def test_distances_are_signed_positive_outside():
    assert Sphere([0, 0, 0], 2.0).distances([[3.0, 0, 0], [1.0, 0, 0]]).tolist() == [1.0, -1.0]
    assert Plane([0, 0, 0], [0, 0, 1]).distances([[5.0, 5.0, -2.0]]).tolist() == [-2.0]
    assert Circle([0, 0], 1.0).distances([[0.0, 3.0]]).tolist() == [2.0]
    assert Cylinder([0, 0, 0], [0, 0, 1], 1.0).distances([[0.0, 0.5, 9.0]]).tolist() == [-0.5]
    line = Line([0.0, 0.0], [1.0, 0.0])
    assert line.distances([[2.0, 1.0], [2.0, -1.0]]).tolist() == [1.0, -1.0]
    assert Line([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]).distances([[4.0, 0.0, -2.0]]).tolist() == [2.0]


def test_3d_circle_distance_is_the_in_plane_radial_deviation():
    circle = Circle([0.0, 0.0, 0.0], 5.0, [0.0, 0.0, 1.0])
    assert circle.distances([[6.0, 0.0, 3.0]])[0] == pytest.approx(1.0)
    np.testing.assert_allclose(circle.project([[6.0, 0.0, 3.0]]), [[5.0, 0.0, 0.0]])


@pytest.mark.parametrize("psi", [0.1, 0.6, 1.2])
def test_cone_distance_is_the_true_orthogonal_distance(psi):
    """ρ cos ψ − z sin ψ against a brute-force minimum over the cone's generatrix."""
    cone = Cone([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], psi)
    rng = np.random.default_rng(7)
    for p in rng.uniform([-20, -20, 5], [20, 20, 30], (10, 3)):
        rho = math.hypot(p[0], p[1])

        def dist(s, rho=rho, p=p):  # point at slant length s on the generatrix through p
            return math.hypot(rho - s * math.sin(psi), p[2] - s * math.cos(psi))

        best = minimize_scalar(dist, bounds=(0, 200), method="bounded", options={"xatol": 1e-12})
        assert abs(cone.distances(p[None, :])[0]) == pytest.approx(best.fun, abs=1e-8)


@pytest.mark.parametrize(
    ("call", "pattern"),
    [
        (lambda: Line([0, 0], [0, 0]), "non-zero"),
        (lambda: Line([0, 0, 0], [1, 0]), "length 3"),
        (lambda: Line([0, 0, 0, 0], [1, 0, 0, 0]), "length 2 or 3"),
        (lambda: Plane([0, 0, np.nan], [0, 0, 1]), "finite"),
        (lambda: Sphere([0, 0, 0], -1.0), "positive"),
        (lambda: Circle([0, 0, 0], 1.0), "needs a normal"),
        (lambda: Circle([0, 0], 1.0, [0, 0, 1]), "takes no normal"),
        (lambda: Cylinder([0, 0, 0], [0, 0, 1], 0.0), "positive"),
        (lambda: Cone([0, 0, 0], [0, 0, 1], 1.6), "half_angle"),
        (lambda: Cone([0, 0, 0], [0, 0, 1], 0.0), "half_angle"),
        (lambda: Line([0, 0], [1, 0, 0]).normal, "length 2"),
        (lambda: Line([0, 0, 0], [1, 0, 0]).normal, "no unique normal"),
        (lambda: Sphere([0, 0, 0], 1.0).distances([[1.0, 2.0]]), r"shape \(\.\.\., 3\)"),
    ],
)
def test_invalid_construction_is_refused_with_a_clear_message(call, pattern):
    with pytest.raises(ValueError, match=pattern):
        call()
