"""mtm export: files and check.json written; bad input refused in one line, nothing written."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.export.emulation import emulate
from mtmetrology.export.manifest import MANIFEST
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet

runner = CliRunner()


@pytest.fixture(scope="module")
def params(tmp_path_factory):
    """Three-axis preset: every parameter 5 (customary units), u = 0.3."""
    m = Machine.load("three-axis-xfyz")
    rng = np.random.default_rng(7)
    theta = rng.normal(0, 5.0, m.n_params) * m.parameter_scales
    cov = np.diag((0.3 * m.parameter_scales) ** 2)
    path = tmp_path_factory.mktemp("export") / "params.json"
    ParameterSet(
        m.parameter_names, theta, m.parameter_units, cov, machine=m.name, model=m.model_name
    ).save(path)
    return path


def _run(*args):
    return runner.invoke(app, ["export", *map(str, args)])


def test_export_writes_the_files_and_a_check_that_equals_the_library_result(params, tmp_path):
    res = _run(
        "linuxcnc",
        params,
        "--machine",
        "three-axis-xfyz",
        "--pitch",
        10,
        "--bound",
        1,
        "-o",
        tmp_path,
        "--json",
    )
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert json.loads((tmp_path / "check.json").read_text()) == doc
    written = [*doc["files"], "check.json"]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([*written, MANIFEST])
    assert json.loads((tmp_path / MANIFEST).read_text())["files"] == sorted(written)
    assert doc["residual"]["max_um"] < doc["residual"]["uncompensated_max_um"]
    assert doc["advisor"]["met"] and doc["advisor"]["interpolation_error_um"] <= 1
    files = {p.name: p.read_text() for p in tmp_path.iterdir()}
    tables = emulate("linuxcnc", files, Machine.load("three-axis-xfyz")).tables
    assert [t.function for t in tables] == ["E_XX", "E_YY", "E_ZZ"]
    assert all(
        t.positions.size == row["points"] for t, row in zip(tables, doc["tables"], strict=True)
    )


@pytest.mark.parametrize(
    ("args", "field"),
    [
        (["linuxcnc", "--pitch", 1000], "pitch: 1000 mm is larger than the travel of X"),
        (
            ["linuxcnc", "--pitch", 1],
            "--pitch 1: E_XX: 401 points; format linuxcnc accepts at most 256",
        ),
        (
            ["siemens", "--points", 300],
            "--points 300: E_XX: 300 points; format siemens accepts at most 200",
        ),
        (["linuxcnc", "--pitch", 10, "--functions", "E_AX"], "E_AX: format linuxcnc cannot"),
        (["siemens", "--pitch", 10, "--functions", "E_CZ"], "E_CZ: format siemens cannot"),
        (["heidenhain", "--pitch", 10], "format: 'heidenhain' is not one of"),
        (["linuxcnc", "--pitch", 10, "--axes", "Q"], "axes: Q is not an axis"),
        (["grid", "--pitch", 50, "--region", "X=700:1000"], "grid: x from 700 to 1000 mm is"),
    ],
)
def test_bad_input_is_one_line_exit_2_and_nothing_written(params, tmp_path, args, field):
    fmt, *rest = args
    res = _run(fmt, params, "--machine", "three-axis-xfyz", *rest, "-o", tmp_path)
    assert res.exit_code == 2
    message = res.stderr.strip()
    assert "\n" not in message and message.startswith(f"error: {field}")
    assert list(tmp_path.iterdir()) == []


def test_parameters_of_another_machine_are_refused(params, tmp_path):
    res = _run("linuxcnc", params, "--machine", "cmm-moving-bridge", "--pitch", 10, "-o", tmp_path)
    assert res.exit_code == 2
    assert "\n" not in res.stderr.strip() and str(params) in res.stderr
    assert list(tmp_path.iterdir()) == []


def test_residual_at_the_users_points_and_the_document_round_trip(params, tmp_path):
    """--at: the residual at the user's readings equals the library's at those readings,
    is written per point, and the check document rebuilds the same result."""
    from mtmetrology.export.workflow import ExportResult, export_compensation
    from mtmetrology.io import read_csv_table

    points = tmp_path / "points.csv"
    points.write_text("X,Y,Z\n900,200,250\n1111,333,377\n")
    out = tmp_path / "out"
    out.mkdir()
    res = _run(
        "siemens",
        params,
        "--machine",
        "three-axis-xfyz",
        "--pitch",
        10,
        "--at",
        points,
        "-o",
        out,
        "--json",
    )
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    m = Machine.load("three-axis-xfyz")
    at = m.readings_from_customary({"X": [900, 1111], "Y": [200, 333], "Z": [250, 377]})
    lib = export_compensation(m, ParameterSet.load(params, m), "siemens", pitch=10, at=at)
    np.testing.assert_allclose(doc["at_points"]["r_um"], lib.at_points["r"], atol=1e-9)
    table = read_csv_table(out / "residual_at.csv")
    np.testing.assert_allclose(table.floats("Uy_um"), lib.at_points["U"][:, 1], atol=1e-4)
    again = ExportResult.from_dict(doc, lib.files)
    assert again.to_dict() == doc
    assert again.files == lib.files


def test_report_shows_the_tables_with_bands_and_the_residual_map(params, tmp_path):
    from mtmetrology.export.workflow import ExportResult

    out = tmp_path / "out"
    out.mkdir()
    report = tmp_path / "export.html"
    res = _run(
        "isg", params, "--machine", "three-axis-xfyz", "--pitch", 20, "-o", out, "--report", report
    )
    assert res.exit_code == 0, res.output
    page = report.read_text()
    # 18 tables in panels of 6, and the residual maps of both senses of travel
    assert page.count("<svg") == 18 // 6 + 2
    doc = json.loads((out / "check.json").read_text())
    assert (
        "Residual after the control applies the tables" in ExportResult.from_dict(doc)._repr_html_()
    )


def test_grid_from_a_map_document_and_from_the_written_grid_csv(params, tmp_path):
    """A volumetric-map document is a source of `mtm export grid`; the written grid CSV is
    itself a source (the vendor grid form): exported again on the same nodes it gives the
    same file and no residual."""
    from mtmetrology.export import grid
    from mtmetrology.kinematics.volumetric_map import VolumetricMap

    m = Machine.load("three-axis-xfyz")
    source = VolumetricMap.from_parameters(
        m, ParameterSet.load(params, m), grid.grid_lines(grid.box(m), 20.0)
    )
    doc_path = tmp_path / "map.json"
    doc_path.write_text(json.dumps(source.to_dict()))
    first, second = tmp_path / "a", tmp_path / "b"
    first.mkdir()
    second.mkdir()
    res = _run("grid", doc_path, "--machine", m.name, "--pitch", 40, "-o", first, "--json")
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert 0 < doc["residual"]["max_um"] < doc["residual"]["uncompensated_max_um"]
    csv = first / "volumetric_grid.csv"
    res = _run("grid", csv, "--machine", m.name, "--pitch", 40, "-o", second, "--json")
    assert res.exit_code == 0, res.output
    again = json.loads(res.stdout)
    assert again["residual"]["max_um"] == pytest.approx(0.0, abs=1e-9)
    assert (second / "volumetric_grid.csv").read_text() == csv.read_text()


def _export_command(name):
    import typer

    from mtmetrology.cli import build_app

    return typer.main.get_command(build_app()).commands["export"].commands[name]


@pytest.mark.parametrize(
    ("fmt", "files", "own"),
    [
        ("linuxcnc", "x.comp", {"axes", "functions", "bound"}),
        ("fanuc", "fanuc_pitch.txt", {"axes", "functions", "bound", "reference"}),
        ("siemens", "ENC_COMP.INI", {"axes", "functions", "bound"}),
        ("isg", "volcomp.csv", {"axes", "functions", "bound"}),
        ("etalon", "volcomp.exc", {"axes", "functions", "bound"}),
        ("grid", "volumetric_grid.csv", {"region"}),
    ],
)
def test_each_format_has_its_own_help_and_options(fmt, files, own):
    """`mtm export FORMAT --help` is the format's: what it writes, that one of --pitch and
    --points is required, and only the options that apply to it (issue 29)."""
    command = _export_command(fmt)
    paragraphs = command.help.split("\n\n")
    assert files in paragraphs[1]
    assert paragraphs[-1].startswith("Exactly one of --pitch and --points is required.")
    specific = {"axes", "functions", "bound", "reference", "region"}
    shown = {p.name for p in command.params if not getattr(p, "hidden", False)}
    assert shown & specific == own
    assert {"pitch", "points", "force", "verify_program", "output"} <= shown
    res = runner.invoke(app, ["export", fmt, "--help"])
    assert res.exit_code == 0 and files in res.stdout


def test_the_export_help_lists_the_formats_and_says_why_not_heidenhain():
    import typer

    from mtmetrology.cli import build_app

    group = typer.main.get_command(build_app()).commands["export"]
    assert list(group.commands) == [
        "linuxcnc",
        "fanuc",
        "siemens",
        "isg",
        "etalon",
        "grid",
        "check",
    ]
    assert group.help.split("\n\n")[-1].startswith("Heidenhain is not written")


def test_an_option_of_another_format_is_refused(params, tmp_path):
    out = tmp_path / "out"
    res = _run(
        "linuxcnc",
        params,
        "--machine",
        "three-axis-xfyz",
        "--pitch",
        10,
        "--region",
        "x=800:1000",
        "-o",
        out,
    )
    assert res.exit_code == 2
    assert res.stderr.strip() == "error: --region: does not apply to the linuxcnc format"
    assert not out.exists()


def _names(directory):
    return sorted(p.name for p in directory.iterdir())


def test_re_export_leaves_exactly_the_new_files(params, tmp_path):
    """A previous three-axis run wrote x.comp, y.comp, z.comp; a re-export of X only into
    the same directory is refused without --force and with --force leaves exactly the new
    files (no stale y.comp, z.comp)."""
    out = tmp_path / "out"  # created by the export
    args = [params, "--machine", "three-axis-xfyz", "--pitch", 10, "-o", out]
    assert _run("linuxcnc", *args).exit_code == 0
    first = {n: (out / n).read_bytes() for n in _names(out)}
    assert {"x.comp", "y.comp", "z.comp"} <= set(first)
    res = _run("linuxcnc", *args, "--axes", "X")
    assert res.exit_code == 2 and "--force replaces them" in res.stderr
    assert {n: (out / n).read_bytes() for n in _names(out)} == first
    res = _run("linuxcnc", *args, "--axes", "X", "--force", "--json")
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    new = sorted([*doc["files"], "check.json"])
    assert _names(out) == sorted([*new, MANIFEST])
    assert "y.comp" not in new and "z.comp" not in new
    manifest = json.loads((out / MANIFEST).read_text())
    assert manifest["files"] == new and manifest["format"] == "linuxcnc"


@pytest.mark.parametrize("force", [False, True])
def test_a_foreign_file_blocks_the_export_and_survives(params, tmp_path, force):
    """A directory holding a file no export manifest lists is refused, with or without
    --force (an export is never mixed with foreign files); nothing is removed or written."""
    out = tmp_path / "out"
    args = [params, "--machine", "three-axis-xfyz", "--pitch", 10, "-o", out]
    assert _run("siemens", *args).exit_code == 0
    (out / "my_notes.txt").write_text("keep me")
    before = {n: (out / n).read_bytes() for n in _names(out)}
    res = _run("siemens", *args, *(["--force"] if force else []))
    assert res.exit_code == 2
    assert res.stderr.startswith(f"error: -o: {out} holds 'my_notes.txt', not written by an export")
    assert {n: (out / n).read_bytes() for n in _names(out)} == before


def test_a_manifest_naming_a_path_outside_the_directory_is_refused(params, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (tmp_path / "precious.txt").write_text("x")
    (out / MANIFEST).write_text(
        json.dumps({"kind": "mtm-export-manifest", "files": ["../precious.txt"]})
    )
    res = _run(
        "linuxcnc", params, "--machine", "three-axis-xfyz", "--pitch", 10, "-o", out, "--force"
    )
    assert res.exit_code == 2
    assert res.stderr.startswith(f"error: {out / MANIFEST}: files[0]: '../precious.txt' is not")
    assert (tmp_path / "precious.txt").exists() and _names(out) == [MANIFEST]


def test_an_output_directory_whose_parent_is_missing_is_refused(params, tmp_path):
    out = tmp_path / "no" / "out"
    res = _run("linuxcnc", params, "--machine", "three-axis-xfyz", "--pitch", 10, "-o", out)
    assert res.exit_code == 2 and res.stderr.startswith("error: -o: ")
    assert not (tmp_path / "no").exists()


def _filled(template: str, column_value) -> str:
    """The template with each line's own-axis reading (a laser along the axis) filled."""
    import csv
    import io

    head = [ln for ln in template.splitlines() if ln.startswith("#")]
    body = "\n".join(ln for ln in template.splitlines() if not ln.startswith("#"))
    reader = csv.DictReader(io.StringIO(body))
    out = io.StringIO()
    w = csv.DictWriter(out, reader.fieldnames, lineterminator="\n")
    w.writeheader()
    for row in reader:
        c = row["axis"].lower()
        row[f"m{c}_um"] = f"{column_value(float(row[f'r{c}_um']), float(row[f'e{c}_um'])):.4f}"
        w.writerow(row)
    return "\n".join(head) + "\n" + out.getvalue()


@pytest.mark.parametrize(
    ("case", "reading", "code"),
    [
        ("confirmed", lambda r, e: r, 0),
        ("sign error", lambda r, e: 2 * e - r, 4),
        ("table not active", lambda r, e: e, 4),
    ],
)
def test_verify_program_then_check(params, tmp_path, case, reading, code):
    """--verify-program writes the programme and the template; `mtm export check` on the
    filled template prints the library's comparison and exits 0 only when confirmed."""
    from mtmetrology.export.verification_check import compare_readings

    out = tmp_path / "out"
    res = _run(
        "fanuc",
        params,
        "--machine",
        "three-axis-xfyz",
        "--pitch",
        20,
        "-o",
        out,
        "--verify-program",
        "--verify-positions",
        4,
    )
    assert res.exit_code == 0, res.output
    assert {"O1029.nc", "verify_readings.csv"} <= set(
        json.loads((out / MANIFEST).read_text())["files"]
    )
    filled = tmp_path / "readings.csv"
    filled.write_text(_filled((out / "verify_readings.csv").read_text(), reading))
    res = runner.invoke(app, ["export", "check", str(filled), "--u-reading", "0.2", "--json"])
    assert res.exit_code == code, res.output
    doc = json.loads(res.stdout)
    assert doc["verdict"] == case
    assert doc == json.loads(json.dumps(compare_readings(filled, 0.2).to_dict()))


def test_check_refuses_a_bad_file_in_one_line(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text("point,axis,rx_um\nX01+,X,1\n")
    res = runner.invoke(app, ["export", "check", str(path)])
    assert res.exit_code == 2
    assert res.stderr.strip().startswith(f"error: {path}: missing column 'ry_um'")


def test_siemens_axis_names_map_the_machine_axes_and_bad_names_are_refused(params, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    args = ["siemens", params, "--machine", "three-axis-xfyz", "--pitch", 20, "-o", out]
    res = _run(*args, "--functions", "E_XX,E_YX", "--axis-names", "X=AX1,Y=AX2,Z=AX3")
    assert res.exit_code == 0, res.output
    enc = (out / "ENC_COMP.INI").read_text().splitlines()
    cec = (out / "CEC.INI").read_text().splitlines()
    assert enc[2].startswith("$AA_ENC_COMP[0,0,AX1]=")
    assert "$AN_CEC_INPUT_AXIS[0]=(AX1)" in cec and "$AN_CEC_OUTPUT_AXIS[0]=(AX2)" in cec
    doc = json.loads((out / "check.json").read_text())
    default = tmp_path / "default"
    default.mkdir()
    args[-1] = default
    assert _run(*args, "--functions", "E_XX,E_YX").exit_code == 0
    # the emulated control reads the renamed axes as the same machine axes
    assert doc["residual"] == json.loads((default / "check.json").read_text())["residual"]
    bad = tmp_path / "bad"
    bad.mkdir()
    args[-1] = bad
    res = _run(*args, "--axis-names", "X=AX1,Y=AX1")
    assert res.exit_code == 2
    assert res.output.strip().splitlines()[-1].startswith("error: --axis-names: two axes share")
    assert list(bad.iterdir()) == []
    res = _run("linuxcnc", *args[1:], "--axis-names", "X=X1")
    assert res.exit_code == 2 and "--axis-names" in res.output
