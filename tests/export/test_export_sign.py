"""The sign of every written format, proven against the emulation of its control.

A single positioning error exported, read by the emulation written from the vendor's
document (:mod:`mtmetrology.export.emulation`), must leave at most 1 % of the error in
both directions of travel; the same writer with its sign flipped must leave at least
150 % (it doubles the error), so the check can fail.
"""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.export import _common, etalon, fanuc, isg, linuxcnc, siemens
from mtmetrology.export.emulation import emulate
from mtmetrology.export.model import compensation_model
from mtmetrology.export.workflow import emulated_residual, export_compensation
from mtmetrology.kinematics import Machine

MACHINE = "three-axis-xfyz"
# E_XX1 (Legendre, µm): +10 µm, so E = −10 µm at X = 800 mm.  Fanuc's detection unit (1 µm)
# and staircase (slope × pitch) cannot reach 1 % of 10 µm: 200 µm at a 1 mm pitch leaves
# 1 µm + 0.5 µm of rounding, 0.75 %.  A Fanuc table is zero at the reference position (the
# reference return absorbs the error there): the reference is X = 1000 mm, where E = 0.
REF = {"X": 1000.0}
CASES = [
    ("linuxcnc", linuxcnc, 10.0, 20),
    ("siemens", siemens, 10.0, 20),
    ("isg", isg, 10.0, 20),
    ("etalon", etalon, 10.0, 20),
    ("fanuc", fanuc, 200.0, 1),
]


def _ratios(result) -> tuple[float, float]:
    res = result.residual
    neg = res["negative"]
    return (
        res["max_um"] / res["uncompensated_max_um"],
        neg["max_um"] / neg["uncompensated_max_um"],
    )


@pytest.mark.parametrize(("fmt", "module", "value", "pitch"), CASES)
def test_a_single_positioning_error_is_removed_in_both_directions(
    make_set, fmt, module, value, pitch
):
    m = Machine.load(MACHINE)
    result = export_compensation(
        m, make_set(m, {"E_XX1": value}), fmt, pitch=pitch, functions=["E_XX"], reference=REF
    )
    assert result.residual["uncompensated_max_um"] > 0.8 * value  # the grid misses the ends
    forward, reverse = _ratios(result)
    assert forward <= 0.01
    assert reverse <= 0.01


@pytest.mark.parametrize(("fmt", "module", "value", "pitch"), CASES)
def test_a_writer_with_its_sign_flipped_doubles_the_error(
    make_set, monkeypatch, fmt, module, value, pitch
):
    """A sign error injected into the writer: the check (the emulated control) shows it."""
    flip = module if module is not etalon else isg

    def flipped(model, table):
        return tuple(-c for c in _common.corrections(model, table))

    monkeypatch.setattr(flip, "corrections", flipped)
    m = Machine.load(MACHINE)
    result = export_compensation(
        m, make_set(m, {"E_XX1": value}), fmt, pitch=pitch, functions=["E_XX"], reference=REF
    )
    forward, reverse = _ratios(result)
    assert forward >= 1.5
    assert reverse >= 1.5


def test_siemens_enc_comp_holds_the_error_as_k3_requires(make_set):
    """The issue's case: E_XX1 = +10 µm, so E = −10 µm at X = 800: ``$AA_ENC_COMP[0,0,X1]``
    holds −0.010 mm (+E, K3 p. 238: a positive value moves the axis negatively) and the
    residual is ≤ 1 % (it was 200 % when the table held −E)."""
    m = Machine.load(MACHINE)
    result = export_compensation(
        m, make_set(m, {"E_XX1": 10.0}), "siemens", pitch=20, functions=["E_XX"]
    )
    first = next(line for line in result.files["ENC_COMP.INI"].splitlines() if "[0,0,X1]" in line)
    assert float(first.split("=")[1]) == pytest.approx(-0.010, abs=1e-9)
    assert result.sign["established"] is True
    assert result.residual["max_um"] <= 0.01 * result.residual["uncompensated_max_um"]


@pytest.mark.parametrize(("fmt", "established"), [("linuxcnc", True), ("fanuc", False)])
def test_the_sign_statement_follows_the_documents(make_set, fmt, established):
    m = Machine.load(MACHINE)
    result = export_compensation(m, make_set(m, {"E_XX1": 10.0}), fmt, pitch=20)
    doc = result.to_dict()
    assert doc["sign"]["established"] is established
    assert (doc["sign"]["statement"] in doc["notes"]) is (not established)
    assert doc["model"] == "21-legendre"


def test_siemens_cross_table_sign_is_flagged(make_set):
    m = Machine.load(MACHINE)
    result = export_compensation(
        m, make_set(m, {"E_YX2": 10.0}), "siemens", pitch=20, functions=["E_YX"]
    )
    (cec,) = result.sign["files"]
    assert (cec["file"], cec["sign_established"]) == ("CEC.INI", False)
    assert result.notes[0] == result.sign["statement"]


def test_check_json_residual_is_the_emulation_of_the_written_files(make_set, tmp_path):
    """The command's check.json equals, to 1e-9 µm, the residual of the emulated control
    reading the files the command wrote, on the same grid."""
    m = Machine.load(MACHINE)
    params = tmp_path / "p.json"
    rng = np.random.default_rng(4)
    make_set(m, dict(zip(m.parameter_names, rng.normal(0, 5, m.n_params), strict=True))).save(
        params
    )
    out = tmp_path / "out"
    out.mkdir()
    res = CliRunner().invoke(
        app,
        ["export", "siemens", str(params), "--machine", MACHINE, "--pitch", "20", "-o", str(out)],
    )
    assert res.exit_code == 0, res.output
    doc = json.loads((out / "check.json").read_text())
    files = {name: (out / name).read_text() for name in doc["files"]}
    cm = compensation_model(m, make_set(m, {}), pitch=20)  # the machine and its reference
    from mtmetrology.kinematics.parameter_set import ParameterSet

    ps = ParameterSet.load(params, m)
    cm = compensation_model(m, ps, pitch=20)
    readings = np.array(doc["residual"]["readings"])
    r, _ = emulated_residual(cm, emulate("siemens", files, cm.machine), readings)
    np.testing.assert_allclose(doc["residual"]["r_um"], r * 1e3, rtol=0, atol=1e-9)
