"""Closed loop: the controls' tables, applied by their own interpolation, cancel the error.

The tables are written to text, read by the emulation of the control (written from the
vendor's document, :mod:`mtmetrology.export.emulation`) and applied to the commanded
readings; the machine with the errors (the kinematic chain) then reaches the nominal point
to within the interpolation bound of the format.
"""

import numpy as np
import pytest
from scipy import stats

from mtmetrology.export import etalon, fanuc, isg, linuxcnc, siemens
from mtmetrology.export.control import residual
from mtmetrology.export.emulation import emulate
from mtmetrology.export.model import compensation_model
from mtmetrology.export.workflow import export_compensation
from mtmetrology.kinematics import Machine


def _emulated(module, tables, model):
    """What the control applies after reading the written files (its emulation)."""
    files = module.render(tables, model)
    return emulate(module.NAME, files, model.machine, reference=model.reference)


def _read_back(module, tables, model):
    """The tables as the control applies them after reading the written files."""
    return {t.function: t for t in _emulated(module, tables, model).tables}


def _readings(m, n, seed):
    rng = np.random.default_rng(seed)
    cols = {}
    for a in m.axis_names:
        travel = m.axes[a].travel
        cols[a] = rng.uniform(*travel, n) if travel is not None and a != "S" else np.zeros(n)
    return np.stack([cols[a] for a in m.axis_names], axis=-1)


def _closed_loop(m, theta, tables, q):
    """Tool point reached when the control shifts each table's output axis by its
    correction, minus the nominal point: the error left (mm)."""
    shifted = q.copy()
    for t in tables.values():
        k_in, k_out = m.axis_names.index(t.axis), m.axis_names.index(t.output)
        shifted[:, k_out] += t.correction(q[:, k_in])
    return m.forward(shifted, theta) - m.forward(q)


@pytest.mark.parametrize("function", ["E_XX", "E_YY", "E_ZZ"])
@pytest.mark.parametrize(
    ("module", "bound_mm"),
    # linear interpolation of a linear error is exact: 5e-7 mm of the 6-decimal files plus
    # the second-order term slope × correction (1e-4 × 23 µm); the Fanuc staircase leaves
    # one increment (slope × pitch = 1 µm) plus half a detection unit.
    [(linuxcnc, 1e-5), (siemens, 1e-5), (fanuc, 1.5e-3 + 1e-5)],
)
def test_positioning_slope_100_um_per_m_cancels_on_table_and_tool_side(
    make_set, module, bound_mm, function
):
    """Five-axis preset: X moves the table, Y and Z the spindle; E_XX1 = +100 µm/m (and
    likewise E_YY1, E_ZZ1) exported as corrections is cancelled by the control."""
    m = Machine.load("five-axis-wcbxfzyst")
    ps = make_set(m, {f"{function}1": 100.0})
    cm = compensation_model(m, ps, pitch=10, reference={"X": 0, "Y": 0, "Z": 0})
    tables = _read_back(module, module.build(cm, [function]), cm)
    q = _readings(m, 400, seed=1)
    before = _closed_loop(m, cm.theta, {}, q)
    after = _closed_loop(m, cm.theta, tables, q)
    assert np.abs(before).max() > 0.015  # 100 µm/m over ±200 mm
    assert np.abs(after).max() <= bound_mm


@pytest.mark.parametrize(
    ("function", "pitch_mm", "half_range"), [("E_YX", 10, 200), ("E_XZ", 10, 100)]
)
def test_straightness_exported_as_cross_table_cancels_to_linear_interpolation_bound(
    make_set, function, pitch_mm, half_range
):
    """Three-axis preset (Legendre): E_YX2 = 10 µm (X moves the table) and E_XZ2 = 10 µm
    (Z moves the spindle) through Sinumerik $AN_CEC tables; linear interpolation leaves at
    most h²/8 · max|f''| with f'' = 10 µm · 3 / half_range²."""
    m = Machine.load("three-axis-xfyz")
    ps = make_set(m, {f"{function}2": 10.0})
    cm = compensation_model(m, ps, pitch=pitch_mm)
    tables = _read_back(siemens, siemens.build(cm, [function]), cm)
    q = _readings(m, 400, seed=2)
    after = _closed_loop(m, cm.theta, tables, q)
    bound = pitch_mm**2 / 8 * 10e-3 * 3 / half_range**2 + 5e-7
    assert np.abs(after).max() <= bound
    # the residual of the library (sensitivities of the chain) is the same closed loop
    r, _ = residual(m, cm.theta, None, list(tables.values()), q)
    np.testing.assert_allclose(r, after, atol=1e-9)


def _random_set(make_set, m, seed, scale=5.0, u=0.3):
    rng = np.random.default_rng(seed)
    values = dict(zip(m.parameter_names, rng.normal(0, scale, m.n_params), strict=True))
    return make_set(m, values, u=dict.fromkeys(m.parameter_names, u))


@pytest.mark.parametrize("module", [linuxcnc, fanuc, siemens, isg, etalon])
def test_every_writer_makes_the_control_apply_the_intended_corrections(make_set, module):
    """What the emulated control applies, read from the files as its vendor documents them,
    is the correction the writer intended (−E): sign, unit, points and rule."""
    m = Machine.load("three-axis-xfyz")
    cm = compensation_model(m, _random_set(make_set, m, 3), pitch=20)
    built = module.build(cm)
    back = _read_back(module, built, cm)
    assert sorted(back) == sorted(t.function for t in built)
    for t in built:
        b = back[t.function]
        np.testing.assert_allclose(b.positions, t.positions, atol=5e-7)
        np.testing.assert_allclose(b.forward, t.forward, atol=5e-7)
        np.testing.assert_allclose(b.reverse, t.reverse, atol=5e-7)
        assert (b.rule, b.period) == (t.rule, t.period)
    if module in (isg, etalon):
        consts = _emulated(module, built, cm).constants
        np.testing.assert_allclose([v for _, v in consts], [v for _, v in isg.constants(cm)])


def test_samba_13_through_isg_leaves_only_second_order_error(make_set):
    """The 13 SAMBA parameters (location errors and linear scales) are all carried by the
    ISG volumetric compensation; linear interpolation of linear functions is exact."""
    m = Machine.load("five-axis-wcbxfzyst")
    ps = _random_set(make_set, m, 5, scale=20.0)
    result = export_compensation(m, ps, "isg", pitch=10)
    assert result.not_carried == []
    assert result.residual["uncompensated_max_um"] > 20
    assert result.residual["max_um"] < 0.02
    lin = export_compensation(m, ps, "linuxcnc", pitch=10)
    assert set(lin.not_carried) == {n for n in m.parameter_names if n[3] == "0"}


@pytest.mark.parametrize(
    ("preset", "model", "pitch", "seed"),
    [("three-axis-xfyz", None, 20, 6), ("five-axis-wcbxfzyst", "13", 10, 9)],
)
def test_virtual_machine_residual_uncertainty_covers_95_percent(preset, model, pitch, seed):
    """A virtual machine with known errors θ (the 21 functions of the three-axis preset;
    the SAMBA 13 of the five-axis one), 200 identifications θ̂ ~ N(θ, U), ISG tables from
    θ̂; at one held-out pose per trial the true residual lies within r̂ ± 1.96 u (one
    component per trial).  Acceptance region of the count for p = 0.95, n = 200:
    [181, 197] (0.5 % and 99.5 % binomial quantiles)."""
    from mtmetrology.kinematics.parameter_set import ParameterSet

    m = Machine.load(preset, model=model)
    rng = np.random.default_rng(seed)
    theta = rng.normal(0, 5.0, m.n_params) * m.parameter_scales
    sd = 0.3 * m.parameter_scales
    cov = np.diag(sd**2)
    covered, shrink = 0, []
    for trial in range(200):
        estimate = theta + sd * rng.standard_normal(m.n_params)
        ps = ParameterSet(
            m.parameter_names, estimate, m.parameter_units, cov, machine=m.name, model=m.model_name
        )
        cm = compensation_model(m, ps, pitch=pitch, covariance=False)
        tables, consts = isg.build(cm), isg.constants(cm)
        q = _readings(m, 1, seed=1000 + trial)
        true, _ = residual(m, theta, None, tables, q, constants=consts)
        stated, u = residual(m, estimate, cov, tables, q, constants=consts)
        k = trial % 3
        covered += abs(true[0, k] - stated[0, k]) <= 1.96 * u[0, k]
        shrink.append(np.linalg.norm(true) / np.linalg.norm(residual(m, theta, None, [], q)[0]))
    lo, hi = stats.binom.ppf([0.005, 0.995], 200, 0.95)
    assert (lo, hi) == (181, 197)
    assert lo <= covered <= hi
    assert np.median(shrink) < 0.2  # the tables remove most of the error


def test_isg_carries_a_reversal_as_a_bilateral_ssfk_table(make_set):
    """Five-axis 84 model, E_BBb = 5 µrad: LinuxCNC and ISG carry both directions (ISG as a
    bilateral leadscrew table ssfk_b.lis, left out of volcomp.csv); read back, the negative
    direction's correction exceeds the positive one by 2 · 5 µrad to the list's resolution
    (0.0001° = 1.7 µrad, each value rounded to half of it), and nothing is noted."""
    m = Machine.load("five-axis-wcbxfzyst", model="84")
    ps = make_set(m, {"E_BBb": 5.0})
    assert export_compensation(m, ps, "linuxcnc", pitch=10, functions=["E_BB"]).notes == []
    result = export_compensation(m, ps, "isg", pitch=10, functions=["E_BB"])
    assert result.notes == []
    assert "ssfk_b.lis" in result.files
    assert "EBB" not in result.files["volcomp.csv"]
    (table,) = emulate("isg", result.files, m).tables
    assert table.function == "E_BB"
    np.testing.assert_allclose(table.reverse - table.forward, 10e-6, atol=np.radians(1e-4))
    negative = result.residual["negative"]
    assert negative["max_um"] < 0.5 * negative["uncompensated_max_um"]
