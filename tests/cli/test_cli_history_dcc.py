"""Tests for ``mtm history dcc`` and ``mtm history dcc-import`` (on a SQLite file)."""

from __future__ import annotations

import json
from datetime import date
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.history.dcc import CalibrationCertificate, coverage_probability
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.samba.artefact import load_artefact

runner = CliRunner()
MACHINE = Machine.load("five-axis-wcbxfzyst")
ISSUER = ("--laboratory", "Lab A", "--email", "lab@example.org", "--country", "DE")


def _mtm(*args):
    return runner.invoke(app, [str(a) for a in args])


def _recorded(tmp_path):
    values = np.random.default_rng(5).normal(size=13)
    u = np.linspace(0.2, 0.8, 13)
    path = tmp_path / "cal.json"
    ParameterSet(
        MACHINE.parameter_names,
        values * MACHINE.parameter_scales,
        MACHINE.parameter_units,
        np.diag((u * MACHINE.parameter_scales) ** 2),
        machine=MACHINE.name,
        model="13",
    ).save(path)
    db = tmp_path / "h.sqlite"
    assert _mtm("history", "add", path, "--db", db).exit_code == 0
    return db, values, u


def test_dcc_export_then_import_gives_the_run_values_and_u(tmp_path):
    db, values, u = _recorded(tmp_path)
    cert = tmp_path / "CERT.xml"
    r = _mtm("history", "dcc", "1", "-o", cert, "--db", db, *ISSUER, "--coverage-factor", "3")
    assert r.exit_code == 0, r.output
    out = tmp_path / "values.json"
    r = _mtm("history", "dcc-import", cert, "-o", out)
    assert r.exit_code == 0, r.output
    doc = json.loads(out.read_text())
    assert doc["kind"] == "calibration-certificate" and doc["coverage_factor"] == 3.0
    # customary µm, µrad, µm/m -> SI m, rad, 1: each a factor 1e-6
    assert [e["unit"] for e in doc["quantities"]] == [
        {"µm": "m", "µrad": "rad", "µm/m": "1"}[unit] for unit in MACHINE.parameter_units
    ]
    si = 1e-6
    np.testing.assert_allclose([e["value"] for e in doc["quantities"]], values * si, rtol=1e-13)
    np.testing.assert_allclose([e["u"] for e in doc["quantities"]], u * si, rtol=1e-13)
    np.testing.assert_allclose(np.diag(doc["covariance"]), (u * si) ** 2, rtol=1e-13)


def test_dcc_bad_input_is_one_line_exit_2_and_nothing_written(tmp_path):
    db, _, _ = _recorded(tmp_path)
    cert = tmp_path / "CERT.xml"
    for args, expected in (
        (("1", "--country", "Germany"), "--country 'Germany'"),
        (("7", "--country", "DE"), "run 7: no calibration run"),
        (("1", "--country", "DE", "--coverage-factor", "0.5"), "--coverage-factor 0.5"),
    ):
        issuer = ("--laboratory", "L", "--email", "e@x")
        r = _mtm("history", "dcc", *args, *issuer, "-o", cert, "--db", db)
        assert r.exit_code == 2
        assert len(r.stderr.strip().splitlines()) == 1
        assert expected in r.stderr
        assert not cert.exists()
    bad = tmp_path / "bad.xml"
    bad.write_text("<dcc/>")
    r = _mtm("history", "dcc-import", bad)
    assert r.exit_code == 2 and "bad.xml: line 1: not a valid DCC" in r.stderr


def _scale_bar_certificate(tmp_path) -> Path:
    cert = CalibrationCertificate(
        identifier="SB-2026-001",
        item="scale bar SB-305",
        laboratory="Reference Lab",
        email="ref@example.org",
        country="CH",
        begin=date(2026, 1, 12),
        end=date(2026, 1, 13),
        software_version="1",
        result="length",
        names=("L", "T"),
        units=("m", "rad"),
        values=(0.3052105, 1e-3),
        u=(1.2e-6, 1e-6),
        covariance=((1.44e-12, 0.0), (0.0, 1e-12)),
        coverage_factor=2.0,
        coverage_probability=coverage_probability(2.0),
    )
    path = tmp_path / "SB.xml"
    path.write_bytes(cert.to_xml())
    return path


def test_a_scale_bar_certificate_sets_the_samba_artefact_length_and_u(tmp_path):
    artefact = tmp_path / "samba.yaml"
    artefact.write_text(
        "kind: samba-artefact\nballs:\n  - {id: SB1, diameter_mm: 12.7}\n"
        "  - {id: SB2, diameter_mm: 12.7}\n"
        "scale_bar: {ends: [SB1, SB2], length_mm: 305.0, u_mm: 0.01}\n"
        "stylus_tip_diameter_mm: 5.925\n"
    )
    out = tmp_path / "samba_cal.json"
    cert = _scale_bar_certificate(tmp_path)
    r = _mtm("history", "dcc-import", cert, "--scale-bar", artefact, "-o", out)
    assert r.exit_code == 0, r.output
    updated = load_artefact(out)
    assert updated.scale_bar.length_mm == pytest.approx(305.2105, rel=1e-15)
    assert updated.scale_bar.u_mm == pytest.approx(0.0012, rel=1e-12)  # U/k = 2.4 µm / 2
    assert updated.scale_bar.ends == ("SB1", "SB2")
    r = _mtm("history", "dcc-import", cert, "--scale-bar", artefact, "--quantity", "T")
    assert r.exit_code == 2 and "--quantity 'T': not a length" in r.stderr
