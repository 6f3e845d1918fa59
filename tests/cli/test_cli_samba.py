"""``mtm samba simulate``, ``mtm samba calibrate``, ``mtm length simulate`` and ``mtm length
verify`` end to end through typer's CliRunner, with the example files of examples/samba."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app

runner = CliRunner()
EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "samba"
MACHINE = "five-axis-wcbxfzyst"
SIMULATE = (
    "--machine",
    MACHINE,
    "--truth",
    EXAMPLES / "truth.json",
    "--artefact",
    EXAMPLES / "artefact.yaml",
    "--balls",
    EXAMPLES / "balls.yaml",
    "--poses",
    EXAMPLES / "poses.csv",
)


def mtm(*args):
    return runner.invoke(app, [str(a) for a in args])


def calibrate_samba(records, *args):
    """``mtm samba calibrate RECORDS`` on the example machine and artefact."""
    return mtm(
        "samba",
        "calibrate",
        records,
        "--machine",
        MACHINE,
        "--artefact",
        EXAMPLES / "artefact.yaml",
        *args,
    )


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("cli")
    path = tmp / "records.csv"
    result = mtm(
        "samba",
        "simulate",
        *SIMULATE,
        "--model",
        "13",
        "--noise-um",
        "0.5",
        "--seed",
        "1",
        "-o",
        path,
    )
    assert result.exit_code == 0, result.output
    return path


@pytest.fixture(scope="module")
def calibrated(records):
    out = records.parent / "result.json"
    result = calibrate_samba(
        records,
        "--noise-um",
        "0.5",
        "--estimate-tool",
        "--uncertainty",
        "both",
        "--trials",
        "4000",
        "--seed",
        "3",
        "--json",
        "-o",
        out,
    )
    assert result.exit_code == 0, result.output
    return out, json.loads(result.stdout)


def test_calibrate_writes_the_result_it_prints_with_validated_uncertainty(calibrated):
    path, doc = calibrated
    assert json.loads(path.read_text(encoding="utf-8")) == doc
    assert doc["kind"] == "samba-calibration" and doc["identification"]["rank"] == 34
    truth = {
        p["name"]: p["value"]
        for p in json.loads((EXAMPLES / "truth.json").read_text(encoding="utf-8"))["parameters"]
    }
    for p in doc["parameters"]:
        assert abs(p["value"] - truth[p["name"]]) < 3 * p["u"]
    unc = doc["uncertainty"]
    assert {o["name"] for o in unc["guf"]["outputs"]} == set(truth)
    out = unc["mcm"]["outputs"][0]
    assert set(out) == {"name", "value", "unit", "u", "U", "k", "p", "interval"}
    assert unc["validation"]["passed"] and len(unc["validation"]["table"]) == 15
    assert doc["covariance_source"] == "guf"
    assert (unc["mcm"]["trials"], unc["mcm"]["sequences"], unc["mcm"]["adaptive"]) == (
        4000,
        1,
        False,
    )


def test_predict_reads_the_result_as_it_is(calibrated, records, tmp_path):
    path, doc = calibrated
    out = tmp_path / "xyz.csv"
    result = mtm("predict", "--machine", MACHINE, "--params", path, records, "-o", out)
    assert result.exit_code == 0, result.output
    lines = out.read_text(encoding="utf-8").splitlines()
    assert lines[0].endswith("x,y,z") and len(lines) == 112
    # the compensated centre of ball 1 at B = C = 0 is the identified ball centre
    x = np.array([float(v) for v in lines[1].split(",")[-3:]])
    centre = next(b["centre_mm"] for b in doc["balls"] if b["id"] == "1")
    assert np.allclose(x, centre, atol=0.003)


def test_length_check_after_calibration(calibrated, tmp_path):
    path, _ = calibrated
    gauge = tmp_path / "gauge.csv"
    result = mtm(
        "length",
        "simulate",
        "--machine",
        MACHINE,
        "--truth",
        EXAMPLES / "truth.json",
        "--end-a",
        "-100,-100,40",
        "--end-b",
        "100,100,40",
        "--pairs",
        "20",
        "--seed",
        "5",
        "-o",
        gauge,
    )
    assert result.exit_code == 0, result.output
    length = float(np.hypot(200.0, 200.0))
    result = mtm(
        "length",
        "verify",
        gauge,
        "--machine",
        MACHINE,
        "--params",
        path,
        "--length",
        f"{length:.9f}",
        "--u-length",
        "0.0005",
        "--json",
    )
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["kind"] == "length-check" and len(doc["pairs"]) == 20
    assert doc["compensated"]["rms"] < 0.05 * doc["nominal"]["rms"]


def test_raw_points_and_campaigns_from_simulate_are_read_by_calibrate(tmp_path):
    raw = tmp_path / "raw.csv"
    common = (*SIMULATE, "--seed", "2")
    assert mtm("samba", "simulate", *common, "--raw-points", "-o", raw).exit_code == 0
    camp = tmp_path / "campaigns.csv"
    assert mtm("samba", "simulate", *common, "--campaigns", "5", "-o", camp).exit_code == 0
    for path, form, k, extra in (
        (raw, "raw-points", 1, ()),
        (camp, "centres", 5, ("--uncertainty", "guf")),
    ):
        result = calibrate_samba(
            path,
            "--estimate-tool",
            "--json",
            *extra,
        )
        assert result.exit_code == 0, result.output
        doc = json.loads(result.stdout)
        assert doc["records"]["form"] == form and doc["records"]["campaigns"] == k
    assert "campaigns" in doc["uncertainty"]["input_covariance"]


def test_help_documents_the_file_formats():
    """The help names the record forms and points to ``mtm formats samba-calibration``,
    which prints the full formats from the package (moved out of the help: issue 18 §3;
    reachable without the docs: issue 31)."""
    text = mtm("samba", "calibrate", "--help").output
    for fmt in (
        "ball,X,Y,Z,B,C[,S]",
        "measurement,ball,X,Y,Z,B,C",
        "mtm formats samba-calibration",
    ):
        assert fmt in text
    section = mtm("formats", "samba-calibration").output
    for fmt in ("`ball,X,Y,Z,B,C[,S]`", "`campaign,...`", '"kind": "samba-repeatability"'):
        assert fmt in section
    assert "samba-balls" in mtm("samba", "simulate", "--help").output
    assert "pair,end,X,Y,Z,B,C" in mtm("length", "verify", "--help").output


def _bad_records(records, tmp_path, edit):
    lines = records.read_text(encoding="utf-8").splitlines()
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(edit(lines)) + "\n", encoding="utf-8")
    return path


@pytest.mark.parametrize(
    ("edit", "extra", "expected"),
    [
        (
            lambda ls: [ls[0], *(ln for ln in ls[1:] if not ln.startswith("4,")), ls[4]],
            (),
            "probed only once",
        ),
        (lambda ls: [ln for ln in ls if not ln.startswith("SB")], (), "never probed"),
        (lambda ls: ls, ("--params-only", "E_X0C,E_FOO1"), "E_FOO1"),
        (
            lambda ls: [
                ls[0],
                ls[1].replace(",0.000000,0.000000,0.000000", ",95.0,0.0,0.0"),
                *ls[2:],
            ],
            (),
            "outside the travel",
        ),
        (lambda ls: [ls[0], "1,nan,0,0,0,0,0", *ls[2:]], (), "line 2"),
    ],
    ids=["ball-once", "bar-never-probed", "unknown-parameter", "outside-travel", "nan"],
)
def test_bad_input_is_one_line_exit_2_and_no_result(records, tmp_path, edit, extra, expected):
    path = _bad_records(records, tmp_path, edit)
    out = tmp_path / "RESULT.json"
    result = calibrate_samba(
        path,
        *extra,
        "-o",
        out,
    )
    assert result.exit_code == 2
    assert result.output.startswith("error: ") and result.output.count("\n") == 1
    assert expected in result.output
    assert not out.exists()


def test_a_unit_that_does_not_fit_is_refused_and_nothing_written(tmp_path):
    truth = json.loads((EXAMPLES / "truth.json").read_text(encoding="utf-8"))
    truth["parameters"][2]["unit"] = "µrad"  # E_X0C is a length
    bad = tmp_path / "truth.json"
    bad.write_text(json.dumps(truth), encoding="utf-8")
    out = tmp_path / "records.csv"
    result = mtm(
        "samba",
        "simulate",
        "--machine",
        MACHINE,
        "--truth",
        bad,
        "--artefact",
        EXAMPLES / "artefact.yaml",
        "--balls",
        EXAMPLES / "balls.yaml",
        "--poses",
        EXAMPLES / "poses.csv",
        "-o",
        out,
    )
    assert result.exit_code == 2
    # the file, the field (index and parameter name), the unit given and the one expected
    assert result.output == (
        f"error: {bad}: parameters[2] (E_X0C): unit 'µrad' does not fit this parameter "
        "(expected a unit like 'µm')\n"
    )
    assert not out.exists()


def test_rank_deficiency_names_the_confounded_parameters_and_min_norm_flags(records, tmp_path):
    lines = records.read_text(encoding="utf-8").splitlines()
    no_spindle = [
        ln for ln in lines if not ln.endswith((",90.000000", ",180.000000", ",270.000000"))
    ]
    path = tmp_path / "nospindle.csv"
    path.write_text("\n".join(no_spindle) + "\n", encoding="utf-8")
    result = calibrate_samba(path, "--estimate-tool")
    assert result.exit_code == 2 and "tool x" in result.output and "E_X0S" in result.output
    assert "spindle indexing" in result.output
    result = calibrate_samba(path, "--estimate-tool", "--min-norm", "--json")
    assert result.exit_code == 0
    assert json.loads(result.stdout)["identification"]["minimum_norm"] is True


def test_repeatability_file_is_strict(records, tmp_path):
    bad = tmp_path / "rep.json"
    bad.write_text(
        '{"kind": "samba-repeatability", "version": 1, "u_um": {"X": 0.4, "Y": 0.5}}',
        encoding="utf-8",
    )
    result = calibrate_samba(
        records,
        "--repeatability",
        bad,
    )
    assert result.exit_code == 2 and "u_um" in result.output
    result = calibrate_samba(
        records,
        "--repeatability",
        EXAMPLES / "repeatability.json",
        "--estimate-tool",
        "--json",
    )
    assert result.exit_code == 0, result.output
    assert "repeatability" in json.loads(result.stdout)["records"]["input_covariance"]


def test_noise_of_k_campaigns_is_the_noise_of_their_mean(tmp_path):
    """--noise-um σ with K campaigns: the indications are means, so the probing part of
    u(θ) scales as σ/√K; the scale gains keep the share of the scale bar's u, which no
    repetition averages."""
    common = (*SIMULATE, "--seed", "4")
    one, four = tmp_path / "one.csv", tmp_path / "four.csv"
    assert mtm("samba", "simulate", *common, "-o", one).exit_code == 0
    assert mtm("samba", "simulate", *common, "--campaigns", "4", "-o", four).exit_code == 0
    u = {}
    for name, path in (("one", one), ("four", four)):
        result = calibrate_samba(path, "--noise-um", "0.5", "--uncertainty", "guf", "--json")
        assert result.exit_code == 0, result.output
        doc = json.loads(result.stdout)
        u[name] = {p["name"]: p["u"] for p in doc["parameters"]}
    gains = {"E_XX1", "E_YY1", "E_ZZ1"}
    for name, u_one in u["one"].items():
        ratio = u["four"][name] / u_one
        if name in gains:
            assert 0.5 < ratio < 1.0, name
        else:
            assert abs(ratio - 0.5) < 0.01, name


def test_tool_prior_is_recorded_and_pulls_the_tool_towards_the_nominal(records, tmp_path):
    """``--tool-prior-um`` as one value and as a per-axis triple: RESULT.json lists the
    prior (value = the machine's nominal tool, u in mm) and the tool estimate moves towards
    the nominal; a 1 mm prior (Alami Mchichi 2018) leaves the tool as the data give it."""
    docs = {}
    for prior in (None, "0.05", "0.1,0.1,0.05", "1000"):
        out = tmp_path / f"result-{prior}.json"
        extra = () if prior is None else ("--tool-prior-um", prior)
        result = calibrate_samba(records, "--noise-um", "0.5", "--estimate-tool", *extra, "-o", out)
        assert result.exit_code == 0, result.output
        docs[prior] = json.loads(out.read_text(encoding="utf-8"))
    nominal = np.array([p["value"] for p in docs["0.05"]["priors"]])
    assert docs[None]["priors"] == []
    assert [p["u"] for p in docs["0.1,0.1,0.05"]["priors"]] == pytest.approx([1e-4, 1e-4, 5e-5])
    assert [p["name"] for p in docs["1000"]["priors"]] == ["tool x", "tool y", "tool z"]
    free = np.array(docs[None]["tool_mm"]) - nominal
    for prior in ("0.05", "0.1,0.1,0.05"):
        pulled = np.array(docs[prior]["tool_mm"]) - nominal
        assert np.all(np.abs(pulled) < np.abs(free))
    np.testing.assert_allclose(docs["1000"]["tool_mm"], docs[None]["tool_mm"], rtol=0, atol=1e-9)


@pytest.mark.parametrize(
    "extra",
    [
        ("--estimate-tool", "--tool-prior-um", "0"),
        ("--estimate-tool", "--tool-prior-um", "-1"),
        ("--estimate-tool", "--tool-prior-um", "nan"),
        ("--estimate-tool", "--tool-prior-um", "1,2"),
        ("--estimate-tool", "--tool-prior-um", "one"),
        ("--tool-prior-um", "1000"),
    ],
    ids=["zero", "negative", "nan", "two-values", "not-a-number", "without-estimate-tool"],
)
def test_bad_tool_prior_is_one_line_exit_2_and_no_result(records, tmp_path, extra):
    out = tmp_path / "RESULT.json"
    result = calibrate_samba(records, *extra, "-o", out)
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: --tool-prior-um")
    assert not out.exists()


def test_predict_compensates_with_the_identified_tool_and_gives_u(calibrated, records, tmp_path):
    """The calibration's tool_mm (--estimate-tool) is the tool of the compensation, and
    --u appends √diag(G U_θ Gᵀ): a covariance four times larger doubles every u."""
    from mtmetrology.kinematics import Machine
    from mtmetrology.kinematics.parameter_set import ParameterSet

    path, doc = calibrated
    base = Machine.load(MACHINE)
    pset = ParameterSet.load(path, base)
    m = pset.machine_for(base)
    np.testing.assert_allclose(m.tool, doc["tool_mm"], rtol=0, atol=1e-12)
    out = tmp_path / "xyz.csv"
    result = mtm("predict", "--machine", MACHINE, "--params", path, records, "--u", "-o", out)
    assert result.exit_code == 0, result.output
    lines = out.read_text(encoding="utf-8").splitlines()
    assert lines[0].endswith("x,y,z,u_x_um,u_y_um,u_z_um")
    first = np.array([float(v) for v in lines[1].split(",")[-6:]])
    header = lines[0].split(",")
    row = dict(zip(header, lines[1].split(","), strict=True))
    q = m.readings_from_customary({a: [float(row[a])] for a in m.axis_names if a in row})
    expected = m.forward(q, pset.vector_for(m), tool=np.array(doc["tool_mm"]))[0]
    np.testing.assert_allclose(first[:3], expected, rtol=0, atol=1e-6)
    assert np.all(first[3:] > 0)
    doc4 = json.loads(path.read_text(encoding="utf-8"))
    doc4["covariance"]["matrix"] = (4 * np.array(doc4["covariance"]["matrix"])).tolist()
    path4 = tmp_path / "result4.json"
    path4.write_text(json.dumps(doc4), encoding="utf-8")
    out4 = tmp_path / "xyz4.csv"
    again = mtm("predict", "--machine", MACHINE, "--params", path4, records, "--u", "-o", out4)
    assert again.exit_code == 0, again.output
    row4 = np.array([float(v) for v in out4.read_text().splitlines()[1].split(",")[-3:]])
    np.testing.assert_allclose(row4, 2 * first[3:], rtol=1e-5)


def test_one_coverage_factor_in_console_json_and_report(records, tmp_path):
    """The console printed ``E_A0B -9.5874 ± 1.8433 µrad`` with ± = u, the JSON k = 1.96 and
    the HTML parameter table k = 2 (issue 18 §3). Now: ``u = …`` and ``U = … (k = 2)`` with
    two significant digits and one k, the policy's k = 2 (p = 2 Φ(2) − 1, issue 31), in all
    three, and the GUF's k for that p is 2 as well."""
    import re

    from scipy import stats

    from mtmetrology.formatting import format_uncertainty

    out, page = tmp_path / "r.json", tmp_path / "r.html"
    result = calibrate_samba(
        records, "--noise-um", "0.5", "--uncertainty", "guf", "-o", out, "--report", page
    )
    assert result.exit_code == 0, result.output
    doc = json.loads(out.read_text(encoding="utf-8"))
    k = doc["coverage"]["k"]
    p = doc["coverage"]["coverage_probability"]
    assert k == 2.0 and p == pytest.approx(2 * stats.norm.cdf(2.0) - 1, abs=1e-12)
    assert all(o["k"] == pytest.approx(k, abs=1e-9) for o in doc["uncertainty"]["guf"]["outputs"])
    assert "±" not in result.stdout
    assert "U = k u (k = 2, p ≈ 95.45 %)" in result.stdout.splitlines()[1]
    line = re.compile(r"^  (\S+) +(\S+) (\S+) +u = (\S+) (\S+)  U = (\S+) (\S+) \(k = 2\)$")
    printed = {m[1]: m for m in map(line.match, result.stdout.splitlines()) if m}
    assert list(printed) == [p["name"] for p in doc["parameters"]]
    for p in doc["parameters"]:
        m = printed[p["name"]]
        assert m[3] == m[5] == m[7] == p["unit"]
        assert m[4] == format_uncertainty(p["u"]) and m[6] == format_uncertainty(k * p["u"])
        assert len(m[4].replace(".", "").lstrip("0")) == 2  # two significant digits
    html = page.read_text(encoding="utf-8")
    heads = re.findall(r"<th scope=\"col\">(.*?)</th>", html)
    assert "U (k = 2)" in heads and not any(h.startswith("U (k = 1.96") for h in heads)


def test_coverage_option_sets_k_everywhere(records, tmp_path):
    """--p 0.95 gives k = Φ⁻¹(0.975) = 1.96 in the JSON, the GUF outputs and the console;
    --k with --p, or --k 0, is refused (exit 2) and writes nothing."""
    out = tmp_path / "r.json"
    common = (records, "--noise-um", "0.5", "--uncertainty", "guf", "-o", out)
    result = calibrate_samba(*common, "--p", "0.95")
    assert result.exit_code == 0, result.output
    doc = json.loads(out.read_text(encoding="utf-8"))
    assert doc["coverage"]["k"] == pytest.approx(1.959964, abs=1e-6)
    assert doc["coverage"]["stated"] == "p"
    assert all(o["p"] == 0.95 for o in doc["uncertainty"]["guf"]["outputs"])
    assert "(k = 1.96, p ≈ 95 %)" in result.stdout.splitlines()[1]
    out.unlink()
    for bad in (("--k", "2", "--p", "0.9"), ("--k", "0"), ("--p", "1")):
        refused = calibrate_samba(*common, *bad)
        assert refused.exit_code == 2 and not out.exists(), refused.output


def test_calibrate_history_records_the_written_result(records, tmp_path, monkeypatch):
    """--history: the database's run is the written result, with the inputs' hashes."""
    from mtmetrology.history import list_runs, open_history, show_run

    monkeypatch.setenv("MTMETROLOGY_DB", str(tmp_path / "history.sqlite"))
    out = tmp_path / "result.json"
    result = calibrate_samba(records, "--noise-um", "0.5", "--history", "-o", out)
    assert result.exit_code == 0, result.output
    engine = open_history()
    (run,) = list_runs(engine)
    record = show_run(engine, run.id)
    assert record.result == json.loads(out.read_text())
    assert set(record.input_hashes) == {str(records), str(EXAMPLES / "artefact.yaml")}


def test_the_console_states_the_monte_carlo_trials(calibrated, capsys):
    """The summary names the trial count the result document holds (issue 31: an adaptive
    run of 870 000 trials was silent about it)."""
    from mtmetrology.cli.calibrate import _summary

    _, doc = calibrated
    _summary(doc, None)
    lines = capsys.readouterr().out.splitlines()
    assert "Monte Carlo: 4000 trials in 1 sequence" in lines
    adaptive = json.loads(json.dumps(doc))
    adaptive["uncertainty"]["mcm"].update(
        trials=870_000, sequences=87, adaptive=True, converged=True
    )
    _summary(adaptive, None)
    lines = capsys.readouterr().out.splitlines()
    assert "Monte Carlo: 870000 trials in 87 sequences (adaptive, converged)" in lines
