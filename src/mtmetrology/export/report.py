"""What a report shows for an :class:`~mtmetrology.export.workflow.ExportResult`.

The tables as the control applies them (corrections against axis position, with the band
± U, U = 2 u of the tabulated values from the parameter covariance; the negative-direction
table dashed where the format carries one), for a volumetric grid its middle z-plane (|e|
and the largest u at the nodes), the functions the format does not carry, the pitch
advisor's answer, and the residual map: the largest length of the residual vector r̂ over
the other axes at each (X, Y) of the check grid, for each direction of approach checked.
Values in µm or µrad, positions in mm or degrees.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from mtmetrology.export.workflow import ExportResult
from mtmetrology.report import figures
from mtmetrology.report.figures.style import legend_below
from mtmetrology.report.results import renders

__all__ = ["correction_profiles", "grid_slice"]

#: Tables drawn per figure (one panel each).
PANELS = 6


def correction_profiles(rows: list) -> Figure:
    """Corrections of up to :data:`PANELS` tables against position, with ± U (k = 2)."""
    fig = Figure(figsize=(6.4, 1.6 * len(rows) + 0.6), layout="constrained")
    for k, row in enumerate(rows):
        ax = fig.add_subplot(len(rows), 1, k + 1)
        x, y = np.asarray(row["positions"]), np.asarray(row["correction"])
        ax.plot(x, y, "-", color="C0", lw=1.2, label="correction")
        if row.get("u") is not None:
            band = 2 * np.asarray(row["u"])
            ax.fill_between(x, y - band, y + band, color="C0", alpha=0.25, label="± U (k = 2)")
        if row.get("correction_reverse") is not None:
            yr = np.asarray(row["correction_reverse"])
            ax.plot(x, yr, "--", color="C1", lw=1.2, label="negative direction")
            if row.get("u_reverse") is not None:
                band = 2 * np.asarray(row["u_reverse"])
                ax.fill_between(x, yr - band, yr + band, color="C1", alpha=0.2)
        ax.set_ylabel(f"{row['function']} ({row['unit']})")
        ax.grid(alpha=0.3)
        if k == len(rows) - 1:
            ax.set_xlabel(f"position ({row['pitch_unit']})")
        if k == 0:
            legend_below(fig, ax)  # under the panels, on no table
    return fig


def grid_slice(piece: dict, key: str = "length_um") -> Figure:
    """A volumetric grid on its middle z-plane: ``length_um`` |e|, or ``max_u_um`` the
    largest standard uncertainty of a component, at the nodes."""
    x, y = np.asarray(piece["x_mm"]), np.asarray(piece["y_mm"])
    return figures.error_map(
        x,
        y,
        np.asarray(piece[key]).T,
        name="|e|" if key == "length_um" else "largest u",
        xlabel="x (mm)",
        ylabel="y (mm)",
        title=f"Volumetric grid at z = {piece['z_mm']:g} mm",
    )


def _residual_map(res: dict, r_um=None, title="Residual error after compensation"):
    axes = res.get("axes", [])
    if not {"X", "Y"} <= set(axes):
        return None
    q = np.asarray(res["readings"])
    length = np.linalg.norm(np.asarray(res["r_um"] if r_um is None else r_um), axis=1)
    x, y = q[:, axes.index("X")], q[:, axes.index("Y")]
    gx, gy = np.unique(x), np.unique(y)
    grid = np.zeros((gy.size, gx.size))
    np.maximum.at(grid, (np.searchsorted(gy, y), np.searchsorted(gx, x)), length)
    return figures.error_map(
        gx,
        gy,
        grid,
        name="largest |r̂| over the other axes",
        xlabel="X (mm)",
        ylabel="Y (mm)",
        title=title,
    )


def _negative_rows(neg: dict | None) -> list:
    """Rows of the check for travel in the negative direction (reversal terms), if any."""
    if neg is None:
        return []
    big_u = "" if neg["max_U_um"] is None else f"{neg['max_U_um']:.2g}"
    return [
        ["largest |r̂|, negative direction", f"{neg['max_um']:.3g}", "µm"],
        ["rms |r̂|, negative direction", f"{neg['rms_um']:.3g}", "µm"],
        ["largest U (k = 2), negative direction", big_u, "µm"],
        [
            "largest error without compensation, negative",
            f"{neg['uncompensated_max_um']:.3g}",
            "µm",
        ],
    ]


@renders(ExportResult, "Compensation export")
def _render(rep, result, **_context) -> None:
    res = result.residual
    rep.section(
        f"Compensation tables: {result.format}",
        f"{result.machine}, model {result.model or 'custom'}: corrections (−E) as the "
        "control applies them; U = 2 u of the tabulated values from the parameter "
        "covariance (A U Aᵀ).",
    )
    rep.table(
        ["function", "points", "pitch", "largest correction", "largest u", "unit"],
        [
            [
                t["function"],
                t["points"],
                f"{t['pitch']:g} {t['pitch_unit']}" if "pitch" in t else "",
                f"{t['max_correction']:.3g}",
                "" if t["max_u"] is None else f"{t['max_u']:.2g}",
                t["unit"],
            ]
            for t in result.tables
        ],
    )
    if result.not_carried:
        rep.text(f"Not carried by {result.format}: {', '.join(result.not_carried)}.")
    for note in result.notes:
        if result.sign is None or note != result.sign["statement"]:  # stated above
            rep.text(f"Note: {note}.")
    for t in result.tables:
        if "slice" in t:
            rep.figure(
                grid_slice(t["slice"]),
                caption="Length of the grid's error vectors e (the control commands P + e).",
            )
            if t["slice"]["max_u_um"] is not None:
                rep.figure(
                    grid_slice(t["slice"], "max_u_um"),
                    caption="Largest standard uncertainty of a component of e at the nodes.",
                )
    drawn = [t for t in result.tables if "positions" in t]
    for start in range(0, len(drawn), PANELS):
        rep.figure(
            correction_profiles(drawn[start : start + PANELS]),
            caption="Corrections against axis position with ± U (k = 2).",
        )
    if result.sign is not None:
        rep.section(
            "What the files mean to the control",
            "The residual below is what the control, emulated from its vendor's document, "
            f"does with the written files: {result.sign['statement']}.",
        )
        rep.table(
            ["file", "the file holds", "sign established", "source"],
            [
                [f["file"], f["value"], "yes" if f["sign_established"] else "no", f["source"]]
                for f in result.sign["files"]
            ],
        )
    rep.section(
        "Residual after the control applies the tables",
        "r = e(q; θ) + Σ S_f c_f(q; θ̂): the machine's error plus the corrections the "
        "emulated control applies from the files; u(r)² = diag(J U Jᵀ).",
    )
    rep.table(
        ["quantity", "value", "unit"],
        [
            ["check points", res["points"], ""],
            ["largest |r̂|", f"{res['max_um']:.3g}", "µm"],
            ["rms |r̂|", f"{res['rms_um']:.3g}", "µm"],
            [
                "largest U (k = 2)",
                "" if res["max_U_um"] is None else f"{res['max_U_um']:.2g}",
                "µm",
            ],
            ["largest error without compensation", f"{res['uncompensated_max_um']:.3g}", "µm"],
            *_negative_rows(res.get("negative")),
        ],
    )
    fig = _residual_map(res)
    if fig is not None:
        rep.figure(fig, caption="Largest residual length at each (X, Y) of the check grid.")
    if res.get("negative") is not None:
        fig = _residual_map(
            res, res["negative"]["r_um"], "Residual, travel in the negative direction"
        )
        if fig is not None:
            rep.figure(fig, caption="As above, every axis approached in the negative direction.")
    if result.advisor is not None:
        rep.text(
            f"Pitch advisor (bound {result.advisor['bound_um']:g} µm): {result.advisor['reason']}."
        )
