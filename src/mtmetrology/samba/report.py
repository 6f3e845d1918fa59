"""What a report shows for the SAMBA results (registered with the report layer's ``@renders``).

- :class:`~mtmetrology.samba.calibrate.SambaCalibration` (``uncertainty=`` a
  :class:`~mtmetrology.samba.uncertainty.SambaUncertainty` when one ran): the fit, the
  parameter table with u and U, their correlation, the sign conventions and reference
  points of the parameters, the identifiability indices (rank, condition numbers, O1–O5),
  the unexplained and nominal volumetric error and the residual vector of every
  ball-centre indication on the artefact;
- :class:`~mtmetrology.samba.uncertainty.SambaUncertainty`: the GUF and Monte Carlo
  outputs, the Monte Carlo histograms against the GUF normals and the JCGM 102
  validation table (Sepahi Boroujeni (2021), Tables 5-2 and 5-3 layout);
- :class:`~mtmetrology.samba.verify.LengthCheck`: the gauge-length errors of each pair
  before and after compensation and their statistics;
- :class:`~mtmetrology.samba.campaign_unexplained.CampaignUnexplained`: cov(e) between
  campaigns against the pooled within-campaign estimate, with the estimator's terms.

Values are in customary units (µm, µrad, µm/m, mm); U = k u in the parameter table with
the document's one coverage factor (``coverage.k``: 2 by default, the k of the GUF
outputs; :func:`mtmetrology.samba.calibrate.coverage`).

References
----------
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, Tables 5-2, 5-3 and 7-1.

Alami Mchichi, N. (2018). *Étalonnage des machines-outils à cinq axes : configuration
optimisée des artefacts et de la séquence de mesure de la méthode SAMBA en vue d'une
estimation efficace des erreurs géométriques*. PhD thesis, École Polytechnique de
Montréal, §3 (the SAMBA method, unexplained volumetric error).
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from mtmetrology.formatting import format_k, format_uncertainty, format_value
from mtmetrology.report import figures
from mtmetrology.report.document import Report
from mtmetrology.report.figures.style import legend_below
from mtmetrology.report.results import add_result, renders
from mtmetrology.samba.calibrate import SambaCalibration
from mtmetrology.samba.campaign_unexplained import ESTIMATOR, CampaignUnexplained
from mtmetrology.samba.identifiability import SetupIdentifiability
from mtmetrology.samba.uncertainty import SambaUncertainty
from mtmetrology.samba.verify import LengthCheck
from mtmetrology.units import from_internal

__all__ = ["indication_residuals", "length_error_bars"]

#: Correlation maps of the error parameters are drawn up to this many parameters.
MAX_MAPPED = 90


def indication_residuals(cal) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Residual vector of every ball-centre indication, placed at its ball on the artefact.

    Parameters
    ----------
    cal : SambaCalibration

    Returns
    -------
    centres : (n, 3) ndarray, mm
        Identified centre (workpiece frame) of the ball of each indication.
    residuals : (n, 3) ndarray, µm
        Unexplained volumetric error of each indication (indication minus model).
    balls : list of str
        Ball id of each indication.
    """
    centres = cal.ball_centres()
    balls = list(cal.records.balls)
    points = np.array([centres[b] for b in balls])
    return points, from_internal(cal.residual_vectors, "µm"), balls


def _correlation(covariance) -> np.ndarray:
    cov = np.asarray(covariance, dtype=float)
    u = np.sqrt(np.diag(cov))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.nan_to_num(cov / np.outer(u, u))


@renders(SetupIdentifiability, "Identifiability of a probing set-up")
def _setup_identifiability(rep: Report, result, **_) -> None:
    rep.section("Set-up").table(["item", "value"], result.setup_rows())
    add_result(rep, result.diagnosis)


@renders(SambaCalibration, "SAMBA calibration")
def _calibration(rep: Report, cal, *, uncertainty=None, policy=None, **_) -> None:
    """``uncertainty``: the SambaUncertainty that sets the parameter covariance; ``policy``
    the coverage policy of U (default k = 2)."""
    uncertainty = cal.uncertainty if uncertainty is None else uncertainty
    doc = cal.to_dict(uncertainty, policy=policy)
    ident, rec, vol = doc["identification"], doc["records"], doc["volumetric_error"]
    rep.section(f"SAMBA calibration of {cal.machine.name}", ident["message"])
    rep.table(
        ["quantity", "value"],
        [
            ["status", ident["status"]],
            ["iterations", ident["iterations"]],
            ["records", f"{rec['form']} ({rec['source']})"],
            ["indications", rec["indications"]],
            ["σ of a reading (µm)", f"{rec['sigma_um']:.3g}"],
            ["unknowns", ident["unknowns"]],
            ["minimum-norm solution", ident["minimum_norm"]],
            ["tool vector (mm)", ", ".join(f"{v:.4f}" for v in doc["tool_mm"])],
            ["tool estimated", doc["tool_estimated"]],
            ["tool prior u (mm)", ", ".join(f"{p['u']:.4g}" for p in doc["priors"]) or "none"],
            ["unexplained volumetric error, mean (µm)", f"{vol['unexplained']['mean_um']:.3g}"],
            ["unexplained volumetric error, max (µm)", f"{vol['unexplained']['max_um']:.3g}"],
            ["nominal-model volumetric error, mean (µm)", f"{vol['nominal_model']['mean_um']:.3g}"],
            ["nominal-model volumetric error, max (µm)", f"{vol['nominal_model']['max_um']:.3g}"],
        ],
    )
    if cal.identification.adequacy is not None:
        add_result(rep, cal.identification.adequacy, patterns=doc["residual_patterns"])
    rep.section(
        "Error parameters",
        f"{len(doc['parameters'])} parameters; covariance from {doc['covariance_source']}.",
    )
    k = doc["coverage"]["k"]
    rep.table(
        figures.parameter_table_columns(k),
        figures.parameter_table_rows(doc, coverage_factor=k),
    )
    cov = doc.get("covariance")
    if cov is not None and 1 < len(cov["names"]) <= MAX_MAPPED:
        rep.figure(
            figures.correlation_heatmap(cov["names"], _correlation(cov["matrix"])),
            caption="Correlation of the identified error parameters (ball centres and tool "
            "vector marginalised).",
        )
    rep.section(
        "Uncertainty propagation factors",
        f"UPF = u / σ (Alami Mchichi (2018) eq. 6.14): u = sqrt(diag((JᵀWJ)⁻¹)) of the "
        f"identification for σ = {rec['sigma_um']:.3g} µm per coordinate and the scale bar's "
        "u together, over σ in µm (not a sensitivity to σ alone: for a scale parameter "
        "such as E_XX1 the bar's u dominates); the figure `mtm samba plan` predicts for the "
        "same "
        "set-up.",
    )
    if doc["propagation_factors"] and doc["propagation_factors"][0]["upf"] is not None:
        rep.table(
            ["parameter", "u", "unit", "UPF", "UPF unit"],
            [
                [f["name"], format_uncertainty(f["u"]), f["unit"], upf, f["upf_unit"]]
                for f in doc["propagation_factors"]
                for upf in [format_uncertainty(f["upf"])]
            ],
            caption="Two significant digits (JCGM 100:2008, 7.2.6); RESULT.json keeps full "
            "precision.",
        )
    rep.section(
        "Sign conventions and reference points",
        "What a positive value of each parameter does and the point it is referred to.",
    )
    rep.table(
        ["parameter", "unit", "axis", "positive value", "referred to", "reference point (mm)"],
        [
            [
                c["name"],
                c["unit"],
                c["axis"],
                c["positive"],
                c["reference"],
                ", ".join(f"{v:g}" for v in c["reference_point_mm"]),
            ]
            for c in doc["conventions"]
        ],
    )
    add_result(rep, cal.identification.diagnostics)
    if ident["confounded"]:
        rep.table(["confounded combination"], [[", ".join(g)] for g in ident["confounded"]])
    points, res, balls = indication_residuals(cal)
    rep.section(
        "Residual vectors of the ball-centre indications",
        "Unexplained volumetric error of each indication, drawn at its ball's identified "
        "centre on the artefact (workpiece frame).",
    )
    rep.figure(
        figures.residual_vectors(points, res, unit="µm", title="Unexplained volumetric error"),
        caption=f"{len(balls)} indications on {len(set(balls))} balls: mean norm "
        f"{vol['unexplained']['mean_um']:.3g} µm, max {vol['unexplained']['max_um']:.3g} µm.",
    )
    if uncertainty is not None:
        add_result(rep, uncertainty)


@renders(SambaUncertainty, "SAMBA uncertainty")
def _uncertainty(rep: Report, unc, **_) -> None:
    doc = unc.to_dict()
    g, mc = unc.guf, unc.mcm
    for name, r in (("GUF", g), ("Monte Carlo", mc)):
        if r is None:
            continue
        rep.section(
            f"{name} uncertainty of the error parameters, p = {r.p:g}",
            f"Indication covariance: {unc.source}."
            + ("" if name == "GUF" else f" {r.trials} trials; {r.message}"),
        )
        rep.table(
            ["parameter", "value", "u", "U", "k", "interval", "unit"],
            [
                [
                    o.name,
                    format_value(o.value, o.u),
                    format_uncertainty(o.u),
                    format_uncertainty(o.U),
                    "—" if o.k is None else format_k(o.k),
                    f"[{format_value(o.interval[0], o.u)}, {format_value(o.interval[1], o.u)}]",
                    o.unit,
                ]
                for o in r.outputs
            ],
        )
    if mc is not None:
        rep.section(
            "Monte Carlo distributions",
            "Histogram of each parameter's Monte Carlo values"
            + (" against the GUF normal." if g is not None else "."),
        )
        for j, name in enumerate(mc.names):
            mean, u = float(mc.estimate[j]), float(mc.standard_uncertainty[j])
            g_interval = None
            if g is not None:
                mean, u, g_interval = (
                    float(g.estimate[j]),
                    float(g.standard_uncertainty[j]),
                    (g.interval[j]),
                )
            rep.figure(
                figures.histogram_vs_normal(
                    mc.histogram(j),
                    mean,
                    u,
                    name,
                    mc.units[j],
                    interval=mc.interval[j],
                    guf_interval=g_interval,
                )
            )
    if unc.validation is not None:
        v = doc["validation"]
        verdict = "validated" if v["passed"] else "NOT validated"
        rep.section(f"JCGM 102 validation of the GUF by Monte Carlo: {verdict}", v["message"])
        rep.table(
            ["parameter", "unit", "value GUF", "value MCM", "u GUF", "u MCM", "δ", "validated"],
            [
                [
                    t["name"],
                    t["unit"],
                    format_value(t["value_guf"], t["tolerance"]),
                    format_value(t["value_mcm"], t["tolerance"]),
                    format_value(t["u_guf"], t["tolerance"]) if "u_guf" in t else "—",
                    format_value(t["u_mcm"], t["tolerance"]) if "u_mcm" in t else "—",
                    format_uncertainty(t["tolerance"]),
                    t["validated"],
                ]
                for t in v["table"]
            ],
            caption="Per parameter (Sepahi Boroujeni (2021), Table 5-2 layout; values to the "
            "decimal of δ, JCGM 101:2008, 7.9.2) and jointly (Table 5-3): largest eigenvalue "
            "of the covariance and the joint coverage factor.",
        )
    if g is not None:
        jc = doc["guf"]["joint_coverage"]
        rows = [[k.replace("_", " "), f"{jc[k]:.4g}"] for k in ("m", "p", "hyper_ellipsoid")]
        rows.append(["hyper-rectangle (Bonferroni)", f"{jc['hyper_rectangle_bonferroni']:.4g}"])
        if mc is not None:
            rows.append(["Monte Carlo hyper-ellipsoid", f"{mc.region_coverage_factor:.4g}"])
        rep.table(["joint coverage factor", "value"], rows, caption=jc["note"])


def length_error_bars(pairs, nominal_um, compensated_um) -> Figure:
    """Gauge-length error of each pair before and after compensation, µm.

    Parameters
    ----------
    pairs : sequence of str
    nominal_um, compensated_um : (n,) array_like, µm

    Examples
    --------
    >>> fig = length_error_bars(["1", "2"], [10.0, -8.0], [0.5, -0.2])
    >>> len(fig.axes[0].patches)
    4
    """
    en, ec = np.asarray(nominal_um, float), np.asarray(compensated_um, float)
    x = np.arange(len(pairs))
    fig = Figure(figsize=(6.4, 3.4), layout="constrained")
    ax = fig.add_subplot()
    ax.bar(x - 0.2, en, width=0.4, color="#8c959f", label="nominal model")
    ax.bar(x + 0.2, ec, width=0.4, color="#2a5d8f", label="compensated")
    ax.axhline(0.0, color="black", lw=0.8)
    ax.set_xticks(x, list(pairs), fontsize=7)
    ax.set_xlabel("pair")
    ax.set_ylabel("length error (µm)")
    legend_below(fig, ax)
    ax.set_title("Gauge-length error before and after compensation")
    return fig


@renders(LengthCheck, "Gauge-length check")
def _length(rep: Report, check, **_) -> None:
    doc = check.to_dict()
    u = "" if check.u_length is None else f", u(L) = {check.u_length:g} mm"
    rep.section(
        f"Gauge-length check, L = {check.length:g} mm{u}",
        f"{len(check.pairs)} pairs; error = measured length − L (tip radius "
        f"{check.tip_radius:g} mm), µm.",
    )
    stats = ("mean", "rms", "std", "range", "max_abs")
    rep.table(
        ["model", *[s.replace("_", " ") for s in stats]],
        [[name, *(f"{doc[name][s]:.3g}" for s in stats)] for name in ("nominal", "compensated")],
        caption="errors in µm",
    )
    if doc["thermal"] is not None or doc["u_error_max_um"] is not None:
        t = doc["thermal"]
        rows = [["reference length L_T (mm)", f"{doc['reference_length_mm']:.6f}"]]
        if t is not None:
            rows += [
                [
                    "sensitivity to temperature (µm/°C)",
                    f"{1e3 * t['sensitivities']['temperature']:.3g}",
                ],
                *[
                    [f"u contribution of {k} (µm)", format_uncertainty(1e3 * v)]
                    for k, v in t["contributions_mm"].items()
                ],
            ]
        if doc["u_tip_diameter_mm"] is not None:
            rows.append(
                [
                    "u(d_tip), reference sphere (µm)",
                    format_uncertainty(1e3 * doc["u_tip_diameter_mm"]),
                ]
            )
        if doc["u_gauge_um"] is not None:
            rows.append(["u of the gauge, u_g (µm)", format_uncertainty(doc["u_gauge_um"])])
        if doc["u_error_max_um"] is not None:
            rows.append(["largest u(e) (µm)", format_uncertainty(doc["u_error_max_um"])])
        rep.table(
            ["reference", "value"],
            rows,
            caption="L_T = L20 (1 + α (T − 20 °C)); u(e_i)² = u_g² + g_i U_θ g_iᵀ, "
            "u_g² = u²(L_T) + u²(d_tip), g_i = ∂ℓ_i/∂θ"
            + ("" if doc["calibration_in_u"] else " (no U_θ given: the gauge's part only)")
            + ".",
        )
    with_u = doc["u_error_max_um"] is not None  # a u(e) column when there is one to show
    rep.table(
        ["pair", "error, nominal (µm)", "error, compensated (µm)", *(["u(e) (µm)"] * with_u)],
        [
            [
                p["pair"],
                f"{p['error_nominal_um']:.3g}",
                f"{p['error_compensated_um']:.3g}",
                *([format_uncertainty(p["u_error_um"])] * with_u),
            ]
            for p in doc["pairs"]
        ],
    )
    rep.figure(
        length_error_bars(
            [p["pair"] for p in doc["pairs"]],
            [p["error_nominal_um"] for p in doc["pairs"]],
            [p["error_compensated_um"] for p in doc["pairs"]],
        ),
        caption="Error of each pair with the nominal model and after compensation.",
    )


@renders(CampaignUnexplained, "cov(e) from SAMBA campaigns")
def _campaign_unexplained(rep: Report, result, **_) -> None:
    k, n = result.residuals.shape[:2]
    b, w = result.between, result.within
    rep.section(
        "Unexplained volumetric error from repeated campaigns",
        f"{k} campaigns of {n} common positions, each calibrated on its own with "
        f"{result.fitted_parameters} unknowns and σ = "
        f"{format_uncertainty(float(from_internal(result.sigma, 'µm')))} µm per coordinate. "
        f"Estimator {ESTIMATOR}. The within-campaign estimate (ν = K(n − p/3)) also holds "
        "an error field that repeats identically in every campaign; the between-campaign "
        "one (written to E.json) only what changes from one campaign to the next.",
    )
    rows = []
    for name, est in (("between campaigns", b), ("within campaigns", w)):
        u = from_internal(est.u, "µm")
        rows.append(
            [
                name,
                f"{est.degrees_of_freedom:.1f}",
                *(format_uncertainty(float(v)) for v in u),
                "yes" if est.clipped else "no",
            ]
        )
    rep.table(["estimate", "ν", "u(e_x) µm", "u(e_y) µm", "u(e_z) µm", "clipped"], rows)
    cov = result.to_dict()["covariance"]  # µm²
    rep.table(
        ["", "x", "y", "z"],
        [[a, *(f"{v:.3g}" for v in row)] for a, row in zip("xyz", cov, strict=True)],
        caption="cov(e) between campaigns, µm² (positive semidefinite).",
    )
