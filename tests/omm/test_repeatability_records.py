"""Tests for mtmetrology.omm.repeatability_records (probing records of the repeatability
and hysteresis tests, and their workflows)."""

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.omm.repeatability_records import (
    fit_repeatability_file,
    hysteresis_from_file,
    read_hysteresis_records,
    read_repeatability_records,
)

HEADER = "target,phi,theta,B,C,X_T,Y_T,Z_T,i,j,k,X,Y,Z,time"


def _ring(tmp_path, rows, header="psi,condition,r"):
    path = tmp_path / "ring.csv"
    path.write_text(header + "\n" + "\n".join(rows) + "\n", encoding="utf-8")
    return path


def _records(tmp_path, n_targets=45, flat_x_target=None):
    """Six touches of each target; the approach (i, j, k) is −n̂ scaled by 2 (not unit)."""
    rng = np.random.default_rng(6)
    rows = [HEADER]
    for t in range(n_targets):
        phi, theta = np.radians(rng.uniform(0, 90)), np.radians(rng.uniform(0, 360))
        b, c = rng.uniform(-90, 90), rng.uniform(-180, 180)
        target = rng.uniform(-200, 200, 3)
        n = 2.0 * np.array([np.sin(phi) * np.sin(theta), np.sin(phi) * np.cos(theta), np.cos(phi)])
        for s in range(6):
            p = target + rng.normal(0, 0.001, 3)
            if t == flat_x_target:
                p[0] = target[0]
            rows.append(
                f"T{t},{np.degrees(phi)},{np.degrees(theta)},{b},{c},{target[0]},{target[1]},"
                f"{target[2]},{-n[0]},{-n[1]},{-n[2]},{p[0]:.6f},{p[1]:.6f},{p[2]:.6f},{s}"
            )
    path = tmp_path / "records.csv"
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def test_radial_projection_from_x_and_y(tmp_path):
    """r = X cos ψ + Y sin ψ; '+' is the affected side of the axis test."""
    rows = ["0,+,25.0,0.3", "90,-,0.2,24.9", "180,+,-25.1,0.0", "270,-,0.0,-24.8"]
    psi, r, affected, kind = read_hysteresis_records(_ring(tmp_path, rows, "psi,condition,X,Y"))
    np.testing.assert_allclose(psi, np.radians([0.0, 90.0, 180.0, 270.0]))
    np.testing.assert_allclose(r, [25.0, 24.9, 25.1, 24.8], atol=1e-12)
    np.testing.assert_array_equal(affected, [True, False, True, False])
    assert kind == "axis"


def test_hysteresis_of_constructed_records_is_the_difference_of_the_means(tmp_path):
    """At each ψ: direct touches 25 ± 1 µm, hysteresis touches 25.002 ± 1 µm: H = 2 µm."""
    rows = [
        f"{psi},{condition},{25.0 + offset + sign * 0.001}"
        for psi in (0, 90, 180, 270)
        for condition, offset in (("direct", 0.0), ("hysteresis", 0.002))
        for sign in (-1, 1)
    ]
    path = _ring(tmp_path, rows)
    result = hysteresis_from_file(path, p=0.9)
    assert result.kind == "probing" and result.source == str(path)
    np.testing.assert_allclose(result.hysteresis, 0.002, atol=1e-12)
    assert result.mean == pytest.approx(0.002, abs=1e-12)
    np.testing.assert_array_equal(result.n_affected, 2)


@pytest.mark.parametrize(
    ("header", "rows", "message"),
    [
        (
            "psi,condition,r",
            ["0,direct,25", "0,up,25"],
            "{path}, line 3: column 'condition' holds 'up'; use direct and hysteresis "
            "(probing test) or + and - (axis test)",
        ),
        (
            "psi,condition,r",
            ["0,direct,25", "0,+,25"],
            "{path}: column 'condition' mixes the probing test (direct, hysteresis) and the "
            "axis test (+, -); give each test its own file",
        ),
        (
            "psi,condition,r,X,Y",
            ["0,direct,25,25,0"],
            "{path}: give either the radial projection in column 'r' or the readings in "
            "columns 'X' and 'Y' (relative to the ring centre), not both",
        ),
    ],
)
def test_bad_hysteresis_records_are_refused(tmp_path, header, rows, message):
    path = _ring(tmp_path, rows, header)
    with pytest.raises(InputError) as info:
        read_hysteresis_records(path)
    assert str(info.value) == message.format(path=path)


def test_repeatability_records_give_the_unit_surface_normal(tmp_path):
    path = _records(tmp_path, n_targets=2)
    data = read_repeatability_records(path)
    raw = np.loadtxt(path, delimiter=",", skiprows=1, usecols=(8, 9, 10))
    np.testing.assert_allclose(
        data["normal"], -raw / np.linalg.norm(raw, axis=1)[:, None], rtol=1e-15
    )
    assert list(data["target"]) == ["T0"] * 6 + ["T1"] * 6
    assert data["centre"] is None and data["where"] == str(path)


def test_a_zero_approach_vector_names_its_line(tmp_path):
    path = _records(tmp_path, n_targets=1)
    lines = path.read_text(encoding="utf-8").splitlines()
    fields = lines[3].split(",")
    fields[8:11] = ["0", "0", "0"]
    lines[3] = ",".join(fields)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(InputError) as info:
        read_repeatability_records(path)
    assert str(info.value) == f"{path}, line 4: the approach (i, j, k) is the zero vector"


def test_fit_document_with_windows_and_resolution_warning(tmp_path):
    path = _records(tmp_path, flat_x_target=7)
    fit = fit_repeatability_file(path, allow_few_targets=True, window=3, seed=2)
    assert fit.resolution_warnings == ["T7"]
    doc = fit.to_dict()
    assert doc["source"] == str(path)
    assert doc["resolution_warnings"] == ["T7"]
    assert doc["windows"]["first_iteration"] == 2
    assert len(fit.statistics.targets) == 45
    assert "windows" not in fit_repeatability_file(path, allow_few_targets=True).to_dict()
