"""The gauge's thermal correction and the tip radius from a reference sphere in the length
check (Alami Mchichi (2018) §6.5.3), library and ``mtm length verify``."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.errors import InputError
from mtmetrology.samba.verify import thermal_reference

runner = CliRunner()


def test_thermal_reference_closed_form_and_the_sources_5_4_um_per_degree():
    """L_T = L20 (1 + α ΔT): 500 mm of steel (α = 10.8 µm/(m·°C)) at 21.5 °C is 8.1 µm
    longer (a positive α lengthens the gauge above 20 °C); the sensitivity to T is
    L α = 5.4 µm/°C (digest 004), and u(L_T) is the root sum of squares of the three
    contributions."""
    r = thermal_reference(500.0, 0.00025, 21.5, 0.2, 10.8e-6, 1.0e-6)
    assert r.length == pytest.approx(500.0 + 500.0 * 10.8e-6 * 1.5, abs=1e-12)
    assert r.sensitivities["temperature"] == pytest.approx(5.4e-3, rel=1e-12)
    expected = np.sqrt(
        (0.00025 * (1 + 10.8e-6 * 1.5)) ** 2 + (500.0 * 1.5 * 1e-6) ** 2 + (5.4e-3 * 0.2) ** 2
    )
    assert r.u == pytest.approx(expected, rel=1e-12)
    below = thermal_reference(500.0, 0.0, 18.0, 0.0)
    assert below.length < 500.0 and below.u == 0.0
    with pytest.raises(InputError, match="--u-temperature-c"):
        thermal_reference(500.0, 0.0, 21.0, -1.0)
    with pytest.raises(InputError, match="--temperature-c: -300 °C is outside"):
        thermal_reference(500.0, 0.0, -300.0, 0.1)
    with pytest.raises(InputError, match="--length: must be > 0 mm"):
        thermal_reference(-500.0, 0.0, 21.0, 0.1)


def _sphere_points(centre, radius, n=25, seed=0):
    rng = np.random.default_rng(seed)
    d = rng.standard_normal((n, 3))
    d[:, 2] = np.abs(d[:, 2])  # upper half, as probed
    return centre + radius * d / np.linalg.norm(d, axis=1, keepdims=True)


def _verify(tmp_path, *extra):
    args = [
        "length", "verify", str(tmp_path / "gauge.csv"), "--machine", "five-axis-wcbxfzyst",
        "--length", "300", "--u-length", "0.00025", "--json", *extra,
    ]  # fmt: skip
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)


def test_cli_thermal_correction_and_tip_sphere_shift_each_error_exactly(tmp_path):
    """Against the same readings of a 300 mm gauge (500 mm does not fit the preset's
    travels): at 22 °C every error is smaller by L α ΔT = 6.48 µm than at the calibrated
    length, and u(e) holds the 3.24 µm/°C × 0.5 °C; stylus centres on
    a Ø 19.05 mm sphere at radius 9.525 + 2.9625 mm give the tip radius 2.9625 mm and the
    same errors as --tip-radius-mm 2.9625, with u(e) including u(d_tip)."""
    sim = runner.invoke(
        app,
        [
            "length", "simulate", "--machine", "five-axis-wcbxfzyst", "--end-a",
            "-106.066017,-106.066017,40", "--end-b", "106.066017,106.066017,40", "--pairs", "5",
            "--seed", "3", "-o", str(tmp_path / "gauge.csv"),
        ],
    )  # fmt: skip
    assert sim.exit_code == 0, sim.output
    plain = _verify(tmp_path, "--tip-radius-mm", "2.9625")
    warm = _verify(
        tmp_path, "--tip-radius-mm", "2.9625", "--temperature-c", "22", "--u-temperature-c", "0.5"
    )
    shift = [
        (p["error_nominal_um"] - w["error_nominal_um"])
        for p, w in zip(plain["pairs"], warm["pairs"], strict=True)
    ]
    np.testing.assert_allclose(shift, 300.0 * 10.8e-6 * 2.0 * 1e3, rtol=1e-9)
    assert warm["thermal"]["contributions_mm"]["temperature"] == pytest.approx(1.62e-3)
    assert warm["u_gauge_um"] == pytest.approx(np.hypot(0.25 * (1 + 21.6e-6), 1.62), rel=1e-9)
    # no --params: no calibration part, every pair's u(e) is the gauge's
    assert warm["calibration_in_u"] is False
    assert {p["u_error_um"] for p in warm["pairs"]} == {warm["u_gauge_um"]}
    pts = _sphere_points(np.array([10.0, 20.0, 30.0]), 9.525 + 2.9625)
    lines = ["x,y,z", *(",".join(f"{v:.9f}" for v in p) for p in pts)]
    (tmp_path / "sphere.csv").write_text("\n".join(lines) + "\n")
    tip = _verify(
        tmp_path, "--tip-sphere", str(tmp_path / "sphere.csv"), "--sphere-diameter", "19.05",
        "--u-sphere-diameter", "0.00025",
    )  # fmt: skip
    assert tip["tip_radius_mm"] == pytest.approx(2.9625, abs=1e-9)
    np.testing.assert_allclose(
        [p["error_nominal_um"] for p in tip["pairs"]],
        [p["error_nominal_um"] for p in plain["pairs"]],
        atol=1e-5,
    )
    assert tip["u_gauge_um"] == pytest.approx(np.hypot(0.25, 0.25), rel=1e-9)


def test_cli_tip_sphere_without_diameter_exits_2(tmp_path):
    (tmp_path / "gauge.csv").write_text("pair,end,X,Y,Z,B,C\n")
    args = [
        "length", "verify", str(tmp_path / "gauge.csv"), "--machine", "five-axis-wcbxfzyst",
        "--length", "500", "--tip-sphere", str(tmp_path / "s.csv"),
    ]  # fmt: skip
    result = runner.invoke(app, args)
    assert result.exit_code == 2
    assert "--sphere-diameter" in result.output.strip().splitlines()[0]
