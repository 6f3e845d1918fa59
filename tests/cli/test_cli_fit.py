"""Tests of ``mtm fit`` (mtmetrology.cli.fit) through typer's CliRunner."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.fitting.elements import Cone
from mtmetrology.fitting.least_squares import fit_circle, fit_sphere
from mtmetrology.fitting.minimum_zone import (
    cylindricity,
    inscribed_circle,
    sphericity,
    straightness,
)

runner = CliRunner()

FORM = 0.002  # mm, simulated form error of the test features


def _write(path, points, header="x,y,z"):
    lines = [header] + [",".join(f"{v:.12f}" for v in p) for p in points]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _unit_vectors(rng, n):
    u = rng.normal(size=(n, 3))
    return u / np.linalg.norm(u, axis=1, keepdims=True)


def _features(rng):
    """Point sets (n, 3) of each element with a small form error, in general positions."""
    n = 24
    noise = FORM * rng.uniform(-0.5, 0.5, n)
    t = np.linspace(-40.0, 40.0, n)
    angle = rng.uniform(0.0, 2.0 * np.pi, n)
    cone_z = rng.uniform(10.0, 30.0, n)
    psi = np.radians(30.0)
    cone_r = cone_z * np.tan(psi) + noise / np.cos(psi)
    return {
        "line": np.c_[t, 0.5 * t + noise, 0.2 * t + noise[::-1]] + 10.0,
        "plane": np.c_[rng.uniform(-30, 30, (n, 2)), noise] + [1.0, 2.0, 3.0],
        "circle": np.c_[(12.0 + noise) * np.cos(angle), (12.0 + noise) * np.sin(angle), 0.0 * t],
        "sphere": (9.5 + noise)[:, None] * _unit_vectors(rng, n) + [5.0, -5.0, 20.0],
        "cylinder": np.c_[(8.0 + noise) * np.cos(angle), (8.0 + noise) * np.sin(angle), t],
        "cone": np.c_[cone_r * np.cos(angle), cone_r * np.sin(angle), cone_z],
    }


@pytest.fixture(scope="module")
def csv_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fit")
    rng = np.random.default_rng(42)
    return {name: _write(folder / f"{name}.csv", p) for name, p in _features(rng).items()}


def _run_json(*args):
    result = runner.invoke(app, ["fit", *map(str, args), "--json"])
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)


COMBINATIONS = [
    (element, "ls") for element in ("line", "plane", "circle", "sphere", "cylinder", "cone")
] + [
    ("line", "minimum-zone"),
    ("plane", "minimum-zone"),
    *[
        (element, method)
        for element in ("circle", "sphere", "cylinder")
        for method in ("minimum-zone", "inscribed", "circumscribed")
    ],
]


@pytest.mark.parametrize(("element", "method"), COMBINATIONS)
def test_every_element_and_method_gives_a_complete_json_document(csv_files, element, method):
    doc = _run_json(element, csv_files[element], "--method", method)
    assert doc["kind"] == "fit-result"
    assert doc["version"] == 1
    assert (doc["element"], doc["method"]) == (element, method)
    assert all({"name", "value", "unit"} <= set(p) for p in doc["parameters"])
    assert doc["residuals"]["n"] == 24
    res = doc["residuals"]
    assert res["unit"] == "µm"
    assert res["min"] <= res["max"]
    assert 0.0 <= res["rms"] <= max(abs(res["min"]), abs(res["max"]))
    assert doc["form_error"]["unit"] == "µm"
    # Simulated form error 2 µm: every criterion reports a form error of that order.
    assert 0.5 <= doc["form_error"]["value"] <= 10.0
    assert doc["success"] is True
    if method == "ls":
        assert doc["status"] == (3 if element in ("line", "plane") else doc["status"])
        assert doc["status"] in (1, 2, 3)
    if method == "minimum-zone":
        assert doc["form_error"]["value"] <= doc["least_squares_form_error"]["value"] + 1e-9
    if method != "ls":
        assert len(doc["contact_lines"]) >= 2


def test_json_values_are_those_of_the_library_in_customary_units(csv_files):
    points = np.loadtxt(csv_files["sphere"], delimiter=",", skiprows=1)
    doc = _run_json("sphere", csv_files["sphere"], "--method", "minimum-zone")
    expected = sphericity(points)
    assert doc["form_error"]["value"] == pytest.approx(expected.form_error * 1e3, rel=1e-12)
    params = {p["name"]: (p["value"], p["unit"]) for p in doc["parameters"]}
    assert params["r"] == (pytest.approx(expected.element.radius, rel=1e-14), "mm")
    ls = _run_json("sphere", csv_files["sphere"])
    assert ls["form_error"]["value"] == pytest.approx(fit_sphere(points).form_error * 1e3)


def test_cone_half_angle_is_reported_in_degrees(csv_files):
    doc = _run_json("cone", csv_files["cone"])
    params = {p["name"]: (p["value"], p["unit"]) for p in doc["parameters"]}
    assert params["half_angle"][1] == "deg"
    assert params["half_angle"][0] == pytest.approx(30.0, abs=0.05)


def test_line_with_constant_z_is_a_profile_in_that_plane(tmp_path):
    rng = np.random.default_rng(1)
    xy = np.c_[np.linspace(0, 60, 15), 0.01 * rng.normal(size=15)]
    path = _write(tmp_path / "profile.csv", np.c_[xy, np.full(15, 7.5)])
    doc = _run_json("line", path, "--method", "minimum-zone")
    assert doc["form_error"]["value"] == pytest.approx(straightness(xy).form_error * 1e3)
    params = {p["name"]: p["value"] for p in doc["parameters"]}
    assert params["z0"] == 7.5 and params["az"] == 0.0


def test_human_output_names_parameters_residuals_and_form_error(csv_files):
    result = runner.invoke(
        app, ["fit", "circle", str(csv_files["circle"]), "--method", "inscribed"]
    )
    assert result.exit_code == 0, result.output
    for text in ("x0", "r", "residuals: n = 24", "roundness (inscribed)", "contact points"):
        assert text in result.stdout
    # the radius to the second significant digit of the residual rms (no u is stated)
    from mtmetrology.formatting import format_fitted

    points = np.loadtxt(csv_files["circle"], delimiter=",", skiprows=1)
    rms = _run_json("circle", csv_files["circle"], "--method", "inscribed")["residuals"]["rms"]
    radius = format_fitted(inscribed_circle(points).element.radius, "mm", rms)
    cells = [[c.strip() for c in line.split("│")][1:3] for line in result.stdout.splitlines()]
    assert ["r", radius] in cells


# --------------------------------------------------------------------------------------
# probe-tip compensation


def test_tip_compensation_recovers_the_surface_of_a_ball_a_bore_and_a_shaft(tmp_path):
    """Tip centres lie r_tip off the surface along its normal: outward for a ball and a
    shaft, inward (towards the axis) for a bore; the compensated radius is the surface's."""
    rng = np.random.default_rng(2)
    r_tip = 1.5
    u = _unit_vectors(rng, 20)
    ball = _write(tmp_path / "ball.csv", (12.7 / 2 + r_tip) * u)
    doc = _run_json("sphere", ball, "--tip-radius", r_tip)
    radius = {p["name"]: p["value"] for p in doc["parameters"]}["r"]
    assert radius == pytest.approx(12.7 / 2, abs=1e-9)
    assert doc["tip_radius"] == {"value": r_tip, "unit": "mm", "inside": False}

    angle = rng.uniform(0, 2 * np.pi, 20)
    ring = np.c_[np.cos(angle), np.sin(angle), np.zeros(20)]
    bore = _write(tmp_path / "bore.csv", (25.0 - r_tip) * ring)
    for method in ("ls", "minimum-zone", "inscribed", "circumscribed"):
        doc = _run_json("circle", bore, "--method", method, "--tip-radius", r_tip, "--inside")
        assert {p["name"]: p["value"] for p in doc["parameters"]}["r"] == pytest.approx(
            25.0, abs=1e-9
        )
    shaft = np.c_[(8.0 + r_tip) * ring[:, :2], rng.uniform(0, 30, 20)]
    doc = _run_json("cylinder", _write(tmp_path / "shaft.csv", shaft), "--tip-radius", r_tip)
    assert {p["name"]: p["value"] for p in doc["parameters"]}["r"] == pytest.approx(8.0, abs=1e-9)


def test_tip_compensation_of_a_cone_moves_its_apex_along_the_axis(tmp_path):
    """A male cone probed with tip centres offset r_tip along the outward normal: the
    compensated cone has the surface's apex (shift r_tip / sin(psi)) and half-angle."""
    rng = np.random.default_rng(3)
    r_tip, psi = 2.0, np.radians(20.0)
    surface = Cone([1.0, 2.0, 3.0], [0.0, 0.0, 1.0], psi)
    z = rng.uniform(10, 40, 30)
    angle = rng.uniform(0, 2 * np.pi, 30)
    radial = np.c_[np.cos(angle), np.sin(angle), np.zeros(30)]
    on_surface = surface.apex + radial * (z * np.tan(psi))[:, None] + np.c_[0 * z, 0 * z, z]
    normal = np.cos(psi) * radial - np.sin(psi) * surface.direction
    path = _write(tmp_path / "cone.csv", on_surface + r_tip * normal)
    doc = _run_json("cone", path, "--tip-radius", r_tip)
    params = {p["name"]: p["value"] for p in doc["parameters"]}
    np.testing.assert_allclose([params["x0"], params["y0"], params["z0"]], surface.apex, atol=1e-8)
    assert np.radians(params["half_angle"]) == pytest.approx(psi, abs=1e-10)


def test_tip_radius_on_a_plane_leaves_the_position_and_says_why(csv_files):
    doc = _run_json("plane", csv_files["plane"], "--tip-radius", 1.0)
    plain = _run_json("plane", csv_files["plane"])
    assert doc["parameters"] == plain["parameters"]
    assert "no material side" in doc["notes"][0]


# --------------------------------------------------------------------------------------
# bad input: exit code 2 and a message, no traceback


def _fails(args, *texts):
    result = runner.invoke(app, ["fit", *map(str, args)])
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    for text in texts:
        assert text in result.output
    return result


def test_missing_column_names_the_file_and_the_column(tmp_path):
    path = _write(tmp_path / "no_z.csv", np.ones((5, 3)), header="x,y,w")
    _fails(["sphere", path], "error:", str(path), "missing column 'z'")


def test_nan_cell_names_the_file_line_and_column(tmp_path):
    path = tmp_path / "nan.csv"
    path.write_text("x,y,z\n0,0,0\n1,nan,0\n0,1,0\n", encoding="utf-8")
    _fails(["plane", path], str(path), "line 3", "column 'y'")


def test_missing_file_and_unknown_element_are_refused(tmp_path):
    _fails(["circle", tmp_path / "absent.csv"], "file not found")
    _fails(["torus", tmp_path / "absent.csv"])


def test_degenerate_points_give_the_fitting_error(tmp_path):
    line = np.c_[np.arange(6.0), np.arange(6.0), np.zeros(6)]
    result = _fails(["circle", _write(tmp_path / "collinear.csv", line)], "error:")
    assert "collinear" in result.output
    _fails(["sphere", _write(tmp_path / "three.csv", np.eye(3))], "error:")


@pytest.mark.parametrize(
    ("args", "text"),
    [
        (["cone", "--method", "inscribed"], "not available for a cone"),
        (["plane", "--method", "circumscribed"], "not available for a plane"),
        (["sphere", "--tip-radius", "-1"], "--tip-radius must be"),
        (["sphere", "--tip-radius", "50"], "not smaller than the fitted radius"),
    ],
)
def test_impossible_requests_are_usage_errors(csv_files, args, text):
    element, *options = args
    _fails([element, csv_files[element], *options], text)


def test_zone_results_agree_with_the_library_for_cylinders_and_circles(csv_files):
    cylinder = np.loadtxt(csv_files["cylinder"], delimiter=",", skiprows=1)
    doc = _run_json("cylinder", csv_files["cylinder"], "--method", "minimum-zone")
    assert doc["form_error"]["value"] == pytest.approx(cylindricity(cylinder).form_error * 1e3)
    circle = np.loadtxt(csv_files["circle"], delimiter=",", skiprows=1)
    ls = _run_json("circle", csv_files["circle"])
    assert ls["form_error"]["value"] == pytest.approx(fit_circle(circle).form_error * 1e3)


def test_a_least_squares_fit_does_without_the_zone_machinery(tmp_path):
    """``mtm fit sphere`` (least squares) loads neither scipy.optimize nor scipy.spatial
    (the Chebyshev fits' linear programs and hulls, cylinders' neighbour search): a smaller
    process on millions of points.  Checked in a fresh interpreter after a real run."""
    import subprocess
    import sys

    rng = np.random.default_rng(4)
    path = _write(tmp_path / "ball.csv", 12.5 * _unit_vectors(rng, 40))
    code = (
        "import sys\n"
        "from mtmetrology.__main__ import main\n"
        "try:\n"
        f"    main(['fit', 'sphere', {str(path)!r}, '--json'])\n"
        "except SystemExit as stop:\n"
        "    assert stop.code == 0, stop.code\n"
        "print(sorted(m for m in ('scipy.optimize', 'scipy.spatial') if m in sys.modules))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert json.loads(done.stdout[: done.stdout.rindex("}") + 1])["element"] == "sphere"
    assert done.stdout.strip().splitlines()[-1] == "[]"


@pytest.mark.parametrize("method", ["ls", "minimum-zone"])
def test_an_x_y_profile_is_a_line_in_the_plane_z_0(tmp_path, method):
    """Points (±2, +h), (±1, −h): by symmetry the fitted line is y = 0 (least squares and
    minimum zone alike), the residuals ±h and the 2-D straightness exactly 2h; the same
    points with z = 0 give the same document but for the note."""
    h = 0.001
    xy = np.array([[-2.0, h], [-1.0, -h], [1.0, -h], [2.0, h]])
    doc = _run_json("line", _write(tmp_path / "xy.csv", xy, header="x,y"), "--method", method)
    assert doc["form_error"]["value"] == pytest.approx(2 * h * 1e3, abs=1e-9)
    params = {p["name"]: p["value"] for p in doc["parameters"]}
    assert abs(params["ax"]) == pytest.approx(1.0, abs=1e-12)
    assert (params["y0"], params["z0"], params["ay"], params["az"]) == pytest.approx(
        (0.0, 0.0, 0.0, 0.0), abs=1e-12
    )
    assert doc["notes"] == ["x, y profile: fitted in the plane z = 0 (2-D straightness)"]
    flat = _run_json(
        "line", _write(tmp_path / "xyz.csv", np.c_[xy, np.zeros(4)]), "--method", method
    )
    assert "notes" not in flat
    assert flat["parameters"] == doc["parameters"]
    assert flat["form_error"] == doc["form_error"]


def test_an_x_y_circle_profile_has_its_roundness(tmp_path):
    """Eight points alternately at radius R + d and R − d: centre 0, radius R, least-squares
    roundness 2d, in the plane z = 0."""
    radius, d = 10.0, 0.002
    angles = np.arange(8) * np.pi / 4
    r = radius + d * np.array([1, -1] * 4)
    doc = _run_json(
        "circle",
        _write(tmp_path / "ring.csv", np.c_[r * np.cos(angles), r * np.sin(angles)], header="x,y"),
    )
    params = {p["name"]: p["value"] for p in doc["parameters"]}
    assert params["r"] == pytest.approx(radius, abs=1e-9)
    assert (params["x0"], params["y0"], params["z0"]) == pytest.approx((0, 0, 0), abs=1e-9)
    assert doc["form_error"]["value"] == pytest.approx(2 * d * 1e3, abs=1e-6)
    assert doc["notes"] == ["x, y profile: fitted in the plane z = 0 (2-D roundness)"]


def test_an_x_y_file_is_no_plane(tmp_path):
    path = _write(tmp_path / "xy.csv", np.ones((5, 2)), header="x,y")
    _fails(["plane", path], "error:", str(path), "missing column 'z'")
