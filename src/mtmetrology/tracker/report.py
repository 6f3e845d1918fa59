"""HTML reports of the tracker workflows (tables from the result objects, nothing computed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mtmetrology.report import Report
from mtmetrology.units import from_internal

__all__ = ["calibration_report", "placement_report", "verification_report"]


def _two_digits(u: float) -> float:
    """An uncertainty to two significant digits (GUM 7.2.6)."""
    if u == 0 or not np.isfinite(u):
        return u
    return float(f"{u:.2g}")


def calibration_report(cal, command: str, inputs: list[Path]) -> Report:
    """Report of a :class:`~mtmetrology.tracker.TrackerCalibration`."""
    report = Report(
        "Laser-tracker calibration", command=command, provenance={"inputs": list(inputs)}
    )
    report.section("Identification", cal.summary())
    if cal.adequacy is not None:
        from mtmetrology.report.results import add_result

        add_result(report, cal.adequacy, patterns=cal.residual_patterns)
    p = cal.parameters
    f = p.scales()
    u = p.standard_uncertainty
    rows = [
        [n, float(v / s), _two_digits(float(ui / s)), unit]
        for n, v, ui, s, unit in zip(p.names, p.values, u, f, p.units, strict=True)
    ]
    report.table(["parameter", "value", "u", "unit"], rows, caption="Identified error parameters")
    report.section("What the set-up cannot see", cal.datum.message)
    report.table(
        ["add", "rank then", "identifiable then"],
        [[s["add"], s["rank"], ", ".join(s["identifiable_then"]) or "-"] for s in cal.suggestions],
    )
    report.section("Constants the set-up exposes", cal.setup_terms.message)
    pose = cal.pose.to_dict()
    report.section(f"Tracker pose ({cal.pose_source})")
    report.table(["component", "value"], [[k, v] for k, v in pose.items()])
    return report


def verification_report(result, command: str) -> Report:
    """Report of a :class:`~mtmetrology.tracker.TrackerVerification`: statistics, histograms
    of the mean final volumetric error, uncertainty map of the compensated volume."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    report = Report("Laser-tracker verification Monte Carlo", command=command)
    report.section("Summary", result.summary())
    stats = result.statistics()
    report.table(["quantity", "µm"], [[k, v] for k, v in stats.items()])
    fig, ax = plt.subplots(1, 2, figsize=(9, 3.2))
    um = from_internal(1.0, "µm")
    ax[0].hist(result.mean_final * um, bins=40)
    ax[0].set_xlabel("mean final volumetric error per verification / µm")
    ax[1].hist(np.linalg.norm(result.final_errors, axis=-1).ravel() * um, bins=60)
    ax[1].set_xlabel("final error at a mesh point / µm")
    report.figure(fig, caption="Distributions over the simulated verifications")
    fig, ax = plt.subplots(figsize=(5, 4))
    pts = result.mesh
    sc = ax.scatter(pts[:, 0], pts[:, 1], c=result.point_uncertainty * um, s=40)
    fig.colorbar(sc, label="predicted u of the compensated position / µm")
    ax.set_xlabel("X / mm")
    ax.set_ylabel("Y / mm")
    report.figure(fig, caption="Uncertainty map of the compensated volume (all Z levels)")
    return report


def placement_report(study, command: str) -> Report:
    """Report of a :class:`~mtmetrology.tracker.placement.PlacementStudy`: colour map of the
    criterion over the candidate positions, histogram of the introduced maximum error."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    um = from_internal(1.0, "µm")
    report = Report("Laser-tracker placement study", command=command)
    report.section("Summary", study.summary())
    report.table(["component", "value"], [[k, v] for k, v in study.best.to_dict().items()])
    across = 1 if study.direction == "x" else 0
    fig, ax = plt.subplots(figsize=(6, 4))
    sc = ax.scatter(study.candidates[:, across], study.candidates[:, 2],
                    c=study.criterion * um, s=4, cmap="viridis")  # fmt: skip
    fig.colorbar(sc, label=f"{study.criterion_name} u_p over the mesh / µm")
    ax.set_xlabel(f"{'LD'[across]} / mm")
    ax.set_ylabel("H / mm")
    report.figure(fig, caption="Criterion of each candidate tracker position")
    fig, ax = plt.subplots(figsize=(6, 3))
    ax.hist(study.max_error * um, bins=60)
    ax.set_xlabel("largest tracker-introduced error over the mesh / µm")
    report.figure(fig, caption="One draw per candidate (angular levels N(20, 3) µrad)")
    return report
