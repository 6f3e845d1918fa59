"""The volumetric grid is a VolumetricMap: from a parameter set or a measured map, written
as the vendor grid CSV, read back by VolumetricMap.from_table, applied trilinearly."""

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.export import grid, linuxcnc
from mtmetrology.export.model import compensation_model
from mtmetrology.export.workflow import export_compensation
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.volumetric_map import VolumetricMap


@pytest.fixture
def machine():
    return Machine.load("three-axis-xfyz")


def _nodes(field):
    return np.stack(np.meshgrid(*field.axes, indexing="ij"), axis=-1).reshape(-1, 3)


def test_single_positioning_error_sign_agrees_with_the_map_and_the_axis_tables(machine, make_set):
    """E_XX1 = +20 µm alone (Legendre basis over X = 1000 ± 200 mm: E_XX(x) = 20 µm ·
    (x − 1000)/200, +100 µm/m): the map's error of indication is e_x = −E_XX(x) =
    −1e-4 (x − 1000) mm (VolumetricMap: e = P_indicated − P_true = −δ), e_y = e_z = 0; it is
    the correction the LinuxCNC X table applies at the same x, so the grid and the axis
    tables command the same shift."""
    ps = make_set(machine, {"E_XX1": 20.0})
    field = grid.from_parameters(machine, ps, grid.grid_lines(grid.box(machine), pitch=25.0))
    nodes = _nodes(field)
    e = field.error(nodes)
    np.testing.assert_array_equal(e[:, 1:], 0.0)
    np.testing.assert_allclose(e[:, 0], -1e-4 * (nodes[:, 0] - 1000.0), atol=1e-12)
    delta = machine.forward(nodes - machine.tool, ps.vector_for(machine)) - nodes
    np.testing.assert_allclose(e, -delta, atol=1e-12)  # e = −δ: the map's convention
    cm = compensation_model(machine, ps, pitch=25.0)
    (table,) = linuxcnc.build(cm, ["E_XX"])
    np.testing.assert_allclose(e[:, 0], table.correction(nodes[:, 0]), atol=1e-12)
    # the control commands P + e(P) and lands on P (the error is linear: exact)
    q = nodes - machine.tool + field.error(nodes)
    np.testing.assert_allclose(machine.forward(q, ps.vector_for(machine)), nodes, atol=1e-8)


def test_grid_written_and_read_back_gives_the_same_map(machine, make_set):
    """E_YX2 = 10 µm with u = 0.5 µm: written at 4 decimals of µm and read back by
    VolumetricMap.from_table, the nodes, the errors and their u agree to 5e-5 µm; the
    control's trilinear interpolation of the read grid lands the tool on the nominal point
    to h²/8 · max|f''| (f'' = 10 µm · 3 / 200² mm⁻¹, h = 25 mm), and residual_grid gives
    the same residual as the chain."""
    ps = make_set(machine, {"E_YX2": 10.0}, u={"E_YX2": 0.5})
    field = grid.from_parameters(machine, ps, grid.grid_lines(grid.box(machine), pitch=25.0))
    back = grid.parse(grid.render(field, machine.name), machine.name)
    for a, b in zip(field.axes, back.axes, strict=True):
        np.testing.assert_allclose(b, a, atol=5e-5)
    nodes = _nodes(field)
    np.testing.assert_allclose(back.error(nodes), field.error(nodes), atol=5e-8)
    u = grid.node_uncertainty(field, nodes)
    assert u.max() > 0
    np.testing.assert_allclose(grid.node_uncertainty(back, nodes), u, atol=5e-8)
    rng = np.random.default_rng(8)
    lo, hi = np.array(grid.box(machine)).T
    p = rng.uniform(lo, hi, (400, 3))
    theta = ps.vector_for(machine)
    q = p - machine.tool + back.error(p)  # the command P + e(P) as readings
    after = machine.forward(q, theta) - p
    assert np.abs(after).max() <= 25.0**2 / 8 * 10e-3 * 3 / 200**2 + 1e-7
    r, u_r, before = grid.residual_grid(ps, machine, back, p)
    np.testing.assert_allclose(r, after, atol=1e-9)
    assert np.abs(before).max() > 10 * np.abs(r).max()
    assert u_r.max() > 0


def test_a_measured_map_is_a_source_the_same_nodes_leave_nothing(machine, make_set):
    """A map given as the source: on its own nodes the control's grid is the map (residual
    0, u the map's own); at a coarser pitch the residual is the resampling interpolation
    error, below the h²/8 bound of the coarse grid."""
    ps = make_set(machine, {"E_YX2": 10.0}, u={"E_YX2": 0.5})
    source = VolumetricMap.from_parameters(machine, ps, grid.grid_lines(grid.box(machine), 10.0))
    same = export_compensation(machine, source, "grid", pitch=10.0)
    assert same.residual["max_um"] == pytest.approx(0.0, abs=1e-9)
    assert same.residual["max_U_um"] > 0
    coarse = export_compensation(machine, source, "grid", pitch=50.0)
    assert 0 < coarse.residual["max_um"] <= 1e3 * 50.0**2 / 8 * 10e-3 * 3 / 200**2
    back = grid.parse(coarse.files)
    np.testing.assert_allclose(back.axes[0], np.arange(800.0, 1201.0, 50.0))


def test_map_sources_are_refused_where_they_do_not_belong(machine, make_set):
    ps = make_set(machine, {"E_YX2": 10.0})
    source = VolumetricMap.from_parameters(machine, ps, grid.grid_lines(grid.box(machine), 50.0))
    with pytest.raises(InputError, match=r"^format: linuxcnc tabulates error functions"):
        export_compensation(machine, source, "linuxcnc", pitch=10.0)
    other = Machine.load("five-axis-wcbxfzyst")
    with pytest.raises(InputError, match=r"^map: made for machine 'three-axis-xfyz'"):
        export_compensation(other, source, "grid", pitch=10.0)
    with pytest.raises(InputError, match=r"^grid: x from 700 to 1000 mm is outside"):
        export_compensation(machine, source, "grid", pitch=50.0, region={"x": (700, 1000)})
