"""Reading Digital Calibration Certificates (PTB DCC 3.1.2, D-SI 2.1.0): a certificate's
values, uncertainties and covariance, and an artefact's calibrated values from them (a
scale bar's length, a ball plate's centres).

:func:`read_certificate` validates the file against the shipped XSDs
(:func:`mtmetrology.history.dcc.validate_certificate`) and reads its first
``si:realListXMLList``; the writer and :class:`~mtmetrology.history.dcc.CalibrationCertificate`
are in :mod:`mtmetrology.history.dcc`.
"""

from __future__ import annotations

import math
import re
from datetime import date
from pathlib import Path

import numpy as np
from lxml import etree

from mtmetrology.errors import InputError
from mtmetrology.history.dcc import (
    NAMESPACES,
    SI_UNITS,
    CalibrationCertificate,
    product_unit,
    validate_certificate,
)
from mtmetrology.io.covariance import symmetric_covariance
from mtmetrology.units import from_internal, parse_unit, to_internal

__all__ = ["certified_ball_centres", "certified_length", "read_certificate"]

_NS = NAMESPACES
_PREFIXES = {"": "", "nano": "n", "micro": "µ", "milli": "m", "kilo": "k"}
_BASES = {"metre": "m", "radian": "rad"}
_D_SI_SIMPLE = re.compile(r"^(?:\\(nano|micro|milli|kilo))?\\(metre|radian)$")


def _mtm_unit(d_si: str, source: str) -> str:
    """mtmetrology symbol of a simple D-SI unit (``\\micro\\metre`` -> ``µm``)."""
    if d_si == r"\one":
        return "1"
    match = _D_SI_SIMPLE.match(d_si)
    if match is None:
        raise InputError(f"{source}: unit {d_si!r}: not a D-SI length, angle or \\one")
    return _PREFIXES[match.group(1) or ""] + _BASES[match.group(2)]


def _text(element, path: str, source: str) -> str:
    found = element.find(path, _NS)
    if found is None or found.text is None:
        raise InputError(f"{source}: element {path} missing")
    return found.text.strip()


def _floats(element, path: str, source: str) -> np.ndarray:
    return np.array([float(t) for t in _text(element, path, source).split()])


def _per_quantity(values: np.ndarray, n: int, field: str, source: str) -> np.ndarray:
    """A D-SI XML list of length n, or of length 1 meaning the same for all."""
    if values.size == 1:
        return np.full(n, values[0])
    if values.size != n:
        raise InputError(f"{source}: {field}: {values.size} entries for {n} values")
    return values


def read_certificate(path: str | Path) -> CalibrationCertificate:
    """Read a DCC: the first ``si:realListXMLList`` of its measurement results.

    The file is validated against the shipped XSDs. Standard uncertainties are
    ``u_i = U_i / k_i`` (``expandedUncXMLList``; ``coverage_factor`` and
    ``coverage_probability`` of the result are the first quantity's); the covariance is the
    ``ellipsoidalRegionXMLList`` matrix when present (symmetric to 1e-9 of its largest
    entry, then symmetrised: :func:`mtmetrology.io.covariance.symmetric_covariance`), else
    ``diag(u²)``; the region's own k and p are not read (:attr:`CalibrationCertificate.region`
    derives them from p and n). Values are converted to coherent SI units (m, rad, 1) by
    :mod:`mtmetrology.units`.

    Raises
    ------
    InputError
        Naming the file and the element: not XML, not a valid DCC, no list of real values,
        units other than length, angle or one, inconsistent list lengths, an asymmetric
        covariance matrix.
    """
    source = str(path)
    try:
        tree = etree.parse(source, etree.XMLParser(no_network=True, resolve_entities=False))
    except (OSError, etree.XMLSyntaxError) as exc:
        raise InputError(f"{source}: not a readable XML file: {exc}") from None
    validate_certificate(tree, source)
    root = tree.getroot()
    listed = root.find(".//dcc:measurementResults//si:realListXMLList", _NS)
    if listed is None:
        raise InputError(f"{source}: measurementResults: no si:realListXMLList of values")
    values = _floats(listed, "si:valueXMLList", source)
    n = values.size
    d_units = _text(listed, "si:unitXMLList", source).split()
    if len(d_units) == 1:
        d_units = d_units * n
    elif len(d_units) != n:
        raise InputError(f"{source}: si:unitXMLList: {len(d_units)} entries for {n} values")
    labels = listed.find("si:labelXMLList", _NS)
    names = (labels.text or "").split() if labels is not None else [f"q{i + 1}" for i in range(n)]
    if len(names) != n:
        raise InputError(f"{source}: si:labelXMLList: {len(names)} labels for {n} values")
    units = [_mtm_unit(unit, source) for unit in d_units]
    si = [SI_UNITS[parse_unit(unit).dimension] for unit in units]
    f = np.array(
        [
            from_internal(to_internal(1.0, unit), mtm)
            for unit, (mtm, _) in zip(units, si, strict=True)
        ]
    )
    expanded = listed.find("si:expandedUncXMLList", _NS)
    if expanded is None:
        raise InputError(f"{source}: si:expandedUncXMLList missing: no uncertainty stated")
    big_u = _per_quantity(
        _floats(expanded, "si:uncertaintyXMLList", source), n, "si:uncertaintyXMLList", source
    )
    k = _per_quantity(
        _floats(expanded, "si:coverageFactorXMLList", source), n, "si:coverageFactorXMLList", source
    )
    p = _per_quantity(
        _floats(expanded, "si:coverageProbabilityXMLList", source),
        n,
        "si:coverageProbabilityXMLList",
        source,
    )
    _check_coverage(k, p, source)
    u = big_u / k * f
    matrix = listed.find("si:ellipsoidalRegionXMLList/si:covarianceMatrix", _NS)
    if matrix is None:
        covariance = np.diag(u**2)
    else:
        columns = matrix.findall("si:column", _NS)
        entries = [[c for c in column.findall("si:covariance", _NS)] for column in columns]
        if len(columns) != n or any(len(column) != n for column in entries):
            raise InputError(f"{source}: si:covarianceMatrix: not {n} columns of {n} entries")
        covariance = np.empty((n, n))
        for j, column in enumerate(entries):
            for i, entry in enumerate(column):
                unit = _text(entry, "si:unit", source)
                if unit != product_unit(d_units[i], d_units[j]):
                    raise InputError(
                        f"{source}: si:covarianceMatrix column {j + 1} entry "
                        f"{i + 1}: unit {unit!r}, expected "
                        f"{product_unit(d_units[i], d_units[j])!r}"
                    )
                covariance[i, j] = float(_text(entry, "si:value", source)) * f[i] * f[j]
        covariance = symmetric_covariance(
            covariance, f"{source}: si:ellipsoidalRegionXMLList/si:covarianceMatrix"
        )
    core = root.find("dcc:administrativeData/dcc:coreData", _NS)
    contact = root.find("dcc:administrativeData/dcc:calibrationLaboratory/dcc:contact", _NS)
    item = root.find("dcc:administrativeData/dcc:items/dcc:item/dcc:name/dcc:content", _NS)
    software = root.find("dcc:administrativeData/dcc:dccSoftware/dcc:software/dcc:release", _NS)
    result = root.find(".//dcc:measurementResult/dcc:name/dcc:content", _NS)
    laboratory = _text(contact, "dcc:name/dcc:content", source)
    customer = _optional(root, "dcc:administrativeData/dcc:customer/dcc:name/dcc:content")
    return CalibrationCertificate(
        identifier=_text(core, "dcc:uniqueIdentifier", source),
        item="" if item is None else (item.text or ""),
        laboratory=laboratory,
        email=_text(contact, "dcc:eMail", source),
        country=_text(core, "dcc:countryCodeISO3166_1", source),
        begin=date.fromisoformat(_text(core, "dcc:beginPerformanceDate", source)),
        end=date.fromisoformat(_text(core, "dcc:endPerformanceDate", source)),
        software_version="" if software is None else (software.text or ""),
        result="" if result is None else (result.text or ""),
        names=tuple(names),
        units=tuple(mtm for mtm, _ in si),
        values=tuple(float(v) for v in values * f),
        u=tuple(float(s) for s in u),
        covariance=tuple(tuple(float(c) for c in row) for row in covariance),
        coverage_factor=float(k[0]),
        coverage_probability=float(p[0]),
        customer=None if customer == laboratory else customer,
        responsible_person=_optional(root, f"{_ADMIN}/dcc:respPersons//dcc:person/{_NAME}") or "",
        manufacturer=_optional(root, f"{_ADMIN}/dcc:items/dcc:item/dcc:manufacturer/{_NAME}") or "",
        temperature_c=_temperature(root, source),
        artefact=_optional(root, f".//dcc:measurementResult//dcc:measuringEquipment/{_NAME}"),
    )


_ADMIN = "dcc:administrativeData"
_NAME = "dcc:name/dcc:content"


def _optional(root, path: str) -> str | None:
    found = root.find(path, _NS)
    return None if found is None or found.text is None else found.text.strip()


def _temperature(root, source: str) -> float | None:
    """The workshop temperature this module writes as an influence condition (°C)."""
    real = root.find(".//dcc:influenceCondition/dcc:data/dcc:quantity/si:real", _NS)
    if real is None or _text(real, "si:unit", source) != r"\degreecelsius":
        return None
    return float(_text(real, "si:value", source))


def _check_coverage(k: np.ndarray, p: np.ndarray, source: str) -> None:
    """Refuse a coverage factor and probability that no t distribution relates.

    ``k = t_p(ν_eff)`` with ``ν_eff ≥ 1`` (JCGM 100:2008, G.3–G.4): ``p`` lies between
    ``P(|t₁| ≤ k) = (2/π) atan k`` (Cauchy, ν = 1) and ``P(|N| ≤ k) = erf(k/√2)`` (normal,
    ν → ∞); 0.005 is allowed either side for a p stated rounded (k = 2, p = 0.95).
    """
    for i, (factor, probability) in enumerate(zip(k, p, strict=True)):
        if not (math.isfinite(factor) and factor > 0 and 0 < probability < 1):
            raise InputError(
                f"{source}: quantity {i + 1}: coverage factor {factor:g}, probability "
                f"{probability:g}: k > 0 and 0 < p < 1 are needed"
            )
        low = 2 / math.pi * math.atan(factor) - 0.005
        high = math.erf(factor / math.sqrt(2)) + 0.005
        if not low <= probability <= high:
            raise InputError(
                f"{source}: quantity {i + 1}: coverage factor k = {factor:g} with coverage "
                f"probability p = {probability:g}: inconsistent (k = {factor:g} covers "
                f"{low + 0.005:.3f} to {high - 0.005:.4f}, JCGM 100 G.3)"
            )


def certified_length(
    cert: CalibrationCertificate, quantity: str | None = None, nominal: float | None = None
) -> tuple[float, float]:
    """A certified length and its standard uncertainty, in mm (e.g. a scale bar's).

    Parameters
    ----------
    cert : CalibrationCertificate
    quantity : str, optional
        Its name in the certificate; without it the certificate must hold one quantity
        (a certificate of several, e.g. a machine's, is not silently a scale bar's).
    nominal : float, optional
        The artefact's length so far (mm): a certified length more than 1 % from it is
        refused (a unit or the wrong certificate: 10³ off).

    Returns
    -------
    (length, u) : (float, float)
        In mm, ``u = U / k`` of the certificate.

    Raises
    ------
    InputError
        No such quantity, not a length, several quantities and no ``quantity``, a length
        that is not positive or not the nominal.
    """
    values, u, _ = cert.internal()
    lengths = [i for i, unit in enumerate(cert.units) if parse_unit(unit).dimension == "length"]
    if quantity is None:
        if len(cert.names) != 1:
            raise InputError(
                f"{cert.identifier}: {len(cert.names)} quantities certified "
                f"({', '.join(cert.names[:4])}{' ...' if len(cert.names) > 4 else ''}); a "
                "scale bar's certificate has one: name it with --quantity"
            )
        i = 0
        if i not in lengths:
            raise InputError(f"{cert.identifier}: {cert.names[0]}: not a length ({cert.units[0]})")
    else:
        if quantity not in cert.names:
            raise InputError(f"--quantity {quantity!r}: not a quantity of {cert.identifier}")
        i = cert.names.index(quantity)
        if i not in lengths:
            raise InputError(f"--quantity {quantity!r}: not a length ({cert.units[i]})")
    length = float(values[i])
    if not length > 0:
        raise InputError(
            f"{cert.identifier}: {cert.names[i]}: length {length:g} mm is not positive"
        )
    if nominal is not None and abs(length - nominal) > 0.01 * abs(nominal):
        raise InputError(
            f"{cert.identifier}: {cert.names[i]}: {length:g} mm, the artefact's length is "
            f"{nominal:g} mm (more than 1 % apart: another artefact or unit)"
        )
    return length, float(u[i])


def certified_ball_centres(
    cert: CalibrationCertificate, ball_ids: list[str]
) -> tuple[np.ndarray, np.ndarray]:
    """Ball centres of a ball plate's certificate and their covariance, in mm and mm².

    The certificate names each coordinate ``ID_x``, ``ID_y``, ``ID_z`` (its labels); the
    result is ordered as ``ball_ids``, coordinates ``x0 y0 z0 x1 ...`` (the order of the
    ``covariance_mm2`` of a ``ball-plate`` file).

    Parameters
    ----------
    cert : CalibrationCertificate
    ball_ids : list of str
        The balls wanted, in order.

    Returns
    -------
    centres : ndarray, shape (n, 3)
        mm.
    covariance : ndarray, shape (3n, 3n)
        mm², the certificate's covariance (or diag(u²)) of these coordinates.

    Raises
    ------
    InputError
        A coordinate of a ball missing from the certificate, or not a length.
    """
    values, _, covariance = cert.internal()
    index = []
    for ball in ball_ids:
        for axis in "xyz":
            name = f"{ball}_{axis}"
            if name not in cert.names:
                raise InputError(f"{cert.identifier}: ball {ball!r}: no quantity {name!r}")
            i = cert.names.index(name)
            if parse_unit(cert.units[i]).dimension != "length":
                raise InputError(f"{cert.identifier}: {name}: not a length ({cert.units[i]})")
            index.append(i)
    return values[index].reshape(-1, 3), covariance[np.ix_(index, index)]
