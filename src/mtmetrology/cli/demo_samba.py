"""The SAMBA sections of ``mtm demo``: calibration with validated uncertainty, a gauge
block before and after compensation, and the task uncertainty of that gauge length.

Every step is the SAMBA application (:mod:`mtmetrology.samba`) or the on-machine task
uncertainty (:mod:`mtmetrology.omm.task`) run on files the demo writes into its folder, so
each printed ``$ mtm`` command redoes it. The simulated records come from the
``mtm simulate`` commands themselves, so a rerun rewrites the same CSV files.

References
----------
Alami Mchichi, N. (2018). *Étalonnage des machines-outils à cinq axes : configuration
optimisée des artefacts et de la séquence de mesure de la méthode SAMBA en vue d'une
estimation efficace des erreurs géométriques*. PhD thesis, École Polytechnique de
Montréal. Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with
On-Machine Tool Metrology*. PhD thesis, Polytechnique Montréal, ch. 5–7. JCGM 101:2008,
§7.9 (adaptive Monte Carlo); JCGM 102:2011, §8 (validation); ISO 14253-1:2017.
"""

from __future__ import annotations

import io
from contextlib import redirect_stderr
from dataclasses import replace

import numpy as np

from mtmetrology.cli import simulate as simulate_cli
from mtmetrology.cli._common import readings_from_table
from mtmetrology.cli.demo import DemoContext
from mtmetrology.fitting.features import GaugeLength
from mtmetrology.io import read_csv_table
from mtmetrology.io.tables import write_csv_table
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.omm.task import task_uncertainty
from mtmetrology.report import figures
from mtmetrology.report.format import format_uncertainty, format_value
from mtmetrology.report.results import add_result
from mtmetrology.samba import (
    SambaSetup,
    calibrate,
    evaluate_uncertainty,
    indication_inputs,
    load_artefact,
    load_balls,
    read_length_readings,
    read_poses,
    read_records,
    simulate_records,
    verify_length,
)
from mtmetrology.uncertainty.conformity import Tolerance, decide
from mtmetrology.units import from_internal, to_internal

__all__ = ["samba_calibration_section", "task_section"]

NOISE_UM = 1.0
# A gauge block lying diagonally on the table, probed at 30 random (B, C) indexations.
GAUGE_END_A, GAUGE_END_B = "-100,-100,40", "100,100,40"
GAUGE_LENGTH_MM = 282.842712
GAUGE_U_MM = 0.0005
GAUGE_PAIRS = 30
# The drawing's tolerance on the gauge length: nominal, lower and upper deviation (mm).
GAUGE_TOLERANCE = f"{GAUGE_LENGTH_MM},-0.010,0.010"


def _balls_yaml(setup: SambaSetup) -> str:
    """The true ball centres (``samba-balls`` document) of the set-up."""
    rows = [
        f'  - {{id: "{b}", centre_mm: [{", ".join(f"{v:g}" for v in c)}]}}'
        for b, c in {**setup.balls, **setup.scale_bar}.items()
    ]
    return "kind: samba-balls\nballs:\n" + "\n".join(rows) + "\n"


def _poses_csv(ctx: DemoContext, m: Machine, ids, q) -> None:
    """The probing programme ``ball,B,C,S`` (degrees) of the plan."""
    rotary = [m.axis_names.index(a) for a in ("B", "C", "S")]
    readings = m.readings_to_customary(q)[:, rotary]
    rows = ([b, *(f"{v:g}" for v in r)] for b, r in zip(ids, readings, strict=True))
    write_csv_table(ctx.path("samba", "poses.csv"), ["ball", "B", "C", "S"], rows)


def samba_calibration_section(
    ctx: DemoContext,
    *,
    preset: str,
    setup: SambaSetup,
    plan: tuple[list[str], np.ndarray],
    truth: ParameterSet,
) -> None:
    """Simulate a SAMBA campaign, calibrate with GUF and adaptive MCM, check a length.

    ``plan`` is (ball ids, readings) of the probing sequence (its artefact file,
    ``samba/samba.yaml``, is written by the identifiability section); ``truth`` the
    error parameters of the virtual machine.
    """
    m = Machine.load(preset)
    files = {n: ctx.path("samba", n) for n in ("truth.json", "balls.yaml", "samba.yaml")}
    truth.save(files["truth.json"])
    files["balls.yaml"].write_text(_balls_yaml(setup), encoding="utf-8")
    _poses_csv(ctx, m, *plan)
    seed_sim, seed_mcm, seed_gauge = (ctx.seed + k for k in (1, 2, 3))
    shown = {n: ctx.shown("samba", n) for n in (*files, "poses.csv", "indications.csv")}
    shown["params.json"] = ctx.shown("samba", "params.json")
    simulate = [
        "--machine", preset, "--truth", shown["truth.json"], "--artefact",
        shown["samba.yaml"], "--balls", shown["balls.yaml"], "--poses", shown["poses.csv"],
        "--noise-um", f"{NOISE_UM:g}", "--seed", str(seed_sim),
    ]  # fmt: skip
    artefact = load_artefact(files["samba.yaml"])
    with ctx.step(f"simulate the SAMBA campaign ({NOISE_UM:g} µm probing noise)"):
        simulate_records(
            m,
            truth.vector_for(m),
            load_balls(files["balls.yaml"]).centres(),
            read_poses(ctx.path("samba", "poses.csv")),
            artefact,
            noise=float(to_internal(NOISE_UM, "µm")),
            seed=seed_sim,
        ).write(ctx.path("samba", "indications.csv"))
    ctx.command("simulate the campaign", "simulate", "samba", *simulate,
                "-o", shown["indications.csv"])  # fmt: skip
    records = read_records(ctx.path("samba", "indications.csv"), m, artefact)
    sigma = float(to_internal(NOISE_UM, "µm"))
    described = f"probing noise {NOISE_UM:g} µm per reading"
    with ctx.step("calibrate: 13 parameters, ball centres and tool vector"):
        cal = calibrate(m, records, artefact, sigma=sigma, estimate_tool=True)
    with ctx.step("uncertainty: GUF and adaptive Monte Carlo re-solving the identification"):
        unc = evaluate_uncertainty(
            cal,
            indication_inputs(cal.problem, noise=sigma),
            described,
            method="both",
            adaptive=True,
            digits=1,
            seed=seed_mcm,
        )
    ctx.write_json(cal.to_dict(unc, described), "samba", "params.json")
    _unexplained_document(ctx, cal.residual_vectors)
    ctx.command(
        "calibrate with GUF and adaptive Monte Carlo (JCGM 102 validation)",
        "calibrate", "samba", shown["indications.csv"], "--machine", preset, "--artefact",
        shown["samba.yaml"], "--noise-um", f"{NOISE_UM:g}", "--estimate-tool",
        "--uncertainty", "both", "--adaptive", "--digits", "1", "--seed", str(seed_mcm),
        "-o", shown["params.json"],
    )  # fmt: skip
    covered = _report_calibration(ctx, m, cal, unc, truth)
    ctx.summary.append(
        f"SAMBA calibration: GUF {'validated' if unc.validation.passed else 'NOT validated'} "
        f"by {unc.mcm.trials} Monte Carlo trials (JCGM 102, 1 digit); {covered}/{m.n_params} "
        "true parameters inside their 95 % intervals"
    )
    _gauge_block(ctx, preset, shown, seed_gauge)


def _report_calibration(ctx: DemoContext, m: Machine, cal, unc, truth) -> int:
    """Tables and the residual figure of the calibration; the number of covered truths."""
    g, mc = unc.guf, unc.mcm
    # The outputs of the identification model are in the parameters' customary units.
    true = [
        float(from_internal(v, unit))
        for v, unit in zip(truth.vector_for(m), m.parameter_units, strict=True)
    ]
    rows, covered = [], 0
    for i, (name, unit) in enumerate(zip(m.parameter_names, m.parameter_units, strict=True)):
        low, high = (float(v) for v in mc.interval[i])
        inside = bool(low <= true[i] <= high)
        covered += inside
        u = float(g.standard_uncertainty[i])
        rows.append(
            [
                name,
                unit,
                f"{float(true[i]):g}",
                format_value(float(g.estimate[i]), u),
                format_uncertainty(u),
                format_uncertainty(float(mc.standard_uncertainty[i])),
                f"[{format_value(low, u)}, {format_value(high, u)}]",
                "yes" if inside else "no",
            ]
        )
    volumetric = cal.to_dict()["volumetric_error"]
    ctx.report.section(
        "Simulated SAMBA calibration",
        f"{len(cal.records.balls)} ball-centre indications simulated with "
        f"{NOISE_UM:g} µm probing noise on the virtual machine ('mtm simulate samba'), "
        "calibrated with 'mtm calibrate samba': the 13 errors, the ball centres and the "
        "tool vector. Their uncertainty by the GUF through the identification and by an "
        f"adaptive Monte Carlo re-solving it ({mc.trials} trials, JCGM 101 §7.9), compared "
        "as JCGM 102 §8 prescribes. Unexplained volumetric error "
        f"{volumetric['unexplained']['mean_um']:.2f} µm (mean norm; the nominal model: "
        f"{volumetric['nominal_model']['mean_um']:.1f} µm). {covered} of {m.n_params} true "
        "errors lie within their 95 % Monte Carlo intervals.",
    )
    ctx.report.table(
        ["parameter", "unit", "true", "GUF value", "u (GUF)", "u (MCM)", "95 % interval (MCM)",
         "true inside"],
        rows,
    )  # fmt: skip
    add_result(ctx.report, unc.validation)
    add_result(ctx.report, cal.parameters)
    centres = cal.ball_centres()
    ctx.report.figure(
        figures.residual_vectors(
            np.array([centres[b] for b in cal.records.balls]),
            from_internal(cal.residual_vectors, "µm"),
            labels=list(cal.records.balls),
            title="Residuals of the ball-centre indications",
        ),
        caption="Unexplained volumetric error of every indication after calibration (µm), "
        "on the artefact seen in three projections.",
    )
    return covered


def _gauge_block(ctx: DemoContext, preset: str, shown: dict, seed: int) -> None:
    """``mtm simulate length`` and ``mtm verify length``: nominal and compensated errors."""
    gauge = ctx.path("gauge", "gauge.csv")
    with ctx.step(f"a gauge block at {GAUGE_PAIRS} (B, C) indexations, before/after"):
        with redirect_stderr(io.StringIO()):  # the command's "wrote ..." line
            simulate_cli.length(
                machine=preset,
                end_a=GAUGE_END_A,
                end_b=GAUGE_END_B,
                output=gauge,
                truth=ctx.path("samba", "truth.json"),
                pairs=GAUGE_PAIRS,
                noise_um=NOISE_UM,
                seed=seed,
            )
        base = Machine.load(preset)
        pset = ParameterSet.load(ctx.path("samba", "params.json"), base)
        m = pset.machine_for(base)
        check = verify_length(
            m,
            pset.vector_for(m),
            read_length_readings(gauge, m),
            GAUGE_LENGTH_MM,
            tip_radius=m.tip_radius,
            u_length=GAUGE_U_MM,
        )
    doc = check.to_dict()
    ctx.write_json(doc, "gauge", "length-check.json")
    ctx.command(
        "simulate the gauge-block readings",
        "simulate", "length", "--machine", preset, "--truth", shown["truth.json"],
        f"--end-a={GAUGE_END_A}", f"--end-b={GAUGE_END_B}", "--pairs", str(GAUGE_PAIRS),
        "--noise-um", f"{NOISE_UM:g}", "--seed", str(seed), "-o", ctx.shown("gauge", "gauge.csv"),
    )  # fmt: skip
    ctx.command(
        "the gauge block before and after compensation",
        "verify", "length", ctx.shown("gauge", "gauge.csv"), "--machine", preset,
        "--params", shown["params.json"], "--length", f"{GAUGE_LENGTH_MM}",
        "--u-length", f"{GAUGE_U_MM}", "-o", ctx.shown("gauge", "length-check.json"),
    )  # fmt: skip
    ctx.report.section(
        "A gauge block before and after compensation",
        f"A {GAUGE_LENGTH_MM:g} mm gauge block lying diagonally on the table, its end faces "
        f"probed at {GAUGE_PAIRS} random (B, C) indexations ('mtm simulate length'), "
        "measured with the nominal kinematics and with the calibrated parameters "
        "('mtm verify length'). Length errors in µm.",
    )
    stats = ("mean", "rms", "std", "range", "max_abs")
    ctx.report.table(
        ["model", *stats],
        [[name, *(f"{doc[name][s]:.3f}" for s in stats)] for name in ("nominal", "compensated")],
    )
    ctx.summary.append(
        f"gauge block {GAUGE_LENGTH_MM:g} mm: RMS length error {doc['nominal']['rms']:.1f} µm "
        f"nominal, {doc['compensated']['rms']:.2f} µm compensated ({GAUGE_PAIRS} indexations)"
    )


def _unexplained_document(ctx: DemoContext, residual_vectors: np.ndarray) -> None:
    """cov(e) of the calibration's residual vectors, µm² (Sepahi Boroujeni (2021),
    eqs. 6-13 to 6-15, here from the identification's own positions)."""
    cov = np.cov(from_internal(residual_vectors, "µm"), rowvar=False)
    ctx.write_json(
        {
            "kind": "unexplained-volumetric-error",
            "version": 1,
            "unit": "µm²",
            "covariance": [[round(float(v), 6) for v in row] for row in (cov + cov.T) / 2],
            "source": "mtm demo: residual vectors of the SAMBA calibration",
        },
        "task",
        "unexplained.json",
    )


def task_section(ctx: DemoContext, *, preset: str) -> None:
    """The gauge length of the first indexation with its u, U and conformity decision."""
    from mtmetrology.omm.unexplained import load_unexplained_covariance

    table = read_csv_table(ctx.path("gauge", "gauge.csv"), required=("pair", "end"))
    first = [k for k, pair in enumerate(table.strings("pair")) if pair == "1"]
    base = Machine.load(preset)
    axes = [a for a in base.axis_names if table.has(a)]
    rows = [
        [str(n + 1), str(n + 1), *(table.strings(a)[k] for a in axes)] for n, k in enumerate(first)
    ]
    points = ctx.path("task", "gauge-pair.csv")
    write_csv_table(points, ["point", "end", *axes], rows)
    pset = ParameterSet.load(ctx.path("samba", "params.json"), base)
    m = pset.machine_for(base)
    readings = readings_from_table(m, read_csv_table(points, required=("point",)))
    tolerance = Tolerance.parse(GAUGE_TOLERANCE)
    unexplained = ctx.path("task", "unexplained.json")
    seed = ctx.seed + 5
    with ctx.step("task uncertainty of the gauge length (GUF validated by Monte Carlo)"):
        result = task_uncertainty(
            m,
            readings,
            pset.vector_for(m),
            pset.covariance,
            GaugeLength(tip_diameter=2.0 * m.tip_radius),
            recalibrated=True,  # the virtual machine does not drift after its calibration
            unexplained_covariance=load_unexplained_covariance(unexplained),
            method="both",
            seed=seed,
        )
    g = result.result.output()  # the Monte Carlo result, the reference of the validation
    decision = decide(g.value, g.U, tolerance, unit="mm")
    result = replace(result, decision=decision)
    ctx.write_json(result.to_dict(), "task", "gauge-length.json")
    ctx.command(
        "the gauge length with its uncertainty and ISO 14253-1 decision",
        "task", "uncertainty", ctx.shown("task", "gauge-pair.csv"), "--machine", preset,
        "--params", ctx.shown("samba", "params.json"), "--feature", "length", "--recalibrated",
        "--unexplained", ctx.shown("task", "unexplained.json"), "--method", "both",
        "--seed", str(seed), "--tolerance", GAUGE_TOLERANCE,
        "-o", ctx.shown("task", "gauge-length.json"),
    )  # fmt: skip
    u_um = float(from_internal(g.u, "µm"))
    big_u_um = float(from_internal(g.U, "µm"))
    ctx.report.section(
        "Task uncertainty and conformity of the gauge length",
        "The gauge length of the first indexation, compensated with the calibrated "
        "parameters; its uncertainty by adaptive Monte Carlo (JCGM 101:2008, 7.9) over the "
        "parameter covariance of the calibration (the compensation uses its estimate, whose "
        "error does not cancel) and the unexplained volumetric error (the covariance of the "
        "calibration's residual vectors; Sepahi Boroujeni (2021), ch. 6–7), with the "
        "full-covariance GUF validated against it; the virtual machine does not drift, so "
        "the task counts as recalibrated (no long-term term). The decision follows ISO "
        "14253-1:2017 with guard bands of U: "
        f"tolerance {tolerance.lower_limit:.6f} to {tolerance.upper_limit:.6f} mm.",
    )
    ctx.report.table(
        ["length (mm)", "u (µm)", "U (µm)", "k", "acceptance zone (mm)", "decision"],
        [[
            f"{g.value:.6f}", f"{u_um:.2f}", f"{big_u_um:.2f}", f"{g.k:.2f}",
            "[{:.6f}, {:.6f}]".format(*decision.acceptance_zone), decision.decision.value,
        ]],
    )  # fmt: skip
    add_result(ctx.report, result.guf)
    add_result(ctx.report, result.validation)
    validated = "validated" if result.validation.passed else "NOT validated"
    ctx.summary.append(
        f"task: gauge length {g.value:.4f} mm, u = {u_um:.2f} µm, U = {big_u_um:.2f} µm "
        f"(k = {g.k:.2f}, Monte Carlo, {result.mcm.trials} trials; GUF {validated}); "
        f"ISO 14253-1: {decision.decision.value}"
    )
