"""Placement study (digest 001 A4.8, A4.9; issue 21)."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.kinematics.tracker import TrackerLimits, TrackerNoise, point_covariance, spherical
from mtmetrology.tracker import parse_mesh
from mtmetrology.tracker.placement import PlacementStudy, plan_placement
from mtmetrology.tracker.setup import workspace_box

TOOL = np.zeros((1, 3))


@pytest.fixture(scope="module")
def studies(machine, mesh):
    return {d: plan_placement(machine, mesh, TOOL, direction=d, trials=5000, seed=3) for d in "xy"}


def test_best_criterion_is_the_instrument_models_max_point_uncertainty(machine, mesh, studies):
    s = studies["x"]
    cov = point_covariance(s.best.to_tracker(mesh), TrackerNoise())
    u_p = np.sqrt(np.trace(cov, axis1=-2, axis2=-1))
    assert s.best_value == pytest.approx(u_p.max(), rel=1e-12)


def test_accepted_candidates_respect_the_limits_and_refused_are_counted(machine, mesh, studies):
    """Digest A4.9: no accepted candidate is inside the workspace or sees a mesh point
    beyond 0.5–15 m or ±45° elevation; the paper's region has some that do (too high)."""
    s = studies["x"]
    box = workspace_box(machine)
    assert not np.any(np.all((s.candidates >= box[0]) & (s.candidates <= box[1]), axis=1))
    for p in s.candidates[:: max(1, len(s.candidates) // 200)]:
        delta = np.arctan2(*(mesh.mean(axis=0) - p)[1::-1])
        rot = np.array([[np.cos(delta), -np.sin(delta), 0], [np.sin(delta), np.cos(delta), 0],
                        [0, 0, 1]])  # fmt: skip
        assert TrackerLimits().within(spherical((mesh - p) @ rot)).all()
    assert s.refused > 0 and s.refused + len(s.candidates) == 5000


def test_region_inside_the_workspace_is_refused(machine, mesh):
    with pytest.raises(InputError, match=r"^no candidate pose of the 100 drawn satisfies"):
        plan_placement(machine, mesh, TOOL, region=((850, 900), (150, 200), (250, 300)),
                       trials=100)  # fmt: skip


def test_square_mesh_gives_the_same_best_placement_along_x_and_y(studies):
    """The paper's mesh is 400 × 400 mm in X and Y, and u_p depends on range and elevation
    only: the Y study is the X study turned by 90°, so the best criteria are equal.  The
    paper's 30 % lower maximum along X (Figs 9–10) depends on its unpublished body and
    region and is not reproduced by this model."""
    assert studies["x"].best_value == pytest.approx(studies["y"].best_value, rel=1e-9)


def test_mesh_short_along_x_is_better_seen_along_x(machine):
    """A mesh 200 mm deep in X and 400 mm wide in Y: seen along X the far points are
    nearer than seen along Y, so the best max u_p along X is lower."""
    narrow = parse_mesh("900:1100:100,100:500:100,200:400:100", machine)
    x = plan_placement(machine, narrow, TOOL, direction="x", trials=5000, seed=4)
    y = plan_placement(machine, narrow, TOOL, direction="y", trials=5000, seed=4)
    assert x.best_value < 0.97 * y.best_value


def test_round_trip_and_bad_options(machine, mesh, studies):
    back = PlacementStudy.from_dict(studies["x"].to_dict())
    np.testing.assert_allclose(back.criterion, studies["x"].criterion, rtol=1e-12)
    np.testing.assert_allclose(back.best.vector, studies["x"].best.vector, rtol=1e-12)
    with pytest.raises(InputError, match=r"^--criterion must be max or mean"):
        plan_placement(machine, mesh, TOOL, criterion="median")
    with pytest.raises(InputError, match=r"^--direction must be x or y"):
        plan_placement(machine, mesh, TOOL, direction="z")
