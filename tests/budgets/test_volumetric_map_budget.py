"""VDI/VDE 2617-11 budgets with a volumetric map: closed forms of digest 001-003 B4 item 5,
the plausibility check of item 6, the map Monte Carlo, and a virtual machine."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mtmetrology.budgets.volumetric_map import VolumetricMapBudget, volumetric_map_budget
from mtmetrology.errors import InputError
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.volumetric_map import VolumetricMap
from mtmetrology.multilateration.workflow import (
    Station,
    calibrate_multilateration,
    simulate_lengths,
)
from mtmetrology.units import to_internal

UM = to_internal(1.0, "µm")
S = to_internal(10.0, "µm/m")  # 10 µm/m
# ISO 10791-7 M1-160 test piece on the table: 160 x 160 mm, Ø108 bore at its centre.
CENTRE = np.array([400.0, 500.0, 100.0])
GRID = (np.linspace(0, 750, 6), np.linspace(0, 1000, 6), np.linspace(0, 500, 3))


def _map(field, factor=None, machine="vm") -> VolumetricMap:
    nodes = np.stack(np.meshgrid(*GRID, indexing="ij"), -1)
    return VolumetricMap(GRID, field(nodes), machine=machine, factor=factor)


def _bore(diameter, centre, n=36, cycles=1, rng=None, noise=0.0):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    ring = np.c_[diameter / 2 * np.cos(t), diameter / 2 * np.sin(t), np.zeros(n)] + centre
    sets = [ring + (0 if rng is None else rng.normal(0, noise, ring.shape)) for _ in range(cycles)]
    return np.vstack(sets), np.repeat(np.arange(cycles), n)


def _budget(points, vmap, kind="circle", **kw):
    return volumetric_map_budget(points, vmap, kind, u_p=UM, **kw)


def test_zero_map_gives_no_bias():
    pts, _ = _bore(108.0, CENTRE)
    b = _budget(pts, _map(lambda x: np.zeros_like(x)))
    assert all(r.b == 0.0 and r.u_b == 0.0 for r in b.rows)


def test_uniform_translation_moves_only_the_position():
    t = np.array([3.0, -2.0, 1.0]) * UM
    pts, _ = _bore(108.0, CENTRE)
    b = _budget(pts, _map(lambda x: np.broadcast_to(t, x.shape)))
    assert b.row("X position").b == pytest.approx(-t[0], abs=1e-12)
    assert b.row("Y position").b == pytest.approx(-t[1], abs=1e-12)
    for name in ("diameter", "roundness"):
        assert abs(b.row(name).b) < 1e-12
    plane = np.c_[np.random.default_rng(0).uniform(-80, 80, (20, 2)), np.zeros(20)] + CENTRE
    assert (
        abs(_budget(plane, _map(lambda x: np.broadcast_to(t, x.shape)), "plane").rows[0].b) < 1e-12
    )


def test_uniform_scale_in_x_and_y_changes_the_diameter_by_s_d():
    """e = s·(x, y, 0) about the origin: the corrected bore is (1 − s) times the indicated
    one: ΔD = −s·D = −1.08 µm for Ø108 at 10 µm/m, roundness unchanged, centre −s·(x_c, y_c)."""
    pts, _ = _bore(108.0, CENTRE)
    b = _budget(pts, _map(lambda x: S * x * [1.0, 1.0, 0.0]))
    assert b.row("diameter").b == pytest.approx(-1.08 * UM, rel=1e-9)
    assert abs(b.row("roundness").b) < 1e-12
    assert b.row("X position").b == pytest.approx(-S * CENTRE[0], rel=1e-9)
    assert b.row("Y position").b == pytest.approx(-S * CENTRE[1], rel=1e-9)


def test_scale_in_x_only_halves_the_diameter_change_and_makes_it_oval():
    """A scale s on X only: the bore becomes an ellipse, ΔD ≈ −s·D/2 and roundness
    ≈ s·D/2: 0.54 µm each for Ø108 at 10 µm/m (digest 001-003 B4 item 5)."""
    pts, _ = _bore(108.0, CENTRE, n=72)
    b = _budget(pts, _map(lambda x: S * (x - CENTRE) * [1.0, 0.0, 0.0]))
    assert b.row("diameter").b == pytest.approx(-0.54 * UM, rel=1e-3)
    assert b.row("roundness").b == pytest.approx(0.54 * UM, rel=1e-3)


def test_squareness_shifts_the_small_bores_in_the_sign_pattern():
    """e_x = α·y (X–Y squareness α = 10 µrad): a Ø28 bore at y_c > 0 moves by −α·y_c in X,
    one at y_c < 0 by +α·|y_c|; Y does not move."""
    alpha = 10e-6
    vmap = _map(
        lambda x: np.stack([alpha * (x[..., 1] - CENTRE[1]), 0 * x[..., 0], 0 * x[..., 0]], -1)
    )
    for dy in (52.0, -52.0):
        pts, _ = _bore(28.0, CENTRE + np.array([52.0, dy, 0.0]))
        b = _budget(pts, vmap)
        assert b.row("X position").b == pytest.approx(-alpha * dy, rel=1e-9)
        assert abs(b.row("Y position").b) < 1e-12


def test_plausibility_of_the_bias_with_a_20um_map():
    """Digest B4 item 6: a map within 20 µm over 750 × 1000 × 500 mm and within 5 µm over
    the 160 × 160 mm piece gives biases of the size of Table 1's u_b (1 to 7 µm)."""

    def field(x):
        u = (x - CENTRE) / np.array([750.0, 1000.0, 500.0])  # about -0.55 ... 0.55
        ex = 12 * u[..., 0] ** 2 + 8 * u[..., 1]
        ey = 10 * u[..., 0] * u[..., 1] + 6 * u[..., 2]
        ez = 9 * u[..., 1] ** 2
        return (np.stack([ex, ey, ez], -1) + np.array([2.5, -1.5, 0.5])) * UM

    vmap = _map(field)
    nodes = np.stack(np.meshgrid(*GRID, indexing="ij"), -1).reshape(-1, 3)
    assert np.abs(vmap.error(nodes)).max() <= 20 * UM
    piece = np.c_[np.random.default_rng(1).uniform(-80, 80, (400, 2)), np.zeros(400)] + CENTRE
    assert np.linalg.norm(vmap.error(piece), axis=1).max() <= 5 * UM
    biases = []
    for d, dx, dy in [(108, 0, 0), (28, 52, 52), (28, -52, 52), (28, -52, -52), (28, 52, -52)]:
        pts, _ = _bore(float(d), CENTRE + np.array([dx, dy, 0.0]))
        biases += [abs(r.b) for r in _budget(pts, vmap).rows]
    biases += [abs(_budget(piece[:40], vmap, "plane").rows[0].b)]
    assert len(biases) == 21
    assert max(biases) <= 7 * UM
    assert max(biases) >= 1 * UM


def test_map_monte_carlo_agrees_with_the_guf_and_uncorrected_vs_corrected():
    rng = np.random.default_rng(2)
    factor = rng.normal(size=(np.prod([g.size for g in GRID]), 3, 6)) * 0.3 * UM
    vmap = _map(lambda x: S * x * [1.0, 1.0, 0.0], factor=factor)
    pts, cyc = _bore(108.0, CENTRE, cycles=5, rng=rng, noise=1 * UM)
    guf = volumetric_map_budget(pts, vmap, "circle", cycles=cyc)
    mc = volumetric_map_budget(
        pts, vmap, "circle", cycles=cyc, u_cal_method="mc", trials=4000, seed=3
    )
    for g, m in zip(guf.rows, mc.rows, strict=True):
        assert m.u_cal == pytest.approx(g.u_cal, rel=0.08)  # sd of a 4000-draw sd: 1.1 %
    d = guf.row("diameter")
    assert d.u == pytest.approx(np.sqrt(d.b**2 + d.u_p**2 + d.u_cal**2), rel=1e-12)
    assert d.U == 2 * d.u and d.result == d.original
    sample = np.std(
        [
            np.linalg.norm(pts[cyc == c] - pts[cyc == c].mean(0), axis=1).mean() * 2
            for c in range(5)
        ],
        ddof=1,
    )
    assert d.u_p == pytest.approx(sample, rel=1e-3)
    corr = volumetric_map_budget(pts, vmap, "circle", cycles=cyc, mode="corrected")
    dc = corr.row("diameter")
    assert dc.result == dc.corrected and dc.u_cal == 0.0 and dc.u_b == pytest.approx(d.u_cal)
    back = VolumetricMapBudget.from_dict(json.loads(json.dumps(guf.to_dict())))
    assert back == guf
    assert guf.table()[0][0] == "diameter" and len(guf.table()) == 4


def test_virtual_machine_bias_recovered_within_its_uncertainty():
    """A virtual three-axis machine with known errors probes a true Ø108 bore; the map
    identified by multilateration corrects the indicated points to the true bore within
    the map's expanded uncertainty (k = 2) for the diameter and the centre.  Roundness is
    a peak-to-valley, bounded at zero: the corrected (true 0) value keeps a residue of the
    size of the map's point errors, far below the machine's 4 µm."""
    m = Machine.load("three-axis-xfyz")
    rng = np.random.default_rng(4)
    um = np.array([u == "µm" for u in m.parameter_units])
    theta = rng.normal(size=m.n_params) * np.where(um, 3e-3, 5e-6)
    stations = [
        Station("S1", (750, 50, 30), 100),
        Station("S2", (1250, 60, 40), 200),
        Station("S3", (760, 560, 20), 300),
        Station("S4", (1240, 540, 50), 400),
    ]
    tools = np.array([[0.0, 0.0, -100.0], [80.0, 0.0, -150.0], [0.0, 80.0, -150.0]])
    q = rng.uniform([800, 100, 200], [1200, 500, 400], (60, 3))
    res = calibrate_multilateration(m, simulate_lengths(m, theta, stations, q, tools, seed=5))
    grid = (np.linspace(800, 1200, 21), np.linspace(100, 500, 21), np.linspace(100, 300, 5))
    vmap = VolumetricMap.from_parameters(m, res.parameters, grid)
    true_pts, _ = _bore(108.0, np.array([1000.0, 300.0, 150.0]))
    readings = m.inverse(true_pts, np.zeros((len(true_pts), 3)), theta)
    indicated = m.forward(readings)
    b = volumetric_map_budget(indicated, vmap, "circle", u_p=0.0, machine=m.name)
    from mtmetrology.budgets.volumetric_map import _values, characteristics

    truth = _values(characteristics("circle"), true_pts)
    for j, r in enumerate(b.rows):
        if r.name != "roundness":
            assert abs(r.corrected - truth[j]) <= 2 * r.u_cal + 1e-6 * UM, r.name
    rnd = b.row("roundness")
    assert rnd.original > 2 * UM and rnd.corrected < 0.05 * rnd.original
    assert max(abs(r.b) for r in b.rows) > 1 * UM  # the machine's errors are not negligible


def test_bad_inputs():
    vmap = _map(lambda x: np.zeros_like(x))
    pts, _ = _bore(108.0, CENTRE, n=2)
    with pytest.raises(InputError, match="at least 3 needed"):
        _budget(pts, vmap)
    pts, _ = _bore(108.0, CENTRE)
    with pytest.raises(InputError, match="made for machine 'vm', not 'other'"):
        _budget(pts, vmap, machine="other")
    with pytest.raises(InputError, match="one measurement cycle"):
        volumetric_map_budget(pts, vmap, "circle")
    with pytest.raises(InputError, match="u_p: must be >= 0"):
        volumetric_map_budget(pts, vmap, "circle", u_p=-1.0)
    with pytest.raises(InputError, match="outside the map's grid"):
        _budget(pts + np.array([1000.0, 0, 0]), vmap)


def test_repeatability_from_repeated_results():
    """u_p of each characteristic from its repeated results (Eq. 3 with n − 1), or the
    largest over series; a characteristic without results is refused."""
    vmap = _map(lambda x: np.zeros_like(x))
    pts, _ = _bore(108.0, CENTRE)
    rng = np.random.default_rng(6)
    names = ["diameter"] * 20 + ["roundness"] * 20 + ["X position"] * 20 + ["Y position"] * 20
    values = rng.normal(0, 2e-3, 80)
    series = np.tile(np.repeat(["a", "b"], 10), 4)
    b = volumetric_map_budget(pts, vmap, "circle", repeats=(names, values, None))
    assert b.row("roundness").u_p == pytest.approx(np.std(values[20:40], ddof=1), rel=1e-12)
    iso = volumetric_map_budget(
        pts, vmap, "circle", repeats=(names, values, series), repeatability_method="max-over-series"
    )
    a, c = values[:10], values[10:20]
    assert iso.row("diameter").u_p == max(np.std(a, ddof=1), np.std(c, ddof=1))
    with pytest.raises(InputError, match="no values of characteristic 'Y position'"):
        volumetric_map_budget(pts, vmap, "circle", repeats=(names[:60], values[:60], None))


def test_tolerance_decisions_use_iso_14253_1():
    from mtmetrology.uncertainty.conformity import Tolerance

    vmap = _map(lambda x: S * x * [1.0, 1.0, 0.0])
    pts, _ = _bore(108.0, CENTRE)
    tol = {"diameter": Tolerance(108.0, -0.005, 0.005), "roundness": Tolerance(0, None, 0.001)}
    b = _budget(pts, vmap, tolerances=tol)
    d = b.decisions()
    # diameter 108 ± U (U = 2·√(1.08² + 1²) µm ≈ 2.9 µm) inside ±5 µm: conformance
    assert d["diameter"].decision.value == "conformance"
    # roundness 0 with U ≈ 2 µm against 1 µm: the interval crosses the limit
    assert d["roundness"].decision.value == "undecided"
    back = VolumetricMapBudget.from_dict(json.loads(json.dumps(b.to_dict())))
    assert back == b and back.decisions()["diameter"] == d["diameter"]
    with pytest.raises(InputError, match="'flatness' is not a characteristic of a circle"):
        _budget(pts, vmap, tolerances={"flatness": Tolerance(0, None, 0.01)})


def _feature_points(kind):
    rng = np.random.default_rng(7)
    if kind == "sphere":
        v = rng.normal(size=(30, 3))
        v[:, 2] = np.abs(v[:, 2])
        return CENTRE + 12.5 * v / np.linalg.norm(v, axis=1, keepdims=True)
    if kind == "cylinder":
        t, h = rng.uniform(0, 2 * np.pi, 40), rng.uniform(0, 50, 40)
        return CENTRE + np.c_[14 * np.cos(t), 14 * np.sin(t), h]
    if kind == "length":
        return CENTRE + np.array([[-50.0, 0, 0], [50.0, 0, 0]])
    return CENTRE + rng.normal(0, 0.01, (5, 3))  # position: repeated contacts of a point


@pytest.mark.parametrize("kind", ["sphere", "cylinder", "length", "position"])
def test_translation_moves_positions_and_keeps_sizes_for_every_feature(kind):
    t = np.array([3.0, -2.0, 1.0]) * UM
    b = _budget(_feature_points(kind), _map(lambda x: np.broadcast_to(t, x.shape)), kind)
    for r in b.rows:
        if r.name.endswith("position"):
            assert r.b == pytest.approx(-t["XYZ".index(r.name[0])], abs=1e-10)
        else:
            assert abs(r.b) < 1e-10, r.name
    s = _budget(_feature_points(kind), _map(lambda x: S * x), kind)  # isotropic scale
    if kind in ("sphere", "cylinder", "length"):
        size = s.rows[0]
        assert size.b < 0 and size.original > 0
        assert size.b / size.original == pytest.approx(-S, rel=1e-6)
