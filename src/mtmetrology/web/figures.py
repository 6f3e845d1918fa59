"""The documents of the web pages: a recorded run's HTML report and its certificate (the
control chart is :func:`mtmetrology.report.figures.monitoring.trend_chart`, as ``mtm
history trend --report`` draws it)."""

from __future__ import annotations

import math

from mtmetrology.errors import InputError, MtmetrologyError

__all__ = ["certificate_xml", "run_report"]


def run_report(record, amendments=()) -> str:
    """The HTML report of a recorded run: a calibration's parameter set through its
    registered renderer (values, U at k = 2, correlations), any other result as a table of
    its fields; the provenance lists the inputs' SHA-256, the software version and the
    amendments."""
    from mtmetrology.report import Report
    from mtmetrology.report.results import add_result

    title = f"{record.category.capitalize()} run {record.id} of {record.machine}"
    provenance = {
        "recorded": record.recorded_at.isoformat(),
        "performed": record.performed_at.isoformat(),
        "software version (recorded)": record.software_version,
        "result sha256": record.content_sha256,
        **{f"input {path}": sha for path, sha in record.input_hashes.items()},
    }
    for a in amendments:
        provenance[f"amendment {a.id}"] = (
            f"{a.field}: {a.old_value!r} -> {a.new_value!r} by {a.amended_by} "
            f"{a.amended_at.isoformat()} ({a.reason})"
        )
    rep = Report(title, provenance=provenance)
    rendered = False
    if record.category == "calibration":
        from mtmetrology.kinematics.machine import Machine
        from mtmetrology.kinematics.parameter_set import ParameterSet

        try:
            machine = Machine.load(record.machine)
            pset = ParameterSet.from_document(record.result, machine, f"run {record.id}")
            add_result(rep, pset)
            rendered = True
        except (MtmetrologyError, OSError, ValueError):
            rendered = False  # a machine defined by a file not at hand: the fields below
    if not rendered:
        rows = [
            [key, _cell(value)]
            for key, value in record.result.items()
            if not isinstance(value, dict | list)
        ]
        rep.section("Result", f"{record.kind} as recorded.").table(["field", "value"], rows)
    return rep.html()


def _cell(value):
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return value if isinstance(value, int | float | str) or value is None else str(value)


def certificate_xml(record, settings: dict, coverage_factor: float = 2.0) -> bytes:
    """The run's DCC (:func:`~mtmetrology.history.dcc.calibration_certificate`), validated
    against the shipped XSDs by ``to_xml`` before it is returned.

    Raises
    ------
    InputError
        The laboratory's name, e-mail, country, responsible person or manufacturer is not
        set, or the run cannot be certified (no uncertainties, not a calibration).
    """
    from mtmetrology.history.dcc import calibration_certificate

    needed = ("laboratory", "email", "country", "responsible_person", "manufacturer")
    missing = [k.replace("_", " ") for k in needed if not settings.get(k)]
    if missing:
        raise InputError(
            f"certificate: the laboratory's {', '.join(missing)} not set (Settings page)"
        )
    cert = calibration_certificate(
        record,
        laboratory=settings["laboratory"],
        email=settings["email"],
        country=settings["country"],
        responsible_person=settings["responsible_person"],
        manufacturer=settings["manufacturer"],
        coverage_factor=coverage_factor,
    )
    return cert.to_xml()
