"""Tests for mtmetrology.export.workflow (export_compensation and its document)."""

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.export import linuxcnc
from mtmetrology.export.model import compensation_model
from mtmetrology.export.workflow import (
    ADVISOR_PITCHES,
    ExportResult,
    check_readings,
    export_compensation,
    residual_check,
)
from mtmetrology.kinematics import Machine

MACHINE = Machine.load("three-axis-xfyz")  # X 800–1200, Y 100–500, Z 200–400 mm
GOLDEN = (3 - 5**0.5) / 2


def _slope_set(make_set, **extra):
    """E_XX = 100 µm · ξ (ξ = −1 … 1 over the X travel), u = 0.3 µm on every parameter."""
    return make_set(
        MACHINE,
        {"E_XX1": 100.0, **extra},
        u=dict.fromkeys(MACHINE.parameter_names, 0.3),
    )


def test_check_readings_are_the_golden_section_grid_over_the_travel():
    q = check_readings(MACHINE, per_axis=3)
    assert q.shape == (27, 3)
    x = 800.0 + 400.0 * (np.arange(3) + GOLDEN) / 3
    np.testing.assert_allclose(np.unique(q[:, 0]), x, rtol=1e-15)
    np.testing.assert_allclose(np.unique(q[:, 2]), 200.0 + 200.0 * (np.arange(3) + GOLDEN) / 3)


def test_a_positioning_slope_is_removed_exactly_by_linear_tables(make_set):
    """LinuxCNC interpolates linearly: a linear E_XX leaves no residual; uncompensated, the
    largest error on the check grid is 100 µm · |ξ| at the first grid point,
    ξ = 2 · 0.382/5 − 1."""
    result = export_compensation(MACHINE, _slope_set(make_set), "linuxcnc", pitch=20)
    res = result.residual
    assert res["points"] == 125 and res["k"] == 2
    assert res["max_um"] < 1e-3
    xi = 2 * GOLDEN / 5 - 1
    assert res["uncompensated_max_um"] == pytest.approx(100.0 * abs(xi), rel=1e-9)
    (row,) = [t for t in result.tables if t["function"] == "E_XX"]
    assert row["points"] == 21 and row["pitch"] == 20.0 and row["unit"] == "µm"
    assert row["max_correction"] == pytest.approx(100.0, abs=1e-9)


def test_document_round_trip_keeps_every_field(make_set):
    at = np.array([[900.0, 200.0, 300.0], [1100.0, 450.0, 250.0]])
    lib = export_compensation(MACHINE, _slope_set(make_set), "fanuc", pitch=20, at=at)
    doc = lib.to_dict()
    assert (doc["kind"], doc["version"], doc["files"]) == (
        "compensation-export",
        1,
        ["fanuc_pitch.txt"],
    )
    back = ExportResult.from_dict(doc, lib.files)
    assert back.to_dict() == doc
    assert back.files == lib.files
    assert ExportResult.from_dict(doc).files == {"fanuc_pitch.txt": ""}


def test_at_points_are_the_residual_at_the_users_readings(make_set):
    ps = _slope_set(make_set, E_XX2=20.0)
    at = np.array([[900.0, 200.0, 300.0], [1190.0, 450.0, 250.0]])
    lib = export_compensation(MACHINE, ps, "linuxcnc", pitch=50, at=at)
    model = compensation_model(MACHINE, ps, pitch=50)
    r, _ = residual_check(model, linuxcnc.build(model), (), at)
    np.testing.assert_allclose(lib.at_points["r"], r * 1e3, rtol=1e-12, atol=1e-12)
    assert np.abs(r).max() > 1e-5  # a quadratic error leaves an interpolation residual
    assert lib.at_points["U"].shape == (2, 3)


def test_fanuc_carries_only_positioning_errors(make_set):
    result = export_compensation(MACHINE, _slope_set(make_set), "fanuc", pitch=20)
    assert [t["function"] for t in result.tables] == ["E_XX", "E_YY", "E_ZZ"]
    assert "E_YX" in result.not_carried and "E_XX" not in result.not_carried


def test_pitch_advisor_meets_its_bound_and_a_tighter_bound_needs_a_finer_pitch(make_set):
    ps = _slope_set(make_set, E_XX2=50.0)
    loose = export_compensation(MACHINE, ps, "linuxcnc", pitch=20, bound_um=1.0).advisor
    assert loose["met"] and loose["pitch"] in ADVISOR_PITCHES
    assert loose["interpolation_error_um"] <= 1.0
    tight_bound = loose["interpolation_error_um"] / 2
    tight = export_compensation(MACHINE, ps, "linuxcnc", pitch=20, bound_um=tight_bound).advisor
    assert tight["met"] and tight["pitch"] < loose["pitch"]
    assert tight["interpolation_error_um"] <= tight_bound


@pytest.mark.parametrize(
    ("fmt", "kwargs", "message"),
    [
        (
            "heidenhain",
            {"pitch": 10},
            "format: 'heidenhain' is not one of linuxcnc, fanuc, siemens, isg, etalon, grid",
        ),
        ("linuxcnc", {}, "give --pitch or --points"),
    ],
)
def test_bad_requests_are_refused(make_set, fmt, kwargs, message):
    with pytest.raises(InputError) as info:
        export_compensation(MACHINE, _slope_set(make_set), fmt, **kwargs)
    assert str(info.value) == message


def test_a_document_of_another_kind_is_refused():
    with pytest.raises(InputError) as info:
        ExportResult.from_dict({"kind": "fit-result", "version": 1})
    assert str(info.value) == "kind/version: not a compensation-export document of version 1"
