"""What a report shows for a circular test: the ISO 230-4 table and the polar trace of each
test (:func:`mtmetrology.report.figures.circular_trace`), values in µm."""

from __future__ import annotations

from mtmetrology.units import from_internal

__all__ = ["analysis_report"]


def analysis_report(analysis, command: str | None = None, inputs=()):
    """An HTML report of a :class:`~mtmetrology.ballbar.requests.CircularAnalysis`.

    Parameters
    ----------
    analysis : CircularAnalysis
    command : str, optional
        The command line, for the provenance.
    inputs : sequence of path
        Files recorded in the provenance (size and SHA-256).

    Returns
    -------
    mtmetrology.report.Report
    """
    from mtmetrology.report import Report
    from mtmetrology.report.figures import circular_trace

    rep = Report(
        "ISO 230-4 circular test",
        command=command,
        provenance={"inputs": [str(p) for p in inputs]},
    )
    rep.section(
        "Results",
        "G about the least-squares centre (ISO 230-4:2005, 3.2), H between the runs at the "
        "same angle (3.3), F with the pivot as centre (3.4); µm.",
    )
    rows = []
    for r in analysis.results:
        d = r.to_dict()
        for run in ("ccw", "cw"):
            f = d["radial_deviation_F"][run]
            rows.append(
                [r.name, r.plane, run, d["circular_deviation_G"][run], f["max"], f["min"],
                 d["circular_hysteresis_H"]]
            )  # fmt: skip
    rep.table(["test", "plane", "run", "G", "F max", "F min", "H"], rows)
    for test in analysis.tests:
        runs = {"ccw": test.direction == 1, "cw": test.direction == -1}
        angle = {k: from_internal(test.angle[m], "deg") for k, m in runs.items()}
        dev = {k: from_internal(test.reading[m], "µm") for k, m in runs.items()}
        c = test.conditions
        rep.section(f"Test {c.name}: {c.plane}, R = {c.radius:g} mm, F = {c.feed:g} mm/min")
        rep.figure(circular_trace(angle, dev), caption="Radial deviation ℓ about the pivot, µm")
    return rep
