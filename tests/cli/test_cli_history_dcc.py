"""Tests for ``mtm history dcc`` and ``mtm history dcc-import`` (on a SQLite file)."""

from __future__ import annotations

import json
from datetime import date
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.cmm.files import load_plate
from mtmetrology.history.dcc import CalibrationCertificate, coverage_probability
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.samba.artefact import load_artefact

runner = CliRunner()
MACHINE = Machine.load("five-axis-wcbxfzyst")
ISSUER = (
    "--laboratory",
    "Lab A",
    "--email",
    "lab@example.org",
    "--country",
    "DE",
    "--responsible-person",
    "A. Person",
    "--manufacturer",
    "Maker GmbH",
)


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
        (("1", "--country", "DE", "--laboratory", " "), "--laboratory: empty"),
        (("1", "--country", "DE", "--email", "lab@x"), "--email 'lab@x': not an e-mail"),
    ):
        issuer = ("--laboratory", "L", "--email", "e@x.org", "--responsible-person", "P")
        issuer += ("--manufacturer", "M")
        r = _mtm("history", "dcc", *issuer, *args, "-o", cert, "--db", db)
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
    assert r.exit_code == 2 and r.stderr.strip() == (
        "error: SB-2026-001: 2 quantities certified (L, T); a scale bar's certificate has "
        "one: name it with --quantity"
    )
    r = _mtm("history", "dcc-import", cert, "--scale-bar", artefact, "--quantity", "L", "-o", out)
    assert r.exit_code == 0, r.output
    updated = load_artefact(out)
    assert updated.scale_bar.length_mm == pytest.approx(305.2105, rel=1e-15)
    assert updated.scale_bar.u_mm == pytest.approx(0.0012, rel=1e-12)  # U/k = 2.4 µm / 2
    assert updated.scale_bar.ends == ("SB1", "SB2")
    r = _mtm("history", "dcc-import", cert, "--scale-bar", artefact, "--quantity", "T")
    assert r.exit_code == 2 and "--quantity 'T': not a length" in r.stderr


def test_a_ball_plate_certificate_sets_the_centres_and_their_covariance(tmp_path):
    rng = np.random.default_rng(11)
    ids = ["00", "01", "02"]
    names = [f"{b}_{a}" for b in ids for a in "xyz"]
    order = rng.permutation(9)  # the certificate lists the coordinates in another order
    centres_mm = rng.uniform(0.0, 500.0, 9)
    a = rng.normal(size=(9, 9))
    cov_mm2 = (a @ a.T / 9 + np.eye(9)) * 1e-7
    to_m = 1e-3
    cert = CalibrationCertificate(
        identifier="BP-7",
        item="ball plate",
        laboratory="Reference Lab",
        email="ref@example.org",
        country="FR",
        begin=date(2026, 2, 1),
        end=date(2026, 2, 1),
        software_version="1",
        result="centres",
        names=tuple(names[i] for i in order),
        units=("m",) * 9,
        values=tuple(centres_mm[order] * to_m),
        u=tuple(np.sqrt(np.diag(cov_mm2))[order] * to_m),
        covariance=tuple(map(tuple, cov_mm2[np.ix_(order, order)] * to_m**2)),
        coverage_factor=2.0,
        coverage_probability=coverage_probability(2.0),
    )
    xml = tmp_path / "BP.xml"
    xml.write_bytes(cert.to_xml())
    plate = tmp_path / "plate.yaml"
    plate.write_text(
        "kind: ball-plate\nballs:\n"
        + "".join(f"  - {{id: '{b}', x_mm: 0.0, y_mm: 0.0, z_mm: 0.0}}\n" for b in ids)
        + "u_mm: 0.0005\n"
    )
    out = tmp_path / "plate_cal.json"
    r = _mtm("history", "dcc-import", xml, "--ball-plate", plate, "-o", out)
    assert r.exit_code == 0, r.output
    loaded = load_plate(out)
    got = [c for ball in loaded.balls for c in (ball.x_mm, ball.y_mm, ball.z_mm)]
    np.testing.assert_allclose(got, centres_mm, rtol=1e-13)
    np.testing.assert_allclose(loaded.covariance_mm2, cov_mm2, rtol=1e-12)
    plate.write_text(plate.read_text().replace("'02'", "'09'"))
    r = _mtm("history", "dcc-import", xml, "--ball-plate", plate, "-o", out)
    assert r.exit_code == 2 and "ball '09': no quantity '09_x'" in r.stderr


def test_dcc_command_states_the_13_parameter_region_with_its_own_k(tmp_path):
    """``mtm history dcc``: the ellipsoidalRegionXMLList of the 13 parameters states
    p = 2 Φ(2) − 1 with k = sqrt(χ²_13⁻¹(p)) ≈ 4.76 (was k = 2, which covers 0.9 %)."""
    from lxml import etree
    from scipy.stats import chi2

    db, _, _ = _recorded(tmp_path)
    cert = tmp_path / "c.xml"
    r = _mtm("history", "dcc", "1", "-o", cert, "--db", db, *ISSUER)
    assert r.exit_code == 0, r.output
    ns = {"si": "https://ptb.de/si"}
    region = etree.parse(str(cert)).find(".//si:ellipsoidalRegionXMLList", ns)
    k = float(region.find("si:coverageFactor", ns).text)
    p = float(region.find("si:coverageProbability", ns).text)
    assert len(region.findall("si:covarianceMatrix/si:column", ns)) == 13
    assert p == pytest.approx(coverage_probability(2.0), abs=1e-12)
    assert chi2.cdf(k**2, 13) == pytest.approx(p, abs=1e-6)
    assert k == pytest.approx(4.76, abs=0.005)
