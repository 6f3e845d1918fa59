"""What a report shows for the OMM results (registered with the report layer's ``@renders``).

- :class:`~mtmetrology.omm.task.TaskResult`: the outputs with u, U, k and the coverage
  interval, the first-order budget by source (table and bars), the validation of the GUF
  by Monte Carlo when it ran and the ISO 14253-1:2017 conformity decision with its zones;
- :class:`~mtmetrology.omm.repeatability_records.RepeatabilityFit`: the held-out errors
  of every output model, the per-target statistics and the sliding-window σ;
- :class:`~mtmetrology.omm.hysteresis.HysteresisResult`: H ± U per indexation (figure and
  table) and the summary over the indexations.

The same renderer makes the notebook display (``_repr_html_``) and the sections
``mtm task uncertainty --report`` and ``mtm repeatability fit|hysteresis --report`` write.
Values are in mm (feature values) and µm, µm² (uncertainties, σ, covariances, H).

References
----------
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, §4 (eqs. 4-1 to 4-4, Fig. 4-20),
Ch. 6–7 (task uncertainty).
"""

from __future__ import annotations

import math

from mtmetrology.formatting import (
    SHARE_DEFINITION,
    format_k,
    format_share,
    format_uncertainty,
    format_value,
)
from mtmetrology.omm.hysteresis import HysteresisResult, summary_line
from mtmetrology.omm.repeatability import COVARIANCE_OUTPUTS, STD_OUTPUTS
from mtmetrology.omm.repeatability_records import RepeatabilityFit
from mtmetrology.omm.repeatability_windows import WINDOW_OUTPUTS
from mtmetrology.omm.simulator import group_label
from mtmetrology.omm.task import TaskResult
from mtmetrology.report import figures
from mtmetrology.report.document import Report
from mtmetrology.report.results import add_result, renders
from mtmetrology.units import from_internal

__all__: list[str] = []

#: How the outputs of each ``TaskResult.method`` were evaluated.
_METHODS = {
    "guf": "GUF",
    "mcm": "adaptive Monte Carlo (JCGM 101:2008, 7.9)",
    "both": "adaptive Monte Carlo, with the GUF validated against it (JCGM 101:2008, 8)",
}


@renders(TaskResult, "On-machine task uncertainty")
def _task(rep: Report, result: TaskResult, **_) -> None:
    """Values with u and U, the budget by source, the validation and the decision."""
    target = result.target
    r = result.result
    name = r.names[target]
    rep.section(
        "Result",
        f"{_METHODS[result.method]} of the compensated points through the feature "
        "(full-covariance method of Sepahi Boroujeni (2021), Ch. 6), compensated with the "
        "calibration's estimate: repeatability, the calibration's parameter covariance, the "
        f"long-term variation of the parameters ({result.long_term}) and unexplained "
        f"volumetric errors; {result.inputs.simulator} covariance simulator.",
    )
    rows = []
    for o in r.outputs:
        u_um, big_u_um = float(from_internal(o.u, "µm")), float(from_internal(o.U, "µm"))
        low, high = o.interval
        rows.append(
            [
                o.name,
                f"{format_value(o.value, o.u)} mm",
                f"{format_uncertainty(u_um)} µm",
                f"{format_uncertainty(big_u_um)} µm",
                format_k(o.k),
                o.p,
                f"[{format_value(low, o.u)}, {format_value(high, o.u)}] mm",
            ]
        )
    rep.table(["output", "value", "u", "U", "k", "p", "interval"], rows)
    sources = list(result.shares)
    shares = [float(result.shares[k][target]) for k in sources]
    rep.section("Budget by source (first order)")
    rep.table(
        ["source", "share of u_c²"],
        [[group_label(k), format_share(v)] for k, v in zip(sources, shares, strict=True)],
        caption=f"{SHARE_DEFINITION}; the sources are independent, so their shares add.",
    )
    rep.figure(
        figures.budget_bars(
            [group_label(k) for k in sources], shares, title=f"Uncertainty budget of {name}"
        ),
        caption="Share of u_c² of each source, as in the table.",
    )
    if result.validation is not None:
        add_result(rep, result.validation, units=dict(zip(r.names, r.units, strict=True)))
    if result.decision is not None:
        tol = result.decision.tolerance
        value, big_u = float(r.outputs[target].value), float(r.outputs[target].U)
        lower = tol.lower_limit if math.isfinite(tol.lower_limit) else None
        upper = tol.upper_limit if math.isfinite(tol.upper_limit) else None
        rep.section(
            f"Conformity decision of {name} (ISO 14253-1:2017)",
            str(result.decision.to_dict()["decision"]),
        )
        rep.figure(
            figures.conformity_zones(
                value, big_u, lower, upper, name=name, unit="mm", nominal=tol.nominal
            ),
            caption=f"{name} ± U against the specification zone and its conformance and "
            "nonconformance zones (ISO 14253-1:2017), in deviations from the nominal.",
        )


@renders(RepeatabilityFit, "Probing repeatability")
def _repeatability(rep: Report, fit: RepeatabilityFit, **_) -> None:
    """Held-out errors of the models, per-target statistics, sliding-window σ."""
    document = fit.to_dict()
    rep.section(
        "Models",
        f"{document['n_fit']} targets fitted, {document['n_validation']} held out. "
        "Separable polynomials on normalised factors (Sepahi Boroujeni (2021), "
        "eqs. 4-1 and 4-2).",
    )
    rows = []
    for o in document["outputs"]:
        rel, rms = o["validation_max_relative_error"], o["validation_rms_relative_error"]
        rows.append(
            [
                o["name"],
                o["unit"],
                len(o["coefficients"]),
                f"{100 * o['r_squared']:.1f} %",
                "—" if rel is None else f"{100 * rel:.1f} %",
                "—"
                if o["validation_max_abs_error"] is None
                else f"{o['validation_max_abs_error']:.3f}",
                "—" if rms is None else f"{100 * rms:.1f} %",
                "flagged" if o["validation_flagged"] else "",
            ]
        )
    rep.table(
        [
            "output",
            "unit",
            "coefficients",
            "R²",
            "max validation error",
            "max abs. difference",
            "rms relative error",
            "check",
        ],
        rows,
        caption="Held-out targets: an output whose RMS error exceeds "
        f"{100 * document['validation_warning']:g} % of the RMS of its held-out values is "
        "flagged (the model does not predict held-out poses).",
    )
    rep.section("Per-target statistics")
    names = STD_OUTPUTS + COVARIANCE_OUTPUTS
    cubic = document["statistics"]["drift"]["model"] == "cubic"
    caption = "σ in µm, covariances in µm²; first touch discarded."
    if cubic:
        caption += (
            " Cubic drift in time removed from each series (Sepahi Boroujeni (2021), §4): "
            "σ and covariances of the residuals, n − 4 degrees of freedom; σ_X raw is the "
            "standard deviation of the X readings themselves."
        )
    rep.table(
        ["target", "touches", *names, *(["sigma_X raw"] if cubic else [])],
        [
            [
                t["target"],
                t["n_touches"],
                *(f"{t[n]:.3f}" for n in names),
                *([f"{t['sigma_X_raw']:.3f}"] if cubic else []),
            ]
            for t in document["statistics"]["targets"]
        ],
        caption=caption,
    )
    if "windows" in document:
        w = document["windows"]
        rep.section(
            "Sliding-window repeatability",
            f"σ of the readings in a window of {w['window']} touches sliding from iteration "
            f"{w['first_iteration']} (Sepahi Boroujeni (2021), §4, Fig. 4-20).",
        )
        rep.figure(
            figures.window_repeatability(
                {n: [(t["start"], t[n]) for t in w["targets"]] for n in WINDOW_OUTPUTS},
                window=w["window"],
            ),
            caption="One thin line per target; the thick line is the median over targets.",
        )


@renders(HysteresisResult, "Hysteresis")
def _hysteresis(rep: Report, result: HysteresisResult, **_) -> None:
    """H ± U per indexation (eqs. 4-3 and 4-4) and the summary over the indexations."""
    document = result.to_dict()
    rep.section(
        f"{document['test'].capitalize()} hysteresis",
        f"{document['definition']} at each indexation (Sepahi Boroujeni (2021), eq. 4-3), "
        "u(H) from the standard deviations of the two means (eq. 4-4). Over the "
        f"indexations: {summary_line(document['summary'])}.",
    )
    outputs, rows = document["outputs"], document["indexations"]
    rep.figure(
        figures.hysteresis_bars(
            [r["psi"] for r in rows],
            [o["value"] for o in outputs],
            [o["u"] for o in outputs],
            coverage_factor=[o["k"] for o in outputs],
        ),
        caption=f"Bars: H ± U, coverage probability {outputs[0]['p']:g}.",
    )
    rep.table(
        ["ψ (deg)", "H (µm)", "u (µm)", "ν_eff", "k", "U (µm)"],
        [
            [f"{r['psi']:g}", format_value(o["value"], o["u"]), format_uncertainty(o["u"]),
             f"{r['dof']:.1f}", format_k(o["k"]), format_uncertainty(o["U"])]
            for r, o in zip(rows, outputs, strict=True)
        ],
    )  # fmt: skip
