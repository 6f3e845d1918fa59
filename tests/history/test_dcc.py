"""Digital Calibration Certificate export and import (PTB DCC 3.1.2, D-SI 2.1.0)."""

from __future__ import annotations

import hashlib
from datetime import date
from pathlib import Path

import numpy as np
import pytest
from lxml import etree

from mtmetrology.errors import InputError
from mtmetrology.history import add_result, open_history
from mtmetrology.history.dcc import (
    DCC_NS,
    SI_NS,
    CalibrationCertificate,
    calibration_certificate,
    coverage_probability,
    validate_certificate,
)
from mtmetrology.history.dcc_read import certified_length, read_certificate
from mtmetrology.history.series import document_covariance
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet

MACHINE = Machine.load("five-axis-wcbxfzyst")
SCHEMAS = Path(__file__).parents[2] / "src/mtmetrology/history/schemas"
NS = {"dcc": DCC_NS, "si": SI_NS}


def _correlated_calibration(seed: int = 7) -> dict:
    """A parameter-set with a full (non-diagonal) covariance, customary units."""
    rng = np.random.default_rng(seed)
    n = len(MACHINE.parameter_names)
    a = rng.normal(size=(n, n))
    scales = MACHINE.parameter_scales
    covariance = (a @ a.T / n + np.eye(n)) * np.outer(scales, scales) * 0.3**2
    values = rng.normal(0.0, 5.0, n) * scales
    pset = ParameterSet(
        MACHINE.parameter_names,
        values,
        MACHINE.parameter_units,
        covariance,
        machine=MACHINE.name,
        model="13",
    )
    return pset.to_document()


@pytest.fixture
def record(tmp_path):
    engine = open_history(tmp_path / "h.sqlite")
    return add_result(engine, _correlated_calibration(), MACHINE, by="test")


ISSUER = {
    "laboratory": "Lab",
    "email": "lab@example.org",
    "country": "DE",
    "responsible_person": "A. Person",
    "manufacturer": "Maker GmbH",
}


def _certificate(record, k=2.0):
    return calibration_certificate(record, **ISSUER, coverage_factor=k)


def test_shipped_schemas_are_the_published_versions_with_their_notice():
    digests = {
        "dcc.xsd": "daf869dc4d03b53ca2d33fc4894ffa4ec4e109b81fcd0ebcd74aa8a63f617e11",
        "SI_Format.xsd": "b0068e2a57512172df79352f28089765859cb1bb1c4458341feae97e3585a265",
    }
    for name, digest in digests.items():
        assert hashlib.sha256((SCHEMAS / name).read_bytes()).hexdigest() == digest
    assert etree.parse(str(SCHEMAS / "dcc.xsd")).getroot().get("version") == "3.1.2"
    assert etree.parse(str(SCHEMAS / "SI_Format.xsd")).getroot().get("version") == "2.1.0"
    licence = (SCHEMAS / "COPYING.LESSER").read_text()
    assert licence.startswith("GNU LESSER GENERAL PUBLIC LICENSE\nVersion 3")


def test_exported_certificate_validates_and_states_k_p_and_covariance(record, tmp_path):
    cert = _certificate(record)
    xml = cert.to_xml()
    tree = etree.ElementTree(etree.fromstring(xml))
    validate_certificate(tree)  # raises if invalid
    listed = tree.find(".//si:realListXMLList", NS)
    assert listed.find("si:labelXMLList", NS).text.split() == list(MACHINE.parameter_names)
    expanded = listed.find("si:expandedUncXMLList", NS)
    big_u = np.array(expanded.find("si:uncertaintyXMLList", NS).text.split(), dtype=float)
    assert float(expanded.find("si:coverageFactorXMLList", NS).text) == 2.0
    p = float(expanded.find("si:coverageProbabilityXMLList", NS).text)
    assert p == pytest.approx(0.954499736, abs=1e-9)  # 2 Φ(2) − 1
    columns = listed.findall("si:ellipsoidalRegionXMLList/si:covarianceMatrix/si:column", NS)
    n = len(MACHINE.parameter_names)
    assert len(columns) == n
    assert all(len(c.findall("si:covariance", NS)) == n for c in columns)
    # U = k u with u the square root of the covariance diagonal, in SI units (m, rad, 1).
    internal = document_covariance(record.result, list(MACHINE.parameter_names))
    to_si = np.array([1e-3 if u == "m" else 1.0 for u in cert.units])
    np.testing.assert_allclose(big_u, 2.0 * np.sqrt(np.diag(internal)) * to_si, rtol=1e-14)


def test_a_tampered_certificate_fails_validation(record):
    tree = etree.ElementTree(etree.fromstring(_certificate(record).to_xml()))
    tree.find(".//si:coverageFactorXMLList", NS).text = "0.5"  # k < 1: not a kValue
    with pytest.raises(InputError, match=r"not a valid DCC 3\.1\.2"):
        validate_certificate(tree, "cert.xml")


def test_export_then_import_gives_the_same_values_u_and_covariance(record, tmp_path):
    cert = _certificate(record, k=2.5)
    path = tmp_path / "cert.xml"
    path.write_bytes(cert.to_xml())
    back = read_certificate(path)
    exact, again = cert.to_dict(), back.to_dict()
    assert {k: v for k, v in again.items() if k != "quantities"} == {
        k: v for k, v in exact.items() if k != "quantities"
    }
    assert back.names == cert.names and back.units == cert.units and back.values == cert.values
    np.testing.assert_allclose(back.u, cert.u, rtol=1e-15)  # U / k: one rounding
    assert CalibrationCertificate.from_dict(back.to_dict()) == back
    values, u, covariance = back.internal()
    names = list(MACHINE.parameter_names)
    expected = [p["value"] * MACHINE.parameter_scales[i] for i, p in enumerate(record.parameters)]
    np.testing.assert_allclose(values, expected, rtol=1e-14, atol=1e-300)
    np.testing.assert_allclose(
        covariance, document_covariance(record.result, names), rtol=1e-14, atol=0
    )
    np.testing.assert_allclose(u, np.sqrt(np.diag(covariance)), rtol=1e-14)
    assert back.coverage_probability == coverage_probability(2.5)


def test_coverage_probability_of_k_1_is_the_one_sigma_probability():
    assert coverage_probability(1.0) == pytest.approx(0.682689492137, abs=1e-12)


def _artefact_certificate(tmp_path, unit_length=r"\milli\metre") -> Path:
    """A third-party scale-bar DCC written by hand: length in mm, U for k = 2, no covariance."""
    cert = CalibrationCertificate(
        identifier="SB-2026-001",
        item="scale bar SB-305",
        laboratory="Reference Lab",
        email="ref@example.org",
        country="CH",
        begin=date(2026, 1, 12),
        end=date(2026, 1, 13),
        software_version="x",
        result="length",
        names=("L_SB1_SB2",),
        units=("m",),
        values=(0.3052105,),
        u=(1.2e-6,),
        covariance=((1.44e-12,),),
        coverage_factor=2.0,
        coverage_probability=0.9545,
    )
    root = etree.fromstring(cert.to_xml())
    listed = root.find(".//si:realListXMLList", NS)
    listed.remove(listed.find("si:ellipsoidalRegionXMLList", NS))
    listed.find("si:valueXMLList", NS).text = "305.2105"
    listed.find("si:unitXMLList", NS).text = unit_length
    listed.find("si:expandedUncXMLList/si:uncertaintyXMLList", NS).text = "0.0024"
    path = tmp_path / "scale_bar.xml"
    path.write_bytes(etree.tostring(root))
    return path


def test_artefact_certificate_in_mm_gives_the_calibrated_length_and_u(tmp_path):
    cert = read_certificate(_artefact_certificate(tmp_path))
    values, u, covariance = cert.internal()  # mm
    assert cert.item == "scale bar SB-305"
    assert values[0] == pytest.approx(305.2105, rel=1e-15)
    assert u[0] == pytest.approx(0.0012, rel=1e-12)  # U / k = 0.0024 mm / 2
    assert covariance[0, 0] == pytest.approx(0.0012**2, rel=1e-12)


def test_artefact_certificate_in_an_unknown_unit_is_refused(tmp_path):
    path = _artefact_certificate(tmp_path, unit_length=r"\kelvin")
    with pytest.raises(InputError, match=r"scale_bar.xml: unit '\\\\kelvin'"):
        read_certificate(path)


def test_not_a_dcc_is_refused_naming_the_file(tmp_path):
    path = tmp_path / "other.xml"
    path.write_text("<root/>")
    with pytest.raises(InputError, match=r"other\.xml: line 1: not a valid DCC"):
        read_certificate(path)


def test_bad_inputs_to_the_export_are_refused(record):
    cases = {
        "--country 'Germany': an ISO 3166-1 alpha-2 code such as DE": {"country": "Germany"},
        "--laboratory: empty; a certificate names it": {"laboratory": "  "},
        "--responsible-person: empty; a certificate names it": {"responsible_person": ""},
        "--email 'lab@': not an e-mail address (name@domain.tld)": {"email": "lab@"},
        "--email 'a b@lab.org': not an e-mail address (name@domain.tld)": {"email": "a b@lab.org"},
        "--email 'lab.org': not an e-mail address (name@domain.tld)": {"email": "lab.org"},
        "--coverage-factor 0.5: must be >= 1": {"coverage_factor": 0.5},
    }
    for message, change in cases.items():
        with pytest.raises(InputError) as raised:
            calibration_certificate(record, **{**ISSUER, **change})
        assert str(raised.value) == message


def test_a_run_without_uncertainty_is_refused(tmp_path):
    engine = open_history(tmp_path / "h.sqlite")
    document = ParameterSet(
        MACHINE.parameter_names,
        np.zeros(len(MACHINE.parameter_names)),
        MACHINE.parameter_units,
        machine=MACHINE.name,
        model="13",
    ).to_document()
    stored = add_result(engine, document, MACHINE, by="test")
    with pytest.raises(InputError, match=r"run 1: parameter E_A0B: no uncertainty to certify"):
        calibration_certificate(stored, **ISSUER)


def _record_of(n: int, tmp_path, seed: int = 11):
    """A recorded calibration of the first n parameters with a full covariance."""
    rng = np.random.default_rng(seed)
    names = MACHINE.parameter_names[:n]
    scales = MACHINE.parameter_scales[:n]
    a = rng.normal(size=(n, n))
    covariance = (a @ a.T / n + np.eye(n)) * np.outer(scales, scales) * 0.3**2
    pset = ParameterSet(
        names,
        rng.normal(0, 5, n) * scales,
        MACHINE.parameter_units[:n],
        covariance,
        machine=MACHINE.name,
    )
    engine = open_history(tmp_path / f"h{n}.sqlite")
    return add_result(engine, pset.to_document(), MACHINE, by="test")


@pytest.mark.parametrize("n", [1, 2, 3, 13])
@pytest.mark.parametrize("k", [2.0, 3.0])
def test_the_ellipsoidal_region_states_k_and_p_consistent_for_its_dimension(n, k, tmp_path):
    """JCGM 102 6.5.2.3: the region of n parameters holds them with p = P(χ²_n ≤ k²). Read
    from the XML: the region's p is the certificate's (2 Φ(k) − 1) and its k is the one of n
    dimensions (4.76 for 13 parameters and k = 2, not 2)."""
    from scipy.stats import chi2, norm

    path = tmp_path / "cert.xml"
    path.write_bytes(_certificate(_record_of(n, tmp_path), k=k).to_xml())
    listed = etree.parse(str(path)).find(".//si:realListXMLList", NS)
    region = listed.find("si:ellipsoidalRegionXMLList", NS)
    dimension = len(region.findall("si:covarianceMatrix/si:column", NS))
    k_region = float(region.find("si:coverageFactor", NS).text)
    p_region = float(region.find("si:coverageProbability", NS).text)
    p_stated = float(listed.find("si:expandedUncXMLList/si:coverageProbabilityXMLList", NS).text)
    assert dimension == n
    assert chi2.cdf(k_region**2, n) == pytest.approx(p_region, abs=1e-6)
    assert p_region == pytest.approx(2 * norm.cdf(k) - 1, abs=1e-12) == p_stated
    if n == 1:
        assert k_region == pytest.approx(k, rel=1e-9)
    if n == 13 and k == 2.0:
        assert k_region == pytest.approx(4.76, abs=0.005)  # the issue's figure


def test_the_json_form_states_the_region(record):
    region = _certificate(record).to_dict()["region"]
    assert region["dimension"] == 13
    assert region["coverage_probability"] == pytest.approx(0.954499736, abs=1e-9)
    assert region["coverage_factor"] == pytest.approx(4.76, abs=0.005)  # issue 30: 4.76


def test_a_certificate_asymmetric_by_rounding_reads_symmetric_beyond_is_refused(record, tmp_path):
    root = etree.fromstring(_certificate(record).to_xml())
    columns = root.findall(".//si:covarianceMatrix/si:column", NS)
    entry = columns[0].findall("si:covariance", NS)[5].find("si:value", NS)  # C[5, 0]
    largest = max(abs(float(v.text)) for v in root.iterfind(".//si:covarianceMatrix//si:value", NS))
    original = float(entry.text)
    path = tmp_path / "cert.xml"
    entry.text = repr(original + 3e-10 * largest)  # rounding: accepted, symmetrised
    path.write_bytes(etree.tostring(root))
    covariance = np.array(read_certificate(path).covariance)
    np.testing.assert_array_equal(covariance, covariance.T)
    entry.text = repr(original + 1e-6 * largest)
    path.write_bytes(etree.tostring(root))
    with pytest.raises(InputError, match=r"cert\.xml: si:ellipsoidalRegionXMLList/si:cov"):
        read_certificate(path)


def test_the_writer_writes_the_covariance_exactly_symmetric(record):
    cert = _certificate(record)
    c = np.array(cert.covariance)
    c[4, 1] *= 1 + 1e-12  # the rounding a computation leaves
    lopsided = CalibrationCertificate(**{**cert.__dict__, "covariance": tuple(map(tuple, c))})
    root = etree.fromstring(lopsided.to_xml())
    columns = root.findall(".//si:covarianceMatrix/si:column", NS)
    written = np.array(
        [
            [float(e.find("si:value", NS).text) for e in col.findall("si:covariance", NS)]
            for col in columns
        ]
    )
    np.testing.assert_array_equal(written, written.T)


def test_the_certificate_names_its_people_and_states_the_recorded_conditions(tmp_path):
    """Customer, responsible person and manufacturer as given (the laboratory is not the
    person), the run's temperature as an influence condition (°C) and its artefact as the
    measuring equipment; all read back from the validated XML."""
    engine = open_history(tmp_path / "h.sqlite")
    stored = add_result(
        engine,
        _correlated_calibration(),
        MACHINE,
        temperature_c=20.4,
        artefact="SAMBA 4 balls",
        by="test",
    )
    cert = calibration_certificate(stored, **ISSUER, customer="Plant 2")
    path = tmp_path / "cert.xml"
    path.write_bytes(cert.to_xml())
    back = read_certificate(path)
    assert (back.customer, back.responsible_person, back.manufacturer) == (
        "Plant 2",
        "A. Person",
        "Maker GmbH",
    )
    assert (back.temperature_c, back.artefact) == (20.4, "SAMBA 4 balls")
    assert CalibrationCertificate.from_dict(cert.to_dict()) == cert
    in_house = read_certificate(_write(tmp_path, calibration_certificate(stored, **ISSUER)))
    assert in_house.customer is None and in_house.laboratory == "Lab"


def _write(tmp_path, cert) -> Path:
    path = tmp_path / "c.xml"
    path.write_bytes(cert.to_xml())
    return path


@pytest.mark.parametrize(
    ("k", "p", "consistent"),
    [
        (2.0, 0.9545, True),
        (2.0, 0.95, True),  # p stated rounded
        (2.2, 0.95, True),  # k = t_0.95(ν_eff ≈ 14)
        (4.30, 0.95, True),  # t_0.95(2)
        (2.0, 0.5, False),  # the issue's: below even the Cauchy's 0.705
        (1.0, 0.95, False),  # k too small for any t
        (2.0, 0.99, False),
    ],
)
def test_a_coverage_factor_and_probability_no_t_distribution_relates_are_refused(
    tmp_path, k, p, consistent
):
    path = _artefact_certificate(tmp_path)
    root = etree.parse(str(path))
    expanded = root.find(".//si:expandedUncXMLList", NS)
    expanded.find("si:coverageFactorXMLList", NS).text = repr(k)
    expanded.find("si:coverageProbabilityXMLList", NS).text = repr(p)
    root.write(str(path))
    if consistent:
        assert read_certificate(path).coverage_probability == p
    else:
        with pytest.raises(InputError, match=rf"coverage factor k = {k:g} with coverage .*"):
            read_certificate(path)


def test_a_length_that_is_not_positive_or_not_the_artefacts_is_refused(tmp_path):
    path = _artefact_certificate(tmp_path)
    cert = read_certificate(path)
    assert certified_length(cert, nominal=305.0)[0] == pytest.approx(305.2105, rel=1e-15)
    with pytest.raises(InputError, match=r"305\.211 mm, the artefact's length is 0\.305 mm"):
        certified_length(cert, nominal=0.305)
    root = etree.parse(str(path))
    root.find(".//si:valueXMLList", NS).text = "-305.2105"
    root.write(str(path))
    with pytest.raises(InputError, match=r"^SB-2026-001: L_SB1_SB2: length -305\.211 mm is not"):
        certified_length(read_certificate(path))
