"""Tests files, NAME=VALUE options and conditions at the command line."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.ballbar.records import BallbarConditions, nominal_test, write_ballbar
from mtmetrology.ballbar.requests import (
    analyse_file,
    conditions_from_options,
    load_tests,
    values_from_pairs,
)
from mtmetrology.errors import InputError
from mtmetrology.kinematics.machine import Machine


@pytest.fixture(scope="module")
def machine():
    return Machine.load("three-axis-xfyz")


def test_values_in_display_units(machine):
    got = values_from_pairs(
        machine, ["E_C0Y=20", "servo_mismatch_XY=1.5", "reversal_spike_X=3"], "--error"
    )
    assert got == pytest.approx(
        {"E_C0Y": 20e-6, "servo_mismatch_XY": 1.5e-3, "reversal_spike_X": 3e-3}
    )


@pytest.mark.parametrize("pair", ["E_C0Y", "E_C0Y=abc", "speed=3", "E_C0Y=nan"])
def test_bad_pairs_refused_naming_the_option(machine, pair):
    with pytest.raises(InputError, match="--error"):
        values_from_pairs(machine, [pair], "--error")


def test_plane_without_radius_refused():
    with pytest.raises(InputError, match="--radius is required"):
        conditions_from_options("XY", None, 1000.0, (0, 0, 0))


def test_tests_file_lists_several_tests(tmp_path):
    for plane, name in (("XY", "a"), ("YZ", "b")):
        cond = BallbarConditions(plane, 50.0, 800.0, np.zeros(3), name=name)
        write_ballbar(nominal_test(cond, 36), tmp_path / f"{name}.csv")
    (tmp_path / "tests.yaml").write_text(
        "kind: ballbar-tests\nversion: 1\ntests:\n"
        "  - {file: a.csv, name: a, plane: XY, radius_mm: 50, feed_mm_per_min: 800, "
        "centre_mm: [0, 0, 0]}\n"
        "  - {file: b.csv, name: b, plane: YZ, radius_mm: 50, feed_mm_per_min: 800, "
        "centre_mm: [0, 0, 0], overshoot_deg: 90}\n"
    )
    tests = load_tests(tmp_path / "tests.yaml")
    assert [t.conditions.plane for t in tests] == ["XY", "YZ"]
    assert tests[1].conditions.overshoot == pytest.approx(np.pi / 2)
    doc = analyse_file(tmp_path / "tests.yaml").to_dict()
    assert [t["test"] for t in doc["tests"]] == ["a", "b"]


def test_tests_file_missing_field_named(tmp_path):
    (tmp_path / "tests.yaml").write_text(
        "kind: ballbar-tests\nversion: 1\ntests:\n  - {file: a.csv, plane: XY}\n"
    )
    with pytest.raises(InputError, match=r"tests\[0\]: missing radius_mm"):
        load_tests(tmp_path / "tests.yaml")


def test_csv_without_conditions_refused(tmp_path):
    with pytest.raises(InputError, match="--plane"):
        load_tests(tmp_path / "x.csv")
