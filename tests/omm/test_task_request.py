"""Tests for mtmetrology.omm.task_request (one task-uncertainty request from its files)."""

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.fitting.composite import CombinedFeature
from mtmetrology.fitting.zone_features import MinimumZoneRoundness
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.omm.task_request import (
    ordered_covariance,
    task_feature,
    task_points,
    task_uncertainty_from_files,
)

MACHINE = Machine.load("five-axis-wcbxfzyst")
# Table 7-1 gauge-block readings (Sepahi Boroujeni (2021)), the two faces of a length,
# written here with the second face first.
LENGTH_POINTS = """point,X,Y,Z,B,C,end
p2,-61.2880,48.3440,246.8170,-64,-124,2
p1,-138.5650,94.6560,196.2320,-42,-293,1
"""


def _sphere_centres(radius=10.0, n=26):
    u = np.random.default_rng(1).normal(size=(n, 3))
    return [5.0, -3.0, 40.0] + radius * u / np.linalg.norm(u, axis=1, keepdims=True)


def _params(path, seed=1):
    rng = np.random.default_rng(seed)
    a = MACHINE.parameter_scales[:, None] * rng.normal(size=(13, 13))
    ParameterSet(
        MACHINE.parameter_names,
        rng.normal(size=13) * MACHINE.parameter_scales * 3,
        MACHINE.parameter_units,
        covariance=a @ a.T,
        machine=MACHINE.name,
    ).save(path)
    return path


@pytest.mark.parametrize(("side", "diameter"), [(None, 20.0 - 2.0), ("inner", 20.0 + 2.0)])
def test_sphere_feature_compensates_the_tip_towards_the_material(side, diameter):
    """Stylus centres on a sphere of radius 10 mm, tip Ø 2 mm: a ball (default side) is
    Ø 18 mm, a spherical cavity Ø 22 mm; the form of exact points is zero."""
    feature = task_feature("sphere", "least-squares", side, 2.0, 26)
    assert isinstance(feature, CombinedFeature)
    value = np.asarray(feature.value(_sphere_centres()))
    assert value[0] == pytest.approx(diameter, abs=1e-9)
    assert value[1] == pytest.approx(0.0, abs=1e-9)


def test_feature_kinds_and_output_counts():
    circle = task_feature("circle", "minimum-zone", None, 1.0, 12)
    assert isinstance(circle.features[1], MinimumZoneRoundness)
    assert len(task_feature("points", "least-squares", None, 1.0, 4).output_names) == 12
    assert len(task_feature("length", "least-squares", None, 1.0, 2).output_names) == 1


def test_ordered_covariance_follows_the_machine_order():
    names = MACHINE.parameter_names[::-1]
    cov = np.diag(np.arange(1.0, 14.0))
    cov[0, 1] = cov[1, 0] = 0.5  # between the last two parameters of the machine
    pset = ParameterSet(names, np.zeros(13), MACHINE.parameter_units[::-1], covariance=cov)
    ordered = ordered_covariance(pset, MACHINE)
    np.testing.assert_array_equal(np.diag(ordered), np.arange(13.0, 0.0, -1.0))
    assert ordered[12, 11] == ordered[11, 12] == 0.5


def test_length_points_are_ordered_by_their_end_column(tmp_path):
    path = tmp_path / "points.csv"
    path.write_text(LENGTH_POINTS, encoding="utf-8")
    readings, approach, senses = task_points(path, MACHINE, "length", need_approach=False)
    x = MACHINE.axis_names.index("X")
    assert readings[:, x].tolist() == [-138.5650, -61.2880]
    assert approach is None and senses is None


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            LENGTH_POINTS + "p3,0,0,200,0,0,1\n",
            "{path}: a length needs exactly 2 points (one pair), got 3",
        ),
        (LENGTH_POINTS.replace(",2\n", ",3\n"), "{path}: column 'end' must hold 1 and 2"),
    ],
)
def test_bad_length_points_are_refused(tmp_path, text, message):
    path = tmp_path / "points.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(InputError) as info:
        task_points(path, MACHINE, "length", need_approach=False)
    assert str(info.value) == message.format(path=path)


@pytest.mark.parametrize(
    ("feature", "kwargs", "message"),
    [
        (
            "torus",
            {"recalibrated": True},
            "feature 'torus': not one of length, sphere, "
            "circle, plane, cylinder, sphere-centre, circle-centre, points",
        ),
        (
            "length",
            {"recalibrated": True, "long_term": "lt.json"},
            "--long-term and --recalibrated: a machine recalibrated for the task has no "
            "long-term term; give one of them",
        ),
        (
            "length",
            {},
            "state the long-term variation of the parameters since the calibration: "
            "--long-term FILE (mtm samba long-term), or --recalibrated",
        ),
        (
            "plane",
            {"recalibrated": True, "side": "inner"},
            "--side applies to a sphere, circle or cylinder, not to a plane",
        ),
        (
            "length",
            {"recalibrated": True, "form": "minimum-zone"},
            "--form minimum-zone applies to a form error, not to a length",
        ),
    ],
)
def test_contradictory_requests_are_refused_before_any_file_is_read(feature, kwargs, message):
    with pytest.raises(InputError) as info:
        task_uncertainty_from_files("missing.csv", MACHINE, "missing.json", feature, **kwargs)
    assert str(info.value) == message


def test_a_length_with_tolerance_gets_a_decision_and_names_its_files(tmp_path):
    points = tmp_path / "points.csv"
    points.write_text(LENGTH_POINTS, encoding="utf-8")
    params = _params(tmp_path / "params.json")
    result = task_uncertainty_from_files(
        points,
        MACHINE,
        params,
        "length",
        recalibrated=True,
        tolerance="100,-0.01,0.01",
        tolerance_output="gauge_length",
    )
    assert result.target == 0
    assert result.source == {"points": str(points), "params": str(params)}
    out = result.result.outputs[0]
    # the decision is made on the result's own value and U, guard bands h·U (h = 1)
    d = result.decision
    assert (d.value, d.uncertainty_below, d.uncertainty_above) == (out.value, out.U, out.U)
    assert d.acceptance_zone == pytest.approx((100.0 - 0.01 + out.U, 100.0 + 0.01 - out.U))
    with pytest.raises(InputError) as info:
        task_uncertainty_from_files(
            points, MACHINE, params, "length", recalibrated=True, tolerance_output="length"
        )
    assert str(info.value) == "--tolerance-output needs --tolerance"
    with pytest.raises(InputError) as info:
        task_uncertainty_from_files(
            points,
            MACHINE,
            params,
            "length",
            recalibrated=True,
            tolerance="100,-0.01,0.01",
            tolerance_output="length",
        )
    assert str(info.value) == "--tolerance-output: 'length' is not an output (gauge_length)"
