"""VolumetricMap: sign convention, trilinear interpolation, covariance, files."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.kinematics.volumetric_map import VolumetricMap
from mtmetrology.units import to_internal

M = Machine.load("three-axis-xfyz")
# Nominal tool-point positions: x = X, y = Y, z = Z - 100 (tool along -Z).
GRID = (np.linspace(800, 1200, 5), np.linspace(100, 500, 5), np.linspace(100, 300, 3))


def _set(values: dict, covariance=None) -> ParameterSet:
    z = ParameterSet.zeros(M)
    v = z.values.copy()
    for name, value in values.items():
        v[z.names.index(name)] = value
    return ParameterSet(z.names, v, z.units, covariance, machine=z.machine, model=z.model)


def test_sign_closed_form_positioning_error():
    """E_XX1 = +10 µm: at X = 1200 (u_x = +1) the tool is 10 µm beyond nominal along +X,
    so the error of indication is e_x = −10 µm and P_true = P_meas + 10 µm."""
    e10 = to_internal(10.0, "µm")
    mp = VolumetricMap.from_parameters(M, _set({"E_XX1": e10}), GRID)
    p = np.array([[1200.0, 300.0, 200.0], [800.0, 300.0, 200.0], [1000.0, 300.0, 200.0]])
    np.testing.assert_allclose(mp.error(p)[:, 0], [-e10, e10, 0.0], atol=1e-15)
    np.testing.assert_allclose(mp.correct(p)[0], p[0] + [e10, 0, 0], atol=1e-12)
    corr = VolumetricMap.from_parameters(M, _set({"E_XX1": e10}), GRID, sign="correction")
    np.testing.assert_allclose(corr.values, -mp.values)
    np.testing.assert_allclose(corr.error(p), mp.error(p))


def test_correct_recovers_the_true_tool_point_off_grid():
    """A model affine in each coordinate (positioning slopes, squareness) is trilinear:
    the interpolated correction equals the kinematic chain at random off-grid points."""
    theta = _set({"E_XX1": 8e-3, "E_YY1": -5e-3, "E_ZZ1": 3e-3, "E_C0Y": 20e-6, "E_B0Z": -9e-6})
    mp = VolumetricMap.from_parameters(M, theta, GRID)
    rng = np.random.default_rng(1)
    p = rng.uniform([800, 100, 100], [1200, 500, 300], (50, 3))
    q = M.inverse(p, np.zeros((50, 3)))
    true = M.forward(q, theta.values)
    np.testing.assert_allclose(mp.correct(p), true, atol=1e-10)


def test_interpolation_reproduces_nodes_and_refuses_outside():
    theta = _set({"E_XX2": 6e-3, "E_AY2": 30e-6})
    mp = VolumetricMap.from_parameters(M, theta, GRID)
    nodes = np.stack(np.meshgrid(*GRID, indexing="ij"), -1).reshape(-1, 3)
    np.testing.assert_allclose(mp.error(nodes), mp.values.reshape(-1, 3), atol=1e-15)
    with pytest.raises(InputError, match="outside the map's grid along x"):
        mp.error([[1300.0, 300.0, 200.0]])


def test_covariance_at_nodes_is_the_propagated_parameter_covariance():
    rng = np.random.default_rng(2)
    a = rng.normal(size=(M.n_params, M.n_params)) * 1e-6
    cov = a @ a.T
    mp = VolumetricMap.from_parameters(M, _set({}, cov), GRID)
    pts = np.array([[800.0, 100.0, 100.0], [1200.0, 500.0, 300.0]])
    q = M.inverse(pts, np.zeros((2, 3)))
    j = M.jacobian(q).reshape(6, -1)
    np.testing.assert_allclose(mp.covariance(pts), j @ cov @ j.T, rtol=1e-9, atol=1e-20)


def test_reference_position_is_zero():
    theta = _set({"E_XX2": 6e-3, "E_C0Y": 20e-6})
    ref = np.array([1000.0, 300.0, 200.0])
    mp = VolumetricMap.from_parameters(M, theta, GRID, reference=ref)
    np.testing.assert_allclose(mp.error(ref[None]), 0.0, atol=1e-15)


def test_round_trip_through_json():
    a = np.random.default_rng(3).normal(size=(M.n_params, 4)) * 1e-6
    mp = VolumetricMap.from_parameters(M, _set({"E_XX2": 6e-3}, a @ a.T), GRID)
    back = VolumetricMap.from_dict(json.loads(json.dumps(mp.to_dict())))
    pts = np.array([[900.0, 250.0, 150.0]])
    np.testing.assert_allclose(back.error(pts), mp.error(pts), rtol=1e-12)
    np.testing.assert_allclose(back.covariance(pts), mp.covariance(pts), rtol=1e-9)
    assert back.machine == M.name and back.sign == "error"


def test_vendor_grid_table(tmp_path):
    nodes = np.stack(np.meshgrid([0, 100], [0, 100], [0, 50], indexing="ij"), -1).reshape(-1, 3)
    e = nodes[:, [0]] * np.array([[0.01, 0.0, 0.0]])  # e_x = 10 µm/m·x → 1 µm at x = 100
    rows = [
        ",".join(map(str, [*n, *v, 0.5, 0.5, 0.5]))
        for n, v in zip(nodes[::-1], e[::-1], strict=True)
    ]
    path = tmp_path / "grid.csv"
    path.write_text("x,y,z,ex,ey,ez,ux,uy,uz\n" + "\n".join(rows) + "\n")
    mp = VolumetricMap.from_table(path, machine="m")
    np.testing.assert_allclose(mp.error([[50.0, 20.0, 10.0]]), [[0.5e-3, 0, 0]], atol=1e-15)
    # Mid-cell: 8 independent nodes of weight 1/8: u = 0.5 µm·sqrt(8/64).
    u = mp.standard_uncertainty([[50.0, 50.0, 25.0]])
    np.testing.assert_allclose(u, 0.5e-3 * np.sqrt(8 / 64), rtol=1e-12)
    stray = "200,0,0,0,0,0"  # a node off the 2x2x2 grid in place of one of it
    body = [r.rsplit(",", 3)[0] for r in rows[:-1]] + [stray]
    path.write_text("x,y,z,ex,ey,ez\n" + "\n".join(body) + "\n")
    with pytest.raises(InputError, match="full 3x2x2 grid"):
        VolumetricMap.from_table(path, machine="m")


def test_map_of_another_machine_refused():
    other = _set({})
    other = ParameterSet(other.names, other.values, other.units, machine="another", model=None)
    with pytest.raises(InputError, match="made for machine 'another'"):
        VolumetricMap.from_parameters(M, other, GRID)
