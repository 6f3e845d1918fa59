"""What a report shows for each result object of the engines.

One renderer per result class, registered by class in the registry of
:mod:`mtmetrology.display` (looked up through the MRO): ``add_result(rep, result)``
appends its sections to a :class:`~mtmetrology.report.Report`, ``result_report(result)``
makes a report of one result, and its fragment is what Jupyter shows through
:class:`~mtmetrology.display.NotebookRepr`. Applications register theirs with
:func:`renders` (that is, :func:`mtmetrology.display.register`) in their report module.

Values are shown in the units of the result: customary units (µm, µrad, µm/m) for
parameter sets and documents, the model's units for uncertainty results, and the internal
units (mm, rad) for the unknowns of an identification, which carry no unit labels.
"""

from __future__ import annotations

import math

import numpy as np

from mtmetrology import display
from mtmetrology.fitting.least_squares import FitResult
from mtmetrology.fitting.minimum_zone import ZoneResult
from mtmetrology.formatting import (
    SHARE_DEFINITION,
    budget_cells,
    budget_columns,
    format_fitted,
    format_k,
    format_uncertainty,
    format_value,
)
from mtmetrology.identification.adequacy import ModelAdequacy
from mtmetrology.identification.diagnostics import IdentifiabilityReport
from mtmetrology.identification.solver import IdentificationResult
from mtmetrology.kinematics.compensation import Compensation, correction_statistics
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.report import figures
from mtmetrology.report.document import Report
from mtmetrology.uncertainty.coverage import DEFAULT_K
from mtmetrology.uncertainty.evaluation import ModelEvaluation
from mtmetrology.uncertainty.guf import GUFResult
from mtmetrology.uncertainty.mcm import MCMResult
from mtmetrology.uncertainty.validation import ValidationReport
from mtmetrology.units import convert, display_unit, from_internal

__all__ = ["add_fit_document", "add_result", "renders", "result_report"]

#: Correlation maps and coverage ellipses are drawn up to this many quantities.
MAX_MAPPED = 40

#: ``@renders(cls, title)``: register the renderer of a result class (one registry, by class).
renders = display.register


def add_result(rep: Report, result: object, **context) -> Report:
    """Append the sections that show ``result`` to ``rep`` (renderer's keyword context).

    Raises
    ------
    TypeError
        If no renderer is registered for the result's class or its bases.
    """
    display.renderer_for(result).func(rep, result, **context)
    return rep


def result_report(result: object, title: str | None = None, **context) -> Report:
    """A report of one result (no command line, versions and date in its provenance)."""
    renderer = display.renderer_for(result)
    rep = Report(title or renderer.title)
    renderer.func(rep, result, **context)
    return rep


def _fragment(renderer: display.Renderer, result: object) -> str:
    rep = Report(renderer.title)
    renderer.func(rep, result)
    return rep.fragment()


display.set_html_builder(_fragment)


def _dof(v: float) -> str:
    return "inf" if not math.isfinite(v) else f"{v:.1f}"


def _uncertainty(u: float, unit: str) -> str:
    """An uncertainty in the display unit of ``unit`` (µm for mm), the number alone: the
    row's unit cell (:func:`_unit_cell`) names that unit."""
    du = display_unit(unit) if unit else unit
    return format_uncertainty(float(convert(u, unit, du)) if du != unit else u)


def _unit_cell(unit: str, shown: str) -> str:
    """The unit cell of a row whose values are in ``unit`` and whose ``shown`` columns
    (uncertainties, tolerances) are in its display unit: ``"mm; u, U in µm"``, so that a row
    never mixes units unannounced; ``unit`` alone when the two are the same."""
    du = display_unit(unit) if unit else unit
    return unit if du == unit else f"{unit}; {shown} in {du}"


def _interval(low: float, high: float, u: float) -> str:
    return f"[{format_value(low, u)}, {format_value(high, u)}]"


# -- uncertainty ---------------------------------------------------------------------------
@renders(GUFResult, "GUF uncertainty evaluation")
def _guf(rep: Report, g, **_) -> None:
    how = f"sensitivities: {g.sensitivity_method}"
    if g.newton_iterations:
        how += f"; implicit model solved in {g.newton_iterations} Newton iterations"
    rep.section(f"GUF results, p = {g.p:g}", how)
    rows = []
    for j, name in enumerate(g.names):
        u = float(g.standard_uncertainty[j])
        rows.append(
            [
                name,
                format_value(float(g.estimate[j]), u),
                _uncertainty(u, g.units[j]),
                _uncertainty(float(g.expanded_uncertainty[j]), g.units[j]),
                format_k(float(g.coverage_factor[j])),
                _interval(*g.interval[j], u),
                _dof(float(g.dof_effective[j])),
                _unit_cell(g.units[j], "u, U"),
            ]
        )
    rep.table(["output", "value", "u", "U", "k", "interval", "ν_eff", "unit"], rows)
    for j, name in enumerate(g.names):
        budget = g.budget(j)
        lines, shown = budget_cells(budget, g.units[j])
        unit = display_unit(g.units[j]) if g.units[j] else ""
        rep.section(f"Uncertainty budget of {name}")
        caption = f"Contributions u_i({name}) = |c_i| u(x_i) in {unit}; " if unit else ""
        rep.table(budget_columns(name), lines, caption=caption + SHARE_DEFINITION + ".")
        rep.figure(
            figures.budget_bars(
                [budget[i].input for i in shown],
                [budget[i].share for i in shown],
                title=f"Uncertainty budget of {name}",
            ),
            caption=f"Share of u_c²({name}) of each input, as in the table: {SHARE_DEFINITION}.",
        )
    if 1 < len(g.names) <= MAX_MAPPED:
        rep.section("Correlation of the outputs")
        rep.figure(figures.correlation_heatmap(g.names, g.correlation))
        rep.figure(
            figures.coverage_ellipses(g.names, g.estimate, g.covariance, p=g.p, units=g.units),
            caption="Bivariate marginal coverage regions of the GUF (χ²₂ quantile).",
        )


@renders(MCMResult, "Monte Carlo uncertainty evaluation")
def _mcm(rep: Report, r, *, names=None, units=None, guf=None, **_) -> None:
    """``names``, ``units``: of the outputs; ``guf``: a GUFResult drawn over the histograms."""
    names = list(names or r.names)
    units = list(units or r.units)
    rep.section(f"Monte Carlo results, p = {r.p:g} ({r.trials} trials)", r.message)
    rows = []
    for j in range(r.m):
        u = float(r.standard_uncertainty[j])
        rows.append(
            [
                names[j],
                format_value(float(r.estimate[j]), u),
                _uncertainty(u, units[j]),
                _interval(*r.interval[j], u),
                _interval(*r.interval_shortest[j], u),
                _unit_cell(units[j], "u"),
            ]
        )
    rep.table(["output", "value", "u", "symmetric interval", "shortest interval", "unit"], rows)
    for j in range(r.m):
        mean, u, dof, g_interval = (
            float(r.estimate[j]),
            float(r.standard_uncertainty[j]),
            None,
            None,
        )
        if guf is not None:
            mean, u = float(guf.estimate[j]), float(guf.standard_uncertainty[j])
            dof, g_interval = float(guf.dof_effective[j]), guf.interval[j]
        rep.figure(
            figures.histogram_vs_normal(
                r.histogram(j),
                mean,
                u,
                names[j],
                units[j],
                dof=dof,
                interval=r.interval[j],
                guf_interval=g_interval,
            ),
            caption=f"Monte Carlo distribution of {names[j]} against the "
            + ("GUF distribution." if guf is not None else "normal of its mean and u."),
        )
    if 1 < r.m <= MAX_MAPPED:
        rep.figure(
            figures.correlation_heatmap(names, r.correlation, title="Correlation (Monte Carlo)")
        )
        if guf is not None:
            rep.figure(
                figures.coverage_ellipses(
                    names,
                    guf.estimate,
                    guf.covariance,
                    p=r.p,
                    units=units,
                    samples=r.samples,
                    mcm_mean=r.estimate,
                    mcm_covariance=r.covariance,
                ),
                caption="Bivariate marginal coverage regions: GUF and Monte Carlo.",
            )


@renders(ValidationReport, "Validation of the GUF")
def _validation(rep: Report, v, *, units=None, **_) -> None:
    """``units``: the unit of each output by name (the rows' values are in it)."""
    verdict = "validated" if v.passed else "NOT validated"
    units = units or {}
    rep.section(f"Validation of the GUF by Monte Carlo: {verdict}", v.message)
    rep.table(
        ["output", "quantity", "unit", "GUF", "MCM", "|difference|", "δ", "ratio", "passed"],
        [
            [
                w.name,
                w.quantity,
                _unit_cell(units[w.name], "|difference|, δ") if units.get(w.name) else "—",
                format_value(w.guf, w.tolerance),
                format_value(w.mcm, w.tolerance),
                _uncertainty(w.difference, units.get(w.name, "")),
                _uncertainty(w.tolerance, units.get(w.name, "")),
                f"{100 * w.ratio:.0f} %",
                w.passed,
            ]
            for w in v.rows
        ],
        caption=f"procedure: {v.procedure}, p = {v.p:g}; values to the decimal of the "
        "numerical tolerance δ (JCGM 101:2008, 7.9.2)",
    )


# -- identification ------------------------------------------------------------------------
@renders(ModelEvaluation, "Measurement uncertainty")
def _model_evaluation(rep: Report, e, **_) -> None:
    """The validation first (its verdict decides which result to quote), then each method."""
    if e.validation is not None:
        units = dict(zip(e.output_names, e.output_units, strict=False))
        _validation(rep, e.validation, units=units)
    if e.guf is not None:
        _guf(rep, e.guf)
    if e.mcm is not None:
        _mcm(rep, e.mcm, names=e.output_names, units=e.output_units or None, guf=e.guf)


@renders(IdentifiabilityReport, "Identifiability")
def _identifiability(rep: Report, d, **_) -> None:
    rep.section("Identifiability", d.message)
    rows = [
        ["unknowns", d.n_unknowns],
        ["rank", d.rank],
        ["condition number (columns scaled)", f"{d.condition_scaled:.4g}"],
        ["condition number (internal units)", f"{d.condition_raw:.4g}"],
    ]
    rows += [[f"observability {k}", f"{v:.4g}"] for k, v in d.observability.items()]
    rep.table(["quantity", "value"], rows)
    if d.null_directions:
        rep.table(
            ["unidentifiable combination", "coefficients (columns scaled)"],
            [[str(n), n.combination()] for n in d.null_directions],
        )
    rep.figure(
        figures.singular_values(d.singular_values),
        caption="A gap of decades before the last values marks what the set-up cannot separate.",
    )


def _rms(v) -> str:
    return "—" if v is None else format_uncertainty(float(v))


@renders(ModelAdequacy, "Model adequacy")
def _adequacy(rep: Report, result, patterns: dict | None = None, **_) -> None:
    """The chi-squared test of the residuals in words and numbers, then the residual RMS by
    group (``patterns`` of :func:`mtmetrology.identification.residual_patterns`): where the
    model misses, a group's weighted RMS stands well above 1."""
    rep.section("Model adequacy", result.message)
    rep.table(
        ["quantity", "value"],
        [
            ["variance factor s² = χ²/ν", "—" if result.variance_factor is None
             else f"{result.variance_factor:.3g}"],
            ["degrees of freedom ν = m − rank", result.dof],
            ["p = P(χ²_ν ≥ χ²)", "—" if result.p_value is None
             else "< 1e-300" if result.p_value == 0 else f"{result.p_value:.2g}"],
            ["significance level", result.alpha],
            ["rule", result.rule],
            ["covariance scaled", "yes" if result.scaled else "no"],
            ["covariance factor", f"{result.factor:.3g}"],
        ],
    )  # fmt: skip
    for name, groups in (patterns or {}).items():
        if name == "component":
            continue
        unit = next((k[4:] for k in groups[0] if k.startswith("rms_") and k != "rms_weighted"), "")
        key = f"rms_{unit}"
        vector = f"{key}_components" in groups[0]
        weighted = "rms_weighted" in groups[0]
        columns = [name, "n", f"RMS ({unit})"]
        columns += [f"RMS {c} ({unit})" for c in "xyz"] if vector else []
        columns += ["weighted RMS (1 = stated noise)"] if weighted else []
        rows = []
        for g in groups:
            row = [g["group"], g["n"], _rms(g[key])]
            row += [_rms(v) for v in g[f"{key}_components"]] if vector else []
            row += [f"{g['rms_weighted']:.3g}"] if weighted else []
            rows.append(row)
        rep.table(columns, rows, caption=f"Residual RMS by {name}")


@renders(IdentificationResult, "Identification")
def _identification(rep: Report, result, **_) -> None:
    rep.section("Identification", result.message)
    vf = result.variance_factor
    rep.table(
        ["quantity", "value"],
        [
            ["status", result.status],
            ["iterations", result.nit],
            ["cost ½‖r‖²", result.cost],
            ["redundancy m − rank", result.dof],
            ["variance factor", "— (no redundancy)" if vf is None else vf],
            ["residuals", result.residuals.size],
            ["rms weighted residual", float(np.sqrt(np.mean(result.residuals**2)))],
        ],
    )
    if result.adequacy is not None:
        _adequacy(rep, result.adequacy)
    u = result.standard_uncertainty
    rep.table(
        ["unknown", "estimate", "u"],
        [
            [n, format_value(float(x), float(s)), format_uncertainty(float(s))]
            for n, x, s in zip(result.names, result.estimate, u, strict=True)
        ],
        caption="internal units: mm, rad, dimensionless",
    )
    if len(result.names) <= MAX_MAPPED:
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = result.covariance / np.outer(u, u)
        rep.figure(figures.correlation_heatmap(result.names, np.nan_to_num(corr)))
    _identifiability(rep, result.diagnostics)


# -- fitting and parameter sets --------------------------------------------------------------
def add_fit_document(rep: Report, document: dict, residuals, points=None) -> Report:
    """Append a ``fit-result`` document (what ``mtm fit --json`` prints) to a report.

    Parameters
    ----------
    rep : Report
    document : dict
        From :func:`mtmetrology.fitting.documents.fit_document`.
    residuals : (n,) array_like, mm
        Signed deviations of the points from the element.
    points : (n, 3) array_like, mm, optional
        The points, to draw their deviations in three projections.
    """
    form = document["form_error"]
    stats = document["residuals"]
    rms = float(convert(stats["rms"], stats["unit"], "µm"))

    def cell(value: float, unit: str) -> str:
        return format_fitted(value, unit, rms)

    rep.section(f"{document['element']} ({document['method']})", document.get("message"))
    rep.table(
        ["parameter", "value", "unit"],
        [[p["name"], cell(p["value"], p["unit"]), p["unit"]] for p in document["parameters"]],
        caption="No uncertainty is stated for a fit: values are rounded to the second "
        "significant digit of the residual rms, which bounds their standard uncertainty.",
    )
    rep.table(
        ["quantity", "value", "unit"],
        [
            [form["name"], cell(form["value"], form["unit"]), form["unit"]],
            ["points", stats["n"], ""],
            ["rms of the residuals", cell(stats["rms"], stats["unit"]), stats["unit"]],
            ["smallest residual", cell(stats["min"], stats["unit"]), stats["unit"]],
            ["largest residual", cell(stats["max"], stats["unit"]), stats["unit"]],
        ],
    )
    for note in document.get("notes", []):
        rep.text(f"Note: {note}")
    res = from_internal(np.asarray(residuals, dtype=float), "µm")
    if points is not None and np.shape(points)[-1] == 3:
        rep.figure(
            figures.point_deviations(points, res, unit="µm"),
            caption="Signed deviations of the points from the fitted element.",
        )
    rep.figure(
        figures.residual_profile(res, unit="µm"), caption="Deviation of each point, in file order."
    )
    return rep


@renders(FitResult, "Least-squares fit")
@renders(ZoneResult, "Chebyshev fit")
def _fit(rep: Report, result, *, points=None, source: str = "points", **_) -> None:
    """``points``: the fitted (n, 3) points, to draw their deviations."""
    from mtmetrology.fitting.documents import fit_document

    element = type(result.element).__name__.lower()
    method = getattr(result, "method", "ls")
    document = fit_document(
        element,
        method,
        source,
        result.element,
        result.residuals,
        result.form_error,
        {"message": result.message},
    )
    add_fit_document(rep, document, result.residuals, points)


@renders(ParameterSet, "Parameter set")
def _parameter_set(rep: Report, pset, *, coverage_factor: float = DEFAULT_K, **_) -> None:
    where = ", ".join(
        f"{k} {v}" for k, v in (("machine", pset.machine), ("model", pset.model)) if v
    )
    rep.section("Parameters", f"{len(pset.names)} parameters" + (f" of {where}" if where else ""))
    rep.table(
        figures.parameter_table_columns(coverage_factor),
        figures.parameter_table_rows(pset, coverage_factor=coverage_factor),
    )
    if pset.covariance is not None and 1 < len(pset.names) <= MAX_MAPPED:
        u = np.sqrt(np.diag(pset.covariance))
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = np.nan_to_num(pset.covariance / np.outer(u, u))
        rep.figure(
            figures.correlation_heatmap(pset.names, corr),
            caption="Correlation of the identified parameters.",
        )


# -- compensation ------------------------------------------------------------------------------
@renders(Compensation, "Compensated coordinates")
def _compensation(rep: Report, comp, *, nominal=None, machine=None, **_) -> None:
    """The correction c_s = f(φ_s, δ̂) − f(φ_s, 0) of each point: its size and vectors.

    ``nominal`` (the positions with the nominal, error-free kinematics, mm) gives the
    corrections; ``machine`` names the kinematics in the text. Without ``nominal`` the
    section gives the number of points and, when computed, the largest u of a coordinate.
    """
    where = "" if machine is None else f"{machine.name}, model {machine.model_name or 'custom'}: "
    points = np.asarray(comp.points)
    if nominal is None:
        rep.section(
            "Compensation",
            f"{where}x, y, z are the stylus-centre positions in the workpiece frame with the "
            "parameter set's errors.",
        )
        rows = [["points", len(points), ""]]
        if comp.u is not None:
            largest_u = float(from_internal(np.max(comp.u), "µm"))
            rows.append(["largest u of a coordinate", format_uncertainty(largest_u), "µm"])
        rep.table(["quantity", "value", "unit"], rows)
        return
    correction, largest, rms = correction_statistics(points, nominal)
    rep.section(
        "Compensation",
        f"{where}x, y, z are the stylus-centre positions in the workpiece frame with the "
        "parameter set's errors, the correction is their difference from the nominal "
        "(error-free) kinematics.",
    )
    rep.table(
        ["quantity", "value", "unit"],
        [
            ["points", len(correction), ""],
            ["largest correction", f"{largest:.4g}", "µm"],
            ["rms correction", f"{rms:.4g}", "µm"],
        ],
    )
    rep.figure(
        figures.residual_vectors(points, correction, title="Corrections"),
        caption="Correction of each point (compensated minus nominal position).",
    )
