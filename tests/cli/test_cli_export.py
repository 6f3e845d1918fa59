"""mtm export: files and check.json written; bad input refused in one line, nothing written."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.export.emulation import emulate
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
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([*doc["files"], "check.json"])
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
        (["linuxcnc", "--pitch", 1], "E_XX: 401 points; format linuxcnc accepts at most 256"),
        (["siemens", "--points", 300], "E_XX: 300 points; format siemens accepts at most 200"),
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
