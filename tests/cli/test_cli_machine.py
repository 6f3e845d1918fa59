"""mtm machine list/show/check/identifiability and mtm predict."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.io import read_csv_table
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.kinematics.preset_registry import list_presets
from mtmetrology.samba import SambaSetup, probing_sequence

runner = CliRunner()

ARTEFACT = """kind: samba-artefact
balls:
  - {id: "1", diameter_mm: 12.7}
  - {id: "2", diameter_mm: 12.7}
  - {id: SB1, diameter_mm: 12.7}
  - {id: SB2, diameter_mm: 12.7}
scale_bar: {ends: [SB1, SB2], length_mm: 305.2105, u_mm: 0.0012}
"""


@pytest.fixture(scope="module")
def poses(tmp_path_factory):
    """A two-ball SAMBA strategy with spindle indexing, as a ball-centre CSV."""
    m = Machine.load("five-axis-wcbxfzyst")
    setup = SambaSetup(
        balls={"1": (-80, -40, 100), "2": (80, 120, 150)},
        scale_bar={"SB1": (-152.60525, 0, 30), "SB2": (152.60525, 0, 30)},
    )
    # B within ±60°: at ±90° the scale-bar ends would need Z below its travel (-110 mm)
    pairs = [(b, c) for b in (-60, -30, 0, 30, 60) for c in range(0, 360, 60)]
    ids, q = probing_sequence(m, setup, pairs)
    c = m.readings_to_customary(q)
    d = tmp_path_factory.mktemp("poses")
    path = d / "poses.csv"
    lines = ["ball,X,Y,Z,B,C,S"] + [
        f"{i}," + ",".join(f"{v:.6f}" for v in row) for i, row in zip(ids, c, strict=True)
    ]
    path.write_text("\n".join(lines) + "\n")
    (d / "artefact.yaml").write_text(ARTEFACT)
    return path, d / "artefact.yaml"


def test_list_names_every_preset():
    result = runner.invoke(app, ["machine", "list"])
    assert result.exit_code == 0
    for name in ("five-axis-wcbxfzyst", "three-axis-xfyz", "cmm-moving-bridge"):
        assert name in result.output


def test_show_json_lists_parameters_with_units():
    result = runner.invoke(app, ["machine", "show", "five-axis-wcbxfzyst", "--json"])
    assert result.exit_code == 0
    doc = json.loads(result.output)
    units = {p["name"]: p["unit"] for p in doc["parameters"]}
    assert units["E_XX1"] == "µm/m" and units["E_X0C"] == "µm" and units["E_A0B"] == "µrad"
    assert [a["axis"] for a in doc["axes"]] == ["X", "Y", "Z", "B", "C", "S"]
    result = runner.invoke(app, ["machine", "show", "five-axis-wcbxfzyst", "--model", "84"])
    assert result.exit_code == 0 and "84 parameters" in result.output
    result = runner.invoke(
        app, ["machine", "show", "three-axis-xfyz", "--catalogue", "--degree", "2", "--json"]
    )
    doc = json.loads(result.output)
    # 3 axes x (6 location + 6 x 3 motion coefficients + 6 reversal terms)
    assert len(doc["parameters"]) == 3 * (6 + 18 + 6)
    units = {p["name"]: p["unit"] for p in doc["parameters"]}
    assert units["E_XX2"] == "µm" and units["E_B0Z"] == "µrad"  # Legendre: error units


def test_check_reports_every_model_and_names_bad_fields(tmp_path):
    good = tmp_path / "good.yaml"
    good.write_text("name: g\ntopology: WXFYZT\nerror_models:\n  a: {parameters: [E_XX1]}\n")
    result = runner.invoke(app, ["machine", "check", str(good)])
    assert result.exit_code == 0 and "model 'a': 1 parameters" in result.output
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: b\ntopology: WXFYZT\naxes:\n  X: {travel_mm: [5, 1]}\n")
    result = runner.invoke(app, ["machine", "check", str(bad)])
    assert result.exit_code == 2
    assert "axes.X.travel_mm" in result.output


def test_identifiability_full_rank_and_confounded(poses):
    path, artefact = poses
    ok = runner.invoke(
        app,
        [
            "machine",
            "identifiability",
            "five-axis-wcbxfzyst",
            str(path),
            "--artefact",
            str(artefact),
        ],
    )
    assert ok.exit_code == 0, ok.output
    assert "unknowns 28, rank 28" in ok.output
    bad = runner.invoke(
        app,
        [
            "machine",
            "identifiability",
            "five-axis-wcbxfzyst",
            str(path),
            "--artefact",
            str(artefact),
            "--add",
            "E_Y0C",
            "--json",
        ],
    )
    doc = json.loads(bad.output)
    assert doc["rank"] == 28 and doc["n_unknowns"] == 29
    assert doc["null_directions"][0]["summary"] == "E_Y0S ~ E_Y0C"
    no_bar = runner.invoke(
        app, ["machine", "identifiability", "five-axis-wcbxfzyst", str(path), "--json"]
    )
    assert json.loads(no_bar.output)["rank"] == 27  # the scale gains need the bar


def test_predict_writes_compensated_coordinates(tmp_path):
    rec = tmp_path / "rec.csv"
    rec.write_text("id,X,Y,Z,B,C\np1,-138.5650,94.6560,196.2320,-42,-293\n")
    m = Machine.load("five-axis-wcbxfzyst")
    values = np.zeros(13)
    values[m.parameter_names.index("E_X0C")] = -0.1046  # -104.6 µm
    ParameterSet(m.parameter_names, values, m.parameter_units, machine=m.name).save(
        tmp_path / "p.json"
    )
    out = tmp_path / "out.csv"
    result = runner.invoke(
        app,
        [
            "predict",
            "--machine",
            "five-axis-wcbxfzyst",
            "--params",
            str(tmp_path / "p.json"),
            str(rec),
            "-o",
            str(out),
        ],
    )
    assert result.exit_code == 0, result.output
    table = read_csv_table(out)
    assert table.header == ("id", "X", "Y", "Z", "B", "C", "x", "y", "z")
    assert table.strings("id") == ["p1"]
    xyz = np.column_stack([table.floats(c) for c in "xyz"])
    q = m.readings_from_customary({"X": -138.565, "Y": 94.656, "Z": 196.232, "B": -42, "C": -293})
    np.testing.assert_allclose(xyz[0], m.forward(q, values), atol=1e-6)
    plain = tmp_path / "nominal.csv"
    nominal = runner.invoke(
        app, ["predict", "--machine", "five-axis-wcbxfzyst", str(rec), "-o", str(plain)]
    )
    assert nominal.exit_code == 0, nominal.output
    table = read_csv_table(plain)
    # the nominal chain written out by hand: the table carries X (sign -1), B and C (sign
    # -1), so the stylus at (X, Y, Z) in the machine frame is Rz(C)·Ry(B)·(X, Y, Z) in the
    # workpiece frame (6 decimals as printed)
    b, c = np.deg2rad(-42.0), np.deg2rad(-293.0)
    rz = np.array([[np.cos(c), -np.sin(c), 0], [np.sin(c), np.cos(c), 0], [0, 0, 1]])
    ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    expected = rz @ ry @ np.array([-138.565, 94.656, 196.232])
    got = [table.floats(k)[0] for k in "xyz"]
    np.testing.assert_allclose(got, expected, atol=1e-6)


def test_predict_bad_input_names_file_and_column(tmp_path):
    rec = tmp_path / "rec.csv"
    rec.write_text("X,Y,Z,B\n1,2,3,4\n")
    result = runner.invoke(app, ["predict", "--machine", "five-axis-wcbxfzyst", str(rec)])
    assert result.exit_code == 2
    assert "missing column 'C'" in result.output
    rec.write_text("X,Y,Z,B,C\n1,2,nan,4,5\n")
    result = runner.invoke(app, ["predict", "--machine", "five-axis-wcbxfzyst", str(rec)])
    assert result.exit_code == 2 and "line 2" in result.output


def test_predict_with_backlash_needs_sense_columns(tmp_path):
    m = Machine.load("five-axis-wcbxfzyst", "84")
    values = np.zeros(m.n_params)
    values[m.parameter_names.index("E_BBb")] = 5e-6
    ParameterSet(m.parameter_names, values, m.parameter_units, machine=m.name).save(
        tmp_path / "p.yaml"
    )
    rec = tmp_path / "rec.csv"
    rec.write_text("X,Y,Z,B,C\n10,20,30,45,90\n")
    args = ["predict", "--machine", "five-axis-wcbxfzyst", "--params", str(tmp_path / "p.yaml")]
    result = runner.invoke(app, [*args, str(rec)])
    assert result.exit_code == 2 and "sense_B" in result.output
    rec.write_text("X,Y,Z,B,C,sense_B\n10,20,30,45,90,1\n10,20,30,45,90,-1\n")
    out = tmp_path / "out.csv"
    result = runner.invoke(app, [*args, str(rec), "-o", str(out)])
    assert result.exit_code == 0, result.output
    table = read_csv_table(out, required=["x", "y", "z"])
    up, down = np.column_stack([table.floats(k) for k in "xyz"])
    assert np.linalg.norm(up - down) > 1e-4  # 2 x 5 µrad over ~50 mm


@pytest.mark.parametrize(
    ("preset", "model"),
    [
        ("five-axis-wcbxfzyst", "13"),
        ("five-axis-wcbxfzyst", "84"),
        ("three-axis-xfyz", None),
        ("cmm-moving-bridge", None),
    ],
)
def test_show_states_each_parameters_convention(preset, model):
    """Per parameter: name, unit, what a positive value does, where it is referred to
    (the same fields the table prints), for every preset and model."""
    args = ["machine", "show", preset, "--json"] + (["--model", model] if model else [])
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    doc = json.loads(result.output)
    m = Machine.load(preset, model)
    assert [p["name"] for p in doc["parameters"]] == list(m.parameter_names)
    for p, unit in zip(doc["parameters"], m.parameter_units, strict=True):
        assert p["unit"] == unit
        assert f"+{p['name']}" in p["positive"]
        if p["kind"] == "location":  # the axis line moves or turns in the machine frame
            assert f"axis {p['axis']}" in p["positive"] and "machine frame" in p["positive"]
        else:  # error motions: ISO 230-1, the tool relative to the workpiece
            assert p["positive"].startswith(("the tool deviates by +", "the tool turns by +"))
            assert p["positive"].count("relative to the workpiece") == 1
        assert p["side"] in ("tool", "workpiece")
        assert len(p["reference_point_mm"]) == 3 and p["reference"]


@pytest.mark.parametrize("name", list_presets())
def test_export_writes_a_machine_file_read_back_as_the_preset(name, tmp_path):
    """A user had no way to get a preset's file to edit (issue 18 §3): `mtm machine export`
    writes it, and `--machine FILE` reads it back as the preset, every error model alike."""
    path = tmp_path / f"{name}.yaml"
    res = runner.invoke(app, ["machine", "export", name, "-o", str(path)])
    assert res.exit_code == 0, res.output
    shown = [runner.invoke(app, ["machine", "show", m, "--json"]) for m in (name, str(path))]
    assert json.loads(shown[0].stdout) == json.loads(shown[1].stdout)
    preset = Machine.load(name)
    rng = np.random.default_rng(7)
    for model in preset.spec.error_models:
        a, b = Machine.load(name, model), Machine.load(path, model)
        assert a.parameter_names == b.parameter_names and a.parameter_units == b.parameter_units
        lo, hi = np.array([ax.travel for ax in a.axes.values()]).T
        q = lo + (hi - lo) * rng.random((5, len(lo)))
        theta = rng.normal(size=a.n_params) * a.parameter_scales * 10
        senses = rng.choice([-1.0, 1.0], size=q.shape) if a.chain.has_reversal else None
        np.testing.assert_array_equal(
            a.forward(q, theta, senses=senses), b.forward(q, theta, senses=senses)
        )


def test_export_refuses_an_unknown_preset_and_writes_nothing(tmp_path):
    path = tmp_path / "m.yaml"
    res = runner.invoke(app, ["machine", "export", "no-such-machine", "-o", str(path)])
    assert res.exit_code == 2
    assert res.output.startswith("error: no-such-machine: not a preset (presets: ")
    assert not path.exists()
