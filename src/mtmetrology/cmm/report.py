"""What a report shows for the CMM results (registered with the report layer's ``@renders``).

- :class:`~mtmetrology.cmm.calibrate.BallPlateCalibration`: the fit, the parameter table
  with u and U, their correlation, the datum, the rank diagnostics, the residual vectors
  of the ball centres in each plate position, U1/U2/U3 and maps of the model uncertainty
  over the volume, and (``model_selection=``) the held-out scores of ``--model auto``;
- :class:`~mtmetrology.cmm.gp.GPErrorModel`: hyper-parameters per component and the
  training residuals;
- :class:`~mtmetrology.cmm.compare.ModelComparison`: the held-out table and the length
  errors of each model with their ±2u bars.
- :class:`~mtmetrology.cmm.heldout.HeldOutComparison`: the same against the plate
  certificate (``mtm cmm compare``).

The ball-plate budget is a :class:`~mtmetrology.uncertainty.GUFResult`, shown by the
report layer's own renderer (budget bars).

Values are in customary units (µm, µrad, µm/m); U = k u with k = 2.

References
----------
Salacheep, P. (2016). *Error Compensation and Uncertainty Evaluation of CMMs Based on
Kinematic Error Models and Gaussian Processes*. MPhil thesis, Brunel University London,
§6.4 (U1, U2, U3), Ch. 7 (kinematic versus GP).
"""

from __future__ import annotations

import numpy as np

from mtmetrology.cmm.budget import BallPlateLengthBudget
from mtmetrology.cmm.calibrate import BallPlateCalibration
from mtmetrology.cmm.compare import ModelComparison
from mtmetrology.cmm.gp import GPErrorModel
from mtmetrology.cmm.gpml import SourceGPDemo
from mtmetrology.cmm.heldout import HeldOutComparison
from mtmetrology.cmm.probecal import ProbeCalibration
from mtmetrology.cmm.selfcal import SelfCalibrationDesign
from mtmetrology.formatting import format_uncertainty
from mtmetrology.report import figures
from mtmetrology.report.document import Report
from mtmetrology.report.results import add_result, renders
from mtmetrology.uncertainty.coverage import DEFAULT_K
from mtmetrology.units import from_internal

__all__ = ["COVERAGE_FACTOR", "ball_residuals", "uncertainty_map"]

#: k of the expanded uncertainties shown.
COVERAGE_FACTOR = DEFAULT_K  # the coverage policy (mtmetrology.uncertainty.coverage)
#: Correlation maps of the error parameters are drawn up to this many parameters.
MAX_MAPPED = 80
#: Grid of the uncertainty maps (points per axis).
MAP_POINTS = 13


def ball_residuals(cal) -> list[tuple[str, np.ndarray, np.ndarray, list[str]]]:
    """Residual vectors of the ball centres, per plate position.

    Parameters
    ----------
    cal : BallPlateCalibration

    Returns
    -------
    list of (position, centres (m, 3) mm, residuals (m, 3) µm, ball ids)
        For each position, the fitted machine-frame ball centres ``T_l(y_i)`` and the
        indication residual ``p(q; θ̂, t) − T_l(y_i)`` averaged over the styli that
        probed the ball.
    """
    prob, res = cal.problem, cal.identification
    n = len(prob.readings)
    _, poses, balls = prob.split(res.estimate)
    centres = prob.plate_points(poses, balls)
    r = from_internal(prob.sigma * res.residuals[: 3 * n].reshape(n, 3), "µm")
    positions = np.asarray(prob.records.positions)
    ball_ids = np.asarray(prob.records.balls)
    out = []
    for pid in prob.position_ids:
        sel = positions == pid
        ids = list(dict.fromkeys(ball_ids[sel]))
        pts = np.array([centres[sel & (ball_ids == b)].mean(axis=0) for b in ids])
        mean = np.array([r[sel & (ball_ids == b)].mean(axis=0) for b in ids])
        out.append((pid, pts, mean, ids))
    return out


def uncertainty_map(cal, plane: str, n: int = MAP_POINTS):
    """Standard uncertainty of the compensated point, ``sqrt(u_x² + u_y² + u_z²)`` in µm.

    On a grid over the whole travel in ``plane``, the third axis at the middle of the
    measured region, with the probe of the U2/U3 summary; the covariance of each point is
    ``J Σ_θ Jᵀ`` (:func:`~mtmetrology.cmm.calibrate.error_covariance`), the full
    covariance of the error parameters, as for U2 and U3.

    Parameters
    ----------
    cal : BallPlateCalibration
    plane : {"XY", "XZ", "YZ"}
        The two axes of the map.
    n : int
        Grid points per axis.

    Returns
    -------
    a, b : (n,) mm
        Grid coordinates along the plane's two axes.
    u : (n, n) µm
        Indexed ``[b, a]``.
    """
    from mtmetrology.cmm.calibrate import error_covariance

    summary, m = cal.summary, cal.machine
    i, j = ("XYZ".index(plane[0]), "XYZ".index(plane[1]))
    k = 3 - i - j
    volume = np.asarray(summary["volume_mm"], dtype=float)  # [[lo x, y, z], [hi x, y, z]]
    region = np.asarray(summary["region_mm"], dtype=float)
    a = np.linspace(volume[0, i], volume[1, i], n)
    b = np.linspace(volume[0, j], volume[1, j], n)
    q = np.zeros((n * n, 3))
    q[:, i] = np.tile(a, n)
    q[:, j] = np.repeat(b, n)
    q[:, k] = 0.5 * (region[0, k] + region[1, k])
    cov = error_covariance(
        m, cal.theta, cal.parameters.covariance, q, np.asarray(summary["probe_offset_mm"])
    )
    u = np.sqrt(np.clip(np.trace(cov, axis1=1, axis2=2), 0.0, None))
    return a, b, from_internal(u, "µm").reshape(n, n)


def _correlation(covariance) -> np.ndarray:
    u = np.sqrt(np.diag(covariance))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.nan_to_num(covariance / np.outer(u, u))


@renders(BallPlateLengthBudget, "Ball-plate length budget")
def _length_budget(rep: Report, b, **_) -> None:
    """The GUF budget of the length, then the CMM statement at it (eqs 3.10–3.13)."""
    add_result(rep, b.guf)
    st = b.statement
    if st is not None:
        rep.section(
            f"CMM statement at {st.length_mm:g} mm",
            f"Expanded uncertainties at k = {st.k:g} (Salacheep (2016), eqs 3.10–3.13).",
        )
        rep.table(
            ["quantity", "value (µm)"],
            [
                ["U of the CMM (specification)", f"{st.U_cmm_um:.3f}"],
                ["U of the plate (certificate)", f"{st.U_plate_um:.3f}"],
                ["MPE", f"{st.mpe_um:.3f}"],
                ["U(P), eq. 3.12", format_uncertainty(st.U_P_um)],
                ["U(E), eq. 3.13", format_uncertainty(st.U_E_um)],
            ],
        )


@renders(BallPlateCalibration, "Ball-plate calibration of a CMM")
def _calibration(rep: Report, cal, *, model_selection: dict | None = None, **_) -> None:
    """``model_selection``: the scores of ``cross_validate`` (``--model auto``)."""
    doc = cal.to_document(model_selection)
    fit = doc["fit"]
    rep.section(
        f"Ball-plate calibration: model {cal.model}",
        cal.identification.message,
    )
    rep.table(
        ["quantity", "value"],
        [
            ["status", fit["status"]],
            ["iterations", fit["iterations"]],
            ["indications", fit["n_indications"]],
            ["plate positions", ", ".join(fit["positions"])],
            ["unknowns", fit["n_unknowns"]],
            ["rank", fit["rank"]],
            ["condition number (columns scaled)", f"{fit['condition_scaled']:.4g}"],
            ["σ of a reading (µm)", fit["sigma_um"]],
            ["rms residual (µm)", f"{fit['rms_residual_um']:.3g}"],
            ["variance factor", "—" if fit["variance_factor"] is None else fit["variance_factor"]],
            ["χ² p-value", "—" if fit["chi2_p_value"] is None else f"{fit['chi2_p_value']:.3g}"],
        ],
    )
    if cal.identification.adequacy is not None:
        add_result(rep, cal.identification.adequacy, patterns=doc["residual_patterns"])
    if model_selection is not None:
        _model_selection(rep, model_selection)
    pset = cal.parameters
    rep.section("Error parameters", f"{len(pset.names)} parameters of model {cal.model}")
    rep.table(
        figures.parameter_table_columns(COVERAGE_FACTOR),
        figures.parameter_table_rows(pset, coverage_factor=COVERAGE_FACTOR),
    )
    if pset.covariance is not None and 1 < len(pset.names) <= MAX_MAPPED:
        rep.figure(
            figures.correlation_heatmap(pset.names, _correlation(pset.covariance)),
            caption="Correlation of the identified error parameters (plate poses and ball "
            "centres marginalised).",
        )
    datum = doc["datum"]
    rep.section("Datum", datum["rule"])
    rep.table(
        ["term left out", "a combination of (with the plate poses)"],
        [[d["name"], ", ".join(d["combination_of"]) or "the plate poses"] for d in datum["dropped"]]
        or [["—", "no term left out"]],
    )
    add_result(rep, cal.identification.diagnostics)
    rep.section(
        "Residual vectors of the ball centres",
        "Indication minus fitted plate point, averaged over the styli, for each plate "
        "position (machine frame).",
    )
    for pid, pts, r, ids in ball_residuals(cal):
        rep.figure(
            figures.residual_vectors(pts, r, unit="µm", labels=ids, title=f"Position {pid}"),
            caption=f"Plate position {pid}: residuals of the {len(ids)} ball centres.",
        )
    _uncertainty(rep, cal)


def _model_selection(rep: Report, selection: dict) -> None:
    rep.section(
        f"Model selection: {selection['chosen']}",
        f"{selection['method']}. Folds compared: {len(selection['common_folds'])} of "
        f"{len(selection['folds'])}"
        + ("" if selection["fair"] else f" ({selection['reason']})")
        + ".",
    )
    positions = selection["positions"]
    rows = []
    for s in selection["scores"]:
        verdict = (
            "chosen"
            if s["model"] == selection["chosen"]
            else "scored"
            if s["scored"]
            else "compared by AIC"
            if s["eligible"]
            else "not identifiable"
        )
        rows.append(
            [
                s["model"] + (" (chosen)" if s["model"] == selection["chosen"] else ""),
                "—" if s["median_rms_um"] is None else f"{s['median_rms_um']:.3g}",
                "—" if s["mean_rms_um"] is None else f"{s['mean_rms_um']:.3g}",
                "—" if s["aic"] is None else f"{s['aic']:.1f}",
                verdict,
                *("—" if v is None else f"{v:.3g}" for v in s["rms_um"]),
            ]
        )
    rep.table(
        ["model", "median RMS (µm)", "pooled RMS (µm)", "AIC", "verdict", *positions],
        rows,
        caption="RMS of the held-out indications (compensated, minus the fitted plate "
        "point), µm: median over the folds compared, pooled over them, and pooled per plate "
        "position.",
    )


def _uncertainty(rep: Report, cal) -> None:
    s = cal.summary
    rep.section(
        "Uncertainty of the compensated coordinates: u1, u2, u3",
        f"Mean standard uncertainty per axis at the ball centres (u1), over the measured "
        f"region (u2) and over the whole volume (u3), from the {s['method']}; u2 and u3 "
        f"are averages over {s['n_points']} random points (the source's U1, U2, U3: "
        "standard uncertainties, not expanded).",
    )
    rep.table(
        ["quantity", "x (µm)", "y (µm)", "z (µm)"],
        [
            ["u1: ball centres", *(format_uncertainty(v) for v in s["U1_um"])],
            ["u2: measured region", *(format_uncertainty(v) for v in s["U2_um"])],
            ["u3: whole volume", *(format_uncertainty(v) for v in s["U3_um"])],
        ],
    )
    region = np.round(np.asarray(s["region_mm"]), 1).tolist()
    a, b, u = uncertainty_map(cal, "XY")
    rep.figure(
        figures.error_map(
            a, b, u, name="u of the compensated point", title="Model uncertainty over the XY travel"
        ),
        caption=f"sqrt(u_x² + u_y² + u_z²) over the XY travel, Z at the middle of the measured "
        f"region {region[0]} to {region[1]} mm: u2 inside that region, u3 beyond it.",
    )


@renders(GPErrorModel, "Gaussian-process error model of a CMM")
def _gp(rep: Report, gp, **_) -> None:
    doc = gp.to_document()
    mean = "zero mean" if gp.mean is None else f"kinematic mean ({gp.mean.model})"
    rep.section(
        f"Gaussian-process error model ({gp.kernel} kernel, {mean})",
        f"One GP per error component on the axis readings, hyper-parameters by maximum "
        f"likelihood; {len(gp.inputs)} training indications.",
    )
    rep.table(
        ["component", "amplitude s (µm)", "length-scale ℓ (mm)", "noise σ (µm)", "log ML"],
        [
            [
                c["component"],
                f"{c['amplitude_um']:.3g}",
                f"{c['length_scale_mm']:.4g}",
                f"{c['noise_um']:.3g}",
                f"{c['log_marginal_likelihood']:.4g}",
            ]
            for c in doc["components"]
        ],
    )
    flags = gp.at_bounds
    if flags:
        rep.text(
            "Warning: hyper-parameters at a bound of their search range, so the likelihood "
            "has no interior optimum there: "
            + "; ".join(str(f) for f in flags)
            + ". A length-scale at its upper bound makes that component a constant offset; "
            "an amplitude at its lower bound leaves the kinematic mean alone."
        )
    fitted = np.column_stack([g.predict(gp.inputs) for g in gp.regressors])
    resid = gp.targets_um - fitted
    rep.section(
        "Training residuals",
        "Errors seen at the training indications minus the GP mean there (µm): of the "
        "size of the fitted noise σ when the GP neither under- nor over-fits.",
    )
    rep.table(
        ["component", "rms of the errors (µm)", "rms residual (µm)", "largest |residual| (µm)"],
        [
            [
                c,
                f"{np.sqrt(np.mean(gp.targets_um[:, k] ** 2)):.3g}",
                f"{np.sqrt(np.mean(resid[:, k] ** 2)):.3g}",
                f"{np.max(np.abs(resid[:, k])):.3g}",
            ]
            for k, c in enumerate("xyz")
        ],
    )
    rep.figure(
        figures.residual_vectors(gp.inputs, resid, unit="µm", title="GP training residuals"),
        caption="Training residuals at the axis readings of the indications.",
    )


@renders(ModelComparison, "Kinematic versus GP error model")
def _comparison(rep: Report, comp, **_) -> None:
    k = comp.table[0]["coverage_factor"] if comp.table else COVERAGE_FACTOR
    rep.section(
        "Kinematic and GP models on a held-out plate position",
        "Lengths between the balls of a position neither model saw, against the true "
        f"lengths; coverage is the fraction of lengths with |error| ≤ {k:g} u.",
    )
    rep.table(
        ["model", "lengths", "rms error (µm)", "max |error| (µm)", "mean u (µm)", "coverage"],
        [
            [
                r["model"],
                r["n_lengths"],
                f"{r['rms_error_um']:.3g}",
                f"{r['max_error_um']:.3g}",
                format_uncertainty(r["mean_u_um"]),
                f"{100 * r['coverage']:.0f} %",
            ]
            for r in comp.table
        ],
    )
    rep.figure(
        figures.length_errors(comp.plot, coverage_factor=k),
        caption=f"Length error of each model with its ±{k:g}u bar; red points are not covered.",
    )
    if comp.gp_at_bounds:
        rep.text(
            "Warning: the GP's hyper-parameters ended at a bound of their search range ("
            + "; ".join(
                f"{f['component']}: {f['hyperparameter']} = {f['value']:.3g} {f['unit']}, "
                f"{f['side']} bound"
                for f in comp.gp_at_bounds
            )
            + "): where the amplitude is at its lower bound the GP predicts its kinematic "
            "mean, and the two rows of the table agree by construction."
        )


@renders(HeldOutComparison, "Kinematic versus GP error model")
def _held_out(rep: Report, comp, **_) -> None:
    k = comp.table[0]["coverage_factor"] if comp.table else COVERAGE_FACTOR
    rep.section(
        f"Kinematic and GP models on held-out positions {', '.join(comp.held_out)}",
        "Lengths between the balls of a position neither model saw (same stylus), against "
        "the plate certificate's lengths; u includes the certificate's; coverage is the "
        f"fraction of lengths with |error| ≤ {k:g} u.",
    )
    rep.table(
        ["model", "lengths", "rms error (µm)", "max |error| (µm)", "mean u (µm)", "coverage"],
        [
            [r["model"], r["n_lengths"], f"{r['rms_error_um']:.2g}", f"{r['max_error_um']:.2g}",
             f"{r['mean_u_um']:.2g}", f"{100 * r['coverage']:.0f} %"]
            for r in comp.table
        ],
    )  # fmt: skip
    rep.figure(
        figures.length_errors(comp.plot, coverage_factor=k),
        caption=f"Length error of each model with its ±{k:g}u bar; red points are not covered.",
    )


@renders(SourceGPDemo, "The source's GP re-run")
def _source_gp(rep: Report, demo, **_) -> None:
    rep.section(
        "The source's GP (GPML port)",
        "Training data from gpml_randn(0.01, 9); SE-iso covariance, Gaussian noise, "
        "hyper-parameters [β, log ℓ, log σ_f, log σ_n] by maximum marginal likelihood.",
    )
    rep.table(
        ["mean", "hyper-parameters", "NLML"],
        [
            [gp.mean, ", ".join(f"{v:.6f}" for v in gp.hyperparameters), f"{gp.nlml:.5f}"]
            for gp in (demo.zero_mean, demo.quadratic_mean)
        ],
    )
    rep.text(
        f"Largest |m_zero − m_quad| on the 21 × 21 grid: {demo.max_difference:.5f} "
        "(the source: “less than 0.011”)."
    )


@renders(SelfCalibrationDesign, "Self-calibration design")
def _selfcal(rep: Report, d, **_) -> None:
    rep.section(
        f"Self-calibration design: {' + '.join(d.locations)}",
        f"{d.n_unknowns} unknowns, {d.n_constraints} constraints, rank {d.rank}; average "
        "standard uncertainties (µm) from the full covariance and the truncated SVD "
        f"(K = {d.truncation}).",
    )
    rows = []
    for label, table in (("full", d.U_full), (f"K = {d.truncation}", d.U_truncated)):
        for key in ("U1", "U2", "U3"):
            vals = ["—"] * 3 if table is None else [format_uncertainty(v) for v in table[key]]
            rows.append([label, key.lower(), *vals])  # the source's U1-U3 are standard u
    rep.table(["covariance", "", "x", "y", "z"], rows)
    rep.table(
        ["constraints", "free directions", "what is free"],
        [[k, v["free"], v["message"]] for k, v in d.freedoms.items()],
    )


@renders(ProbeCalibration, "Ball-plate calibration with styli")
def _probecal(rep: Report, res, **_) -> None:
    rep.section(
        f"Stylus offsets estimated ({res.model}, plate by {res.plate})",
        f"RMS residual {res.fit['rms_residual_um']:.2g} µm; {res.fit['message']}",
    )
    rep.table(
        ["stylus", "offset (mm)", "correction (µm)", "u (µm)"],
        [
            [
                pid,
                ", ".join(f"{v:.4f}" for v in p["offset_mm"]),
                ", ".join(f"{v:+.2g}" for v in p["correction_um"]),
                ", ".join(f"{v:.2g}" for v in p["u_um"]),
            ]
            for pid, p in res.probes.items()
        ],
    )
