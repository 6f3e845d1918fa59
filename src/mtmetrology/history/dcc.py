"""Digital Calibration Certificates (PTB DCC 3.1.2 with D-SI 2.1.0 quantities).

:func:`calibration_certificate` makes the certificate of a recorded calibration run,
:meth:`CalibrationCertificate.to_xml` writes it as ``dcc:digitalCalibrationCertificate``
(built element by element with lxml) and
:func:`mtmetrology.history.dcc_read.read_certificate` reads one back, or the certificate of
an artefact (a scale bar's length, a ball plate's centres) as calibrated values with their
uncertainty. Every certificate written or read is validated against the
XSDs shipped in ``history/schemas`` (LGPL v3, see ``NOTICE.md``); nothing is fetched.

The measurement result is one ``si:realListXMLList``: the parameter names
(``labelXMLList``), values and units in coherent SI units (``\\metre``, ``\\radian``,
``\\one``), the expanded uncertainties ``U_i = k u_i`` with their coverage factor and
coverage probability, and the covariance matrix of the parameters
(``ellipsoidalRegionXMLList``, in the products of the units). The ellipsoidal region
covers the n parameters jointly: it states the certificate's p and the coverage factor
of n dimensions, ``p = P(χ²_n ≤ k_n²)`` (JCGM 102:2011, 6.5.2.3;
:func:`mtmetrology.uncertainty.normal_coverage.normal_region_coverage`), not the one-parameter k.
The covariance is written exactly symmetric and read by the one rule of every covariance
reader (:func:`mtmetrology.io.covariance.symmetric_covariance`).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from datetime import date
from functools import cache
from pathlib import Path

import numpy as np
from lxml import etree

from mtmetrology.errors import InputError
from mtmetrology.history.records import RunRecord
from mtmetrology.history.series import document_covariance
from mtmetrology.io.covariance import symmetric
from mtmetrology.uncertainty.normal_coverage import RegionCoverage, normal_region_coverage
from mtmetrology.units import from_internal, parse_unit, to_internal

__all__ = [
    "DCC_NS",
    "NAMESPACES",
    "SCHEMA_VERSION",
    "SI_NS",
    "SI_UNITS",
    "CalibrationCertificate",
    "calibration_certificate",
    "coverage_probability",
    "product_unit",
    "validate_certificate",
]

DCC_NS = "https://ptb.de/dcc"
SI_NS = "https://ptb.de/si"
SCHEMA_VERSION = "3.1.2"
_SCHEMAS = Path(__file__).parent / "schemas"
NAMESPACES = {"dcc": DCC_NS, "si": SI_NS}
#: Dimension of a parameter -> (mtmetrology symbol of its coherent SI unit, D-SI unit).
SI_UNITS = {"length": ("m", r"\metre"), "angle": ("rad", r"\radian"), "ratio": ("1", r"\one")}
#: An e-mail address as a certificate states it: local@domain.tld, no spaces.
_EMAIL = re.compile(r"[^@\s]+@[^@\s.]+(\.[^@\s.]+)+")


class _LocalSchemas(etree.Resolver):
    """Resolve the D-SI import of dcc.xsd (an https URL) to the shipped copy."""

    def resolve(self, url, pubid, context):
        if url.endswith("/SI_Format.xsd"):
            return self.resolve_filename(str(_SCHEMAS / "SI_Format.xsd"), context)
        return None


@cache
def _schema() -> etree.XMLSchema:
    parser = etree.XMLParser(no_network=True)
    parser.resolvers.add(_LocalSchemas())
    return etree.XMLSchema(etree.parse(str(_SCHEMAS / "dcc.xsd"), parser))


def validate_certificate(tree: etree._ElementTree, source: str = "certificate") -> None:
    """Validate a DCC against the shipped XSDs (DCC 3.1.2, D-SI 2.1.0).

    Raises
    ------
    InputError
        Naming ``source``, the line and libxml2's message of the first violation.
    """
    schema = _schema()
    if not schema.validate(tree):
        first = schema.error_log[0]
        raise InputError(
            f"{source}: line {first.line}: not a valid DCC {SCHEMA_VERSION}: {first.message}"
        )


def coverage_probability(k: float) -> float:
    """Coverage probability of ``y ± k u`` for a normal distribution, ``p = 2 Φ(k) − 1``
    (:func:`~mtmetrology.uncertainty.normal_coverage.normal_region_coverage` with n = 1)."""
    return normal_region_coverage(1, k=k).coverage_probability


def product_unit(a: str, b: str) -> str:
    """D-SI unit of the product of two D-SI units (covariance entries)."""
    if a == r"\one":
        return b
    if b == r"\one":
        return a
    return a + r"\tothe{2}" if a == b else a + b


@dataclass(frozen=True)
class CalibrationCertificate:
    """The content of a digital calibration certificate that mtmetrology writes and reads.

    Measurement model: the certificate states, for each quantity, the value ``y_i``, the
    expanded uncertainty ``U_i = k u_i`` (coverage probability ``p = 2 Φ(k) − 1`` for a
    normal distribution) and the covariance ``cov(y_i, y_j)`` of the quantities; values in
    coherent SI units (``units``: m, rad, 1). The n quantities' joint ellipsoidal region
    (:attr:`region`) has the same p and the coverage factor ``k_n`` with
    ``p = P(χ²_n ≤ k_n²)`` (JCGM 102:2011, 6.5.2.3).

    Attributes
    ----------
    identifier : str
        The certificate's unique identifier (``dcc:uniqueIdentifier``).
    item : str
        The calibrated item: the machine or artefact name.
    laboratory, email, country : str
        Calibration laboratory, its e-mail address and ISO 3166-1 country code.
    begin, end : date
        Performance dates of the calibration (UTC).
    software_version : str
    result : str
        Name of the measurement result (e.g. the error model).
    names, units : tuple of str
        Quantities and their mtmetrology unit symbols (coherent SI).
    values, u : tuple of float
        Values and standard uncertainties, in ``units``.
    covariance : tuple of tuple of float
        Covariance of the values (products of ``units``).
    coverage_factor, coverage_probability : float
    customer : str or None
        The customer's name (None: the laboratory itself, an in-house calibration).
    responsible_person, manufacturer : str
        The person responsible for the certificate; the item's manufacturer.
    temperature_c : float or None
        The recorded workshop temperature (an influence condition).
    artefact : str or None
        The artefact used (the measuring equipment).
    """

    identifier: str
    item: str
    laboratory: str
    email: str
    country: str
    begin: date
    end: date
    software_version: str
    result: str
    names: tuple[str, ...]
    units: tuple[str, ...]
    values: tuple[float, ...]
    u: tuple[float, ...]
    covariance: tuple[tuple[float, ...], ...]
    coverage_factor: float
    coverage_probability: float
    customer: str | None = None
    responsible_person: str = ""
    manufacturer: str = ""
    temperature_c: float | None = None
    artefact: str | None = None

    @property
    def region(self) -> RegionCoverage:
        """The ellipsoidal region of all n quantities: the certificate's p, k for n
        dimensions (:func:`~mtmetrology.uncertainty.normal_coverage.normal_region_coverage`)."""
        return normal_region_coverage(len(self.names), p=self.coverage_probability)

    def internal(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Values, standard uncertainties and covariance in internal units (mm, rad, 1)."""
        f = np.array([to_internal(1.0, unit) for unit in self.units])
        return (
            np.asarray(self.values) * f,
            np.asarray(self.u) * f,
            np.asarray(self.covariance) * np.outer(f, f),
        )

    def to_dict(self) -> dict:
        """The JSON form (``kind: calibration-certificate``, version 1); ``region`` is the
        joint ellipsoidal region (:attr:`region`, derived: :meth:`from_dict` ignores it)."""
        return {
            "kind": "calibration-certificate",
            "version": 1,
            "identifier": self.identifier,
            "item": self.item,
            "laboratory": self.laboratory,
            "email": self.email,
            "country": self.country,
            "begin": self.begin.isoformat(),
            "end": self.end.isoformat(),
            "software_version": self.software_version,
            "result": self.result,
            "quantities": [
                {"name": n, "unit": unit, "value": v, "u": s}
                for n, unit, v, s in zip(self.names, self.units, self.values, self.u, strict=True)
            ],
            "covariance": [list(row) for row in self.covariance],
            "coverage_factor": self.coverage_factor,
            "coverage_probability": self.coverage_probability,
            "customer": self.customer,
            "responsible_person": self.responsible_person,
            "manufacturer": self.manufacturer,
            "temperature_c": self.temperature_c,
            "artefact": self.artefact,
            "region": self.region.to_dict(),
        }

    @classmethod
    def from_dict(cls, doc: dict) -> CalibrationCertificate:
        """Inverse of :meth:`to_dict`."""
        q = doc["quantities"]
        return cls(
            identifier=doc["identifier"],
            item=doc["item"],
            laboratory=doc["laboratory"],
            email=doc["email"],
            country=doc["country"],
            begin=date.fromisoformat(doc["begin"]),
            end=date.fromisoformat(doc["end"]),
            software_version=doc["software_version"],
            result=doc["result"],
            names=tuple(e["name"] for e in q),
            units=tuple(e["unit"] for e in q),
            values=tuple(float(e["value"]) for e in q),
            u=tuple(float(e["u"]) for e in q),
            covariance=tuple(tuple(float(c) for c in row) for row in doc["covariance"]),
            coverage_factor=float(doc["coverage_factor"]),
            coverage_probability=float(doc["coverage_probability"]),
            customer=doc.get("customer"),
            responsible_person=doc.get("responsible_person", ""),
            manufacturer=doc.get("manufacturer", ""),
            temperature_c=doc.get("temperature_c"),
            artefact=doc.get("artefact"),
        )

    def to_xml(self) -> bytes:
        """The certificate as a ``dcc:digitalCalibrationCertificate`` (UTF-8), validated.

        References
        ----------
        PTB, DCC – Digital Calibration Certificate, XSD version 3.1.2, https://ptb.de/dcc.
        PTB, D-SI – Digital System of Units, XSD version 2.1.0, doi:10.5281/zenodo.3366901.
        """
        tree = etree.ElementTree(_certificate_element(self))
        validate_certificate(tree)
        return etree.tostring(tree, xml_declaration=True, encoding="UTF-8", pretty_print=True)


def _d(tag: str) -> str:
    return f"{{{DCC_NS}}}{tag}"


def _s(tag: str) -> str:
    return f"{{{SI_NS}}}{tag}"


def _sub(parent, tag: str, text: str | None = None, **attributes):
    element = etree.SubElement(parent, tag, attributes)
    if text is not None:
        element.text = text
    return element


def _named(parent, tag: str, text: str):
    """``<dcc:TAG><dcc:content lang="en">text</dcc:content></dcc:TAG>``."""
    element = _sub(parent, _d(tag))
    _sub(element, _d("content"), text, lang="en")
    return element


def _decimals(values) -> str:
    return " ".join(repr(float(v)) for v in values)


def _contact(element, cert: CalibrationCertificate, name: str | None = None) -> None:
    _named(element, "name", name or cert.laboratory)
    _sub(element, _d("eMail"), cert.email)
    _sub(_sub(element, _d("location")), _d("countryCode"), cert.country)


def _certificate_element(cert: CalibrationCertificate):
    d_units = [SI_UNITS[parse_unit(unit).dimension][1] for unit in cert.units]
    root = etree.Element(_d("digitalCalibrationCertificate"), nsmap=NAMESPACES)
    root.set("schemaVersion", SCHEMA_VERSION)
    admin = _sub(root, _d("administrativeData"))
    software = _sub(_sub(admin, _d("dccSoftware")), _d("software"))
    _named(software, "name", "mtmetrology")
    _sub(software, _d("release"), cert.software_version)
    core = _sub(admin, _d("coreData"))
    _sub(core, _d("countryCodeISO3166_1"), cert.country)
    _sub(core, _d("usedLangCodeISO639_1"), "en")
    _sub(core, _d("mandatoryLangCodeISO639_1"), "en")
    _sub(core, _d("uniqueIdentifier"), cert.identifier)
    _sub(core, _d("beginPerformanceDate"), cert.begin.isoformat())
    _sub(core, _d("endPerformanceDate"), cert.end.isoformat())
    _sub(core, _d("performanceLocation"), "customer")
    items = _sub(admin, _d("items"))
    item = _sub(items, _d("item"))
    _named(item, "name", cert.item)
    _named(_sub(item, _d("manufacturer")), "name", cert.manufacturer)
    identification = _sub(_sub(item, _d("identifications")), _d("identification"))
    _sub(identification, _d("issuer"), "customer")
    _sub(identification, _d("value"), cert.item)
    _contact(_sub(_sub(admin, _d("calibrationLaboratory")), _d("contact")), cert)
    person = _sub(_sub(admin, _d("respPersons")), _d("respPerson"))
    _named(_sub(person, _d("person")), "name", cert.responsible_person)
    _contact(_sub(admin, _d("customer")), cert, cert.customer)

    result = _sub(_sub(root, _d("measurementResults")), _d("measurementResult"))
    _named(result, "name", cert.result)
    if cert.artefact is not None:
        equipment = _sub(_sub(result, _d("measuringEquipments")), _d("measuringEquipment"))
        _named(equipment, "name", cert.artefact)
    if cert.temperature_c is not None:
        condition = _sub(_sub(result, _d("influenceConditions")), _d("influenceCondition"))
        _named(condition, "name", "workshop temperature")
        real = _sub(_sub(_sub(condition, _d("data")), _d("quantity")), _s("real"))
        _sub(real, _s("value"), repr(float(cert.temperature_c)))
        _sub(real, _s("unit"), r"\degreecelsius")
    one = _sub(_sub(result, _d("results")), _d("result"))
    _named(one, "name", "parameters")
    quantity = _sub(_sub(one, _d("data")), _d("quantity"))
    _named(quantity, "name", "parameter values")
    listed = _sub(quantity, _s("realListXMLList"))
    _sub(listed, _s("labelXMLList"), " ".join(cert.names))
    _sub(listed, _s("valueXMLList"), _decimals(cert.values))
    _sub(listed, _s("unitXMLList"), " ".join(d_units))
    expanded = _sub(listed, _s("expandedUncXMLList"))
    _sub(expanded, _s("uncertaintyXMLList"), _decimals(cert.coverage_factor * np.array(cert.u)))
    _sub(expanded, _s("coverageFactorXMLList"), repr(float(cert.coverage_factor)))
    _sub(expanded, _s("coverageProbabilityXMLList"), repr(float(cert.coverage_probability)))
    _sub(expanded, _s("distributionXMLList"), "normal")
    region = _sub(listed, _s("ellipsoidalRegionXMLList"))
    matrix = _sub(region, _s("covarianceMatrix"))
    covariance = symmetric(cert.covariance)
    for j, column_unit in enumerate(d_units):
        column = _sub(matrix, _s("column"))
        for i, row_unit in enumerate(d_units):
            entry = _sub(column, _s("covariance"))
            _sub(entry, _s("value"), repr(float(covariance[i, j])))
            _sub(entry, _s("unit"), product_unit(row_unit, column_unit))
    # the joint region of n quantities: k of n dimensions for the certificate's p
    joint = cert.region
    _sub(region, _s("coverageFactor"), repr(joint.coverage_factor))
    _sub(region, _s("coverageProbability"), repr(joint.coverage_probability))
    _sub(region, _s("distribution"), "normal")
    return root


def calibration_certificate(
    record: RunRecord,
    *,
    laboratory: str,
    email: str,
    country: str,
    responsible_person: str,
    manufacturer: str,
    customer: str | None = None,
    coverage_factor: float = 2.0,
) -> CalibrationCertificate:
    """The certificate of a recorded calibration run.

    Parameters
    ----------
    record : RunRecord
        A calibration run (:func:`~mtmetrology.history.show_run`) whose parameters all
        have a standard uncertainty.
    laboratory, email : str
        Name and e-mail address of the calibration laboratory.
    country : str
        Its ISO 3166-1 alpha-2 country code (two capital letters).
    responsible_person, manufacturer : str
        The person responsible for the certificate; the machine's manufacturer.
    customer : str, optional
        The customer (default: the laboratory, an in-house calibration). The run's
        recorded temperature and artefact are stated as an influence condition and the
        measuring equipment.
    coverage_factor : float
        ``k`` of the expanded uncertainties ``U = k u``, ``k >= 1``; the coverage probability
        stated is ``p = 2 Φ(k) − 1`` (normal distribution). The ellipsoidal region of the
        n parameters states the same p with its own ``k_n``, ``p = P(χ²_n ≤ k_n²)``.

    Returns
    -------
    CalibrationCertificate
        Values, ``u`` and covariance (the run's own covariance, else ``diag(u²)``) in
        coherent SI units.

    Raises
    ------
    InputError
        Not a calibration run, a parameter without ``u`` or without a D-SI unit, a bad
        country code or coverage factor, an empty name or a malformed e-mail address.
    """
    source = f"run {record.id}"
    if record.category != "calibration":
        raise InputError(f"{source}: a {record.category} run; a certificate needs a calibration")
    for option, text in (
        ("--laboratory", laboratory),
        ("--responsible-person", responsible_person),
        ("--manufacturer", manufacturer),
        ("--customer", "given" if customer is None else customer),
    ):
        if not text.strip():
            raise InputError(f"{option}: empty; a certificate names it")
    if not _EMAIL.fullmatch(email):
        raise InputError(f"--email {email!r}: not an e-mail address (name@domain.tld)")
    if not re.fullmatch(r"[A-Z]{2}", country):
        raise InputError(f"--country {country!r}: an ISO 3166-1 alpha-2 code such as DE")
    if not (math.isfinite(coverage_factor) and coverage_factor >= 1.0):
        raise InputError(f"--coverage-factor {coverage_factor}: must be >= 1")
    names = [p["name"] for p in record.parameters]
    si_units = []
    for p in record.parameters:
        dimension = parse_unit(p["unit"]).dimension
        if dimension not in SI_UNITS:
            raise InputError(
                f"{source}: parameter {p['name']}: unit {p['unit']!r} has no D-SI "
                "form here (length, angle or ratio)"
            )
        if re.search(r"\s", p["name"]):
            raise InputError(f"{source}: parameter {p['name']!r}: a D-SI label has no spaces")
        si_units.append(SI_UNITS[dimension][0])
    internal = np.array([to_internal(p["value"], p["unit"]) for p in record.parameters])
    covariance = document_covariance(record.result, names, source)
    if covariance is None:
        missing = [p["name"] for p in record.parameters if p["u"] is None]
        if missing:
            raise InputError(f"{source}: parameter {missing[0]}: no uncertainty to certify")
        covariance = np.diag([to_internal(p["u"], p["unit"]) ** 2 for p in record.parameters])
    f = np.array([from_internal(1.0, unit) for unit in si_units])
    cov_si = covariance * np.outer(f, f)
    return CalibrationCertificate(
        identifier=f"{record.machine}-calibration-{record.id}-{record.content_sha256[:12]}",
        item=record.machine,
        laboratory=laboratory,
        email=email,
        country=country,
        begin=record.performed_at.date(),
        end=record.performed_at.date(),
        software_version=record.software_version,
        result=f"{record.kind} of {record.machine}",
        names=tuple(names),
        units=tuple(si_units),
        values=tuple(float(v) for v in internal * f),
        u=tuple(float(s) for s in np.sqrt(np.diag(cov_si))),
        covariance=tuple(tuple(float(c) for c in row) for row in cov_si),
        coverage_factor=float(coverage_factor),
        coverage_probability=coverage_probability(coverage_factor),
        customer=customer,
        responsible_person=responsible_person,
        manufacturer=manufacturer,
        temperature_c=record.temperature_c,
        artefact=record.artefact,
    )
