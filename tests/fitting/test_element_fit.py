"""Tests for mtmetrology.fitting.element_fit (one ``mtm fit`` request as a library call)."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.fitting.element_fit import fit_points_file

DELTA = 0.002  # mm


def _write(tmp_path, points, name="points.csv"):
    path = tmp_path / name
    np.savetxt(path, points, delimiter=",", header="x,y,z", comments="", fmt="%.12f")
    return path


def _cylinder_points():
    """Two sections of 8 points alternating between radii 10 and 10 + DELTA mm about z."""
    t = np.arange(8) * np.pi / 4
    r = 10.0 + DELTA * (np.arange(8) % 2)
    ring = np.column_stack([r * np.cos(t), r * np.sin(t)])
    return np.column_stack([np.tile(ring, (2, 1)), np.repeat([0.0, 10.0], 8)])


def _sphere_points(centre=(5.0, -2.0, 30.0), radius=12.0, n=40):
    u = np.random.default_rng(4).normal(size=(n, 3))
    return np.asarray(centre) + radius * u / np.linalg.norm(u, axis=1, keepdims=True)


@pytest.mark.parametrize(
    ("tip", "inside", "radius"), [(None, False, 12.0), (1.5, False, 10.5), (1.5, True, 13.5)]
)
def test_least_squares_sphere_and_its_tip_offset(tmp_path, tip, inside, radius):
    """R − r_tip for a ball, R + r_tip for a cavity; the centre and residuals do not move."""
    fit = fit_points_file(
        "sphere", _write(tmp_path, _sphere_points()), tip_radius=tip, inside=inside
    )
    assert fit.element.radius == pytest.approx(radius, abs=1e-9)
    np.testing.assert_allclose(fit.element.centre, [5.0, -2.0, 30.0], atol=1e-9)
    assert np.max(np.abs(fit.residuals)) < 1e-9
    assert fit.extra["success"] is True
    assert ("tip_radius" in fit.extra) == (tip is not None)


def test_minimum_zone_cylinder_document_with_tip_and_contact_lines(tmp_path):
    fit = fit_points_file(
        "cylinder",
        _write(tmp_path, _cylinder_points()),
        method="minimum-zone",
        tip_radius=1.0,
        inside=True,
    )
    doc = fit.to_dict()
    assert (doc["kind"], doc["element"], doc["method"]) == (
        "fit-result",
        "cylinder",
        "minimum-zone",
    )
    assert doc["form_error"]["unit"] == "µm"
    assert doc["form_error"]["value"] == pytest.approx(1e3 * DELTA, abs=1e-6)
    # the zone's radii move with the radius: 10 + 1 and 10 + DELTA + 1 mm
    assert (doc["zone"]["low"], doc["zone"]["high"]) == pytest.approx((11.0, 11.0 + DELTA))
    assert fit.element.radius == pytest.approx(11.0 + DELTA / 2)
    # every point touches the zone; file lines start at 2 (line 1 is the header)
    assert doc["contact_lines"] == list(range(2, 18))
    assert doc["tip_radius"] == {"value": 1.0, "unit": "mm", "inside": True}


def test_a_profile_of_constant_z_is_a_line_in_that_plane(tmp_path):
    x = np.linspace(0.0, 100.0, 11)
    y = 3.0 + 0.5 * x + 0.001 * (-1.0) ** np.arange(11)
    points = np.column_stack([x, y, np.full(11, 7.0)])
    ls = fit_points_file("line", _write(tmp_path, points))
    assert ls.element.point[2] == 7.0 and ls.element.direction[2] == 0.0
    zone = fit_points_file("line", _write(tmp_path, points), method="minimum-zone")
    # the zone between two parallel lines of slope 0.5, 2 µm apart vertically
    assert zone.form_error == pytest.approx(2 * 0.001 / np.sqrt(1.25), abs=1e-9)


def test_a_plane_is_not_offset_by_the_tip_and_says_so(tmp_path):
    xy = np.random.default_rng(2).uniform(-20, 20, size=(12, 2))
    points = np.column_stack([xy, 0.1 * xy[:, 0] + 4.0])
    fit = fit_points_file("plane", _write(tmp_path, points), tip_radius=2.0)
    assert fit.extra["notes"] == [
        "a plane has no material side in x, y, z: its position is that of the stylus "
        "centre (not offset by the tip radius)"
    ]
    assert abs(np.dot(fit.element.point - [0.0, 0.0, 4.0], fit.element.normal)) < 1e-9


def test_fit_is_invariant_under_permutation_of_rows(tmp_path):
    points = _sphere_points()
    a = fit_points_file("sphere", _write(tmp_path, points, "a.csv"), method="minimum-zone")
    b = fit_points_file("sphere", _write(tmp_path, points[::-1], "b.csv"), method="minimum-zone")
    assert b.form_error == pytest.approx(a.form_error, abs=1e-12)
    np.testing.assert_allclose(b.element.centre, a.element.centre, atol=1e-9)


@pytest.mark.parametrize(
    ("element", "kwargs", "message"),
    [
        (
            "plane",
            {"method": "inscribed"},
            "--method inscribed is not available for a plane: minimum-zone, inscribed and "
            "circumscribed apply to circle, sphere and cylinder, minimum-zone also to line "
            "and plane",
        ),
        (
            "cylinder",
            {"tip_radius": -1.0},
            "--tip-radius must be a finite length >= 0 mm, got -1.0",
        ),
        ("torus", {}, "unknown element 'torus' or method 'ls'"),
    ],
)
def test_requests_that_cannot_be_served_are_refused(tmp_path, element, kwargs, message):
    path = _write(tmp_path, _cylinder_points())
    with pytest.raises(InputError) as info:
        fit_points_file(element, path, **kwargs)
    assert str(info.value) == message


def test_file_errors_name_the_file(tmp_path):
    path = _write(tmp_path, _cylinder_points()[:2], "two.csv")
    with pytest.raises(InputError) as info:
        fit_points_file("sphere", path)
    assert str(info.value) == (
        f"{path}: sphere: 2 points are fewer than the 4 needed to determine the element"
    )
    with pytest.raises(InputError) as info:
        fit_points_file("sphere", tmp_path / "missing.csv")
    assert str(info.value) == f"{tmp_path / 'missing.csv'}: file not found"
