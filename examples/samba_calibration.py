"""A SAMBA calibration with validated uncertainty, a gauge block before and after
compensation, and compensated coordinates, on the virtual five-axis machine.

Every step is the SAMBA application (:mod:`mtmetrology.samba`) run on files the script
writes into its folder, so each printed ``$ mtm`` command redoes it; the simulated
records are those ``mtm samba simulate`` writes. Run it on its own::

    python examples/samba_calibration.py [OUT]

References
----------
Alami Mchichi, N. (2018). *Étalonnage des machines-outils à cinq axes : configuration
optimisée des artefacts et de la séquence de mesure de la méthode SAMBA en vue d'une
estimation efficace des erreurs géométriques*. PhD thesis, École Polytechnique de
Montréal. Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with
On-Machine Tool Metrology*. PhD thesis, Polytechnique Montréal, ch. 5–7. JCGM 101:2008,
§7.9 (adaptive Monte Carlo); JCGM 102:2011, §8 (validation).
"""

from __future__ import annotations

import numpy as np

from _five_axis import (
    ARTEFACT_YAML,
    GAUGE_END_A,
    GAUGE_END_B,
    GAUGE_LENGTH_MM,
    GAUGE_PAIRS,
    GAUGE_READINGS,
    GAUGE_U_MM,
    GRID,
    NOISE_UM,
    PRESET,
    SETUP,
    true_errors,
)
from mtmetrology.formatting import format_uncertainty, format_value
from mtmetrology.io.tables import format_decimal, write_csv_table
from mtmetrology.kinematics.compensation import compensate
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.report import figures
from mtmetrology.report.demo import DemoContext
from mtmetrology.report.results import add_result
from mtmetrology.samba import (
    SambaSetup,
    calibrate,
    evaluate_uncertainty,
    indication_inputs,
    load_artefact,
    load_balls,
    probing_sequence,
    read_length_readings,
    read_poses,
    read_records,
    simulate_length_check,
    simulate_records,
    verify_length,
)
from mtmetrology.units import from_internal, to_internal


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
    ctx.command("simulate the campaign", "samba", "simulate", *simulate,
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
        "samba", "calibrate", shown["indications.csv"], "--machine", preset, "--artefact",
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
        f"{NOISE_UM:g} µm probing noise on the virtual machine ('mtm samba simulate'), "
        "calibrated with 'mtm samba calibrate': the 13 errors, the ball centres and the "
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
    add_result(
        ctx.report,
        unc.validation,
        units=dict(zip(m.parameter_names, m.parameter_units, strict=True)),
    )
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
    """``mtm length simulate`` and ``mtm length verify``: nominal and compensated errors."""
    gauge = ctx.path("gauge", "gauge.csv")
    with ctx.step(f"a gauge block at {GAUGE_PAIRS} (B, C) indexations, before/after"):
        base = Machine.load(preset)
        truth = ParameterSet.load(ctx.path("samba", "truth.json"), base)
        simulate_length_check(
            base,
            truth.vector_for(base),
            [float(v) for v in GAUGE_END_A.split(",")],
            [float(v) for v in GAUGE_END_B.split(",")],
            pairs=GAUGE_PAIRS,
            noise=float(to_internal(NOISE_UM, "µm")),
            seed=seed,
        ).write(gauge)
        pset = ParameterSet.load(ctx.path("samba", "params.json"), base)
        m = pset.machine_for(base)
        check = verify_length(
            m,
            pset.vector_for(m),
            read_length_readings(gauge, m),
            GAUGE_LENGTH_MM,
            tip_radius=m.tip_radius,
            u_length=GAUGE_U_MM,
            parameter_covariance=pset.covariance,
        )
    doc = check.to_dict()
    ctx.write_json(doc, "gauge", "length-check.json")
    ctx.command(
        "simulate the gauge-block readings",
        "length", "simulate", "--machine", preset, "--truth", shown["truth.json"],
        f"--end-a={GAUGE_END_A}", f"--end-b={GAUGE_END_B}", "--pairs", str(GAUGE_PAIRS),
        "--noise-um", f"{NOISE_UM:g}", "--seed", str(seed), "-o", ctx.shown("gauge", "gauge.csv"),
    )  # fmt: skip
    ctx.command(
        "the gauge block before and after compensation",
        "length", "verify", ctx.shown("gauge", "gauge.csv"), "--machine", preset,
        "--params", shown["params.json"], "--length", f"{GAUGE_LENGTH_MM}",
        "--u-length", f"{GAUGE_U_MM}", "-o", ctx.shown("gauge", "length-check.json"),
    )  # fmt: skip
    ctx.report.section(
        "A gauge block before and after compensation",
        f"A {GAUGE_LENGTH_MM:g} mm gauge block lying diagonally on the table, its end faces "
        f"probed at {GAUGE_PAIRS} random (B, C) indexations ('mtm length simulate'), "
        "measured with the nominal kinematics and with the calibrated parameters "
        "('mtm length verify'). Length errors in µm.",
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


def calibration_section(ctx: DemoContext) -> None:
    m = Machine.load(PRESET)
    truth = ParameterSet(
        m.parameter_names,
        true_errors(m),
        m.parameter_units,
        machine=m.name,
        model=m.model_name,
        provenance={"source": "mtm demo: the simulated truth"},
    )
    plan = probing_sequence(m, SETUP, GRID)
    samba_calibration_section(ctx, preset=PRESET, setup=SETUP, plan=plan, truth=truth)


def prediction_section(ctx: DemoContext) -> None:

    m = Machine.load(PRESET)
    pset = ParameterSet.load(ctx.path("samba", "params.json"), m)
    q = m.readings_from_customary(GAUGE_READINGS)
    header = ["id", *GAUGE_READINGS]
    rows = [[f"p{i + 1}", *(f"{GAUGE_READINGS[a][i]:g}" for a in GAUGE_READINGS)] for i in range(2)]
    write_csv_table(ctx.path("prediction", "gauge.csv"), header, rows)
    nominal, true = (m.forward(q, theta) for theta in (None, true_errors(m)))
    # compensated as `mtm predict` does: the identified parameters and tool vector
    calibrated = pset.machine_for(m)
    compensation = compensate(calibrated, q, pset.vector_for(calibrated))
    identified = compensation.points
    # written as `mtm predict -o` writes them, so that its rerun rewrites the same file
    xyz = [format_decimal(identified[:, k], 6).to_pylist() for k in range(3)]
    xyz_rows = [[*r, *(c[i] for c in xyz)] for i, r in enumerate(rows)]
    write_csv_table(ctx.path("prediction", "gauge-xyz.csv"), [*header, "x", "y", "z"], xyz_rows)
    lengths = [float(np.linalg.norm(p[1] - p[0])) for p in (nominal, identified, true)]
    error_um = float(from_internal(lengths[1] - lengths[2], "µm"))
    ctx.report.section(
        "Compensated coordinates",
        "The two probed points of a gauge-block measurement at two (B, C) orientations "
        "(Sepahi Boroujeni (2021), Table 7-1), compensated with the identified parameters. "
        "The distance between the two stylus centres on the true machine is known in the "
        "simulation: the compensation error is what the calibration leaves.",
    )
    ctx.report.table(
        ["distance of the stylus centres", "mm"],
        [
            ["nominal kinematics (no compensation)", f"{lengths[0]:.4f}"],
            ["compensated with the identified parameters", f"{lengths[1]:.4f}"],
            ["on the true machine", f"{lengths[2]:.4f}"],
        ],
    )
    add_result(ctx.report, compensation, nominal=nominal, machine=m)
    ctx.command(
        "compensated coordinates",
        "predict",
        "--machine",
        PRESET,
        "--params",
        ctx.shown("samba", "params.json"),
        ctx.shown("prediction", "gauge.csv"),
        "-o",
        ctx.shown("prediction", "gauge-xyz.csv"),
    )
    ctx.summary.append(
        f"compensation: gauge-point distance off by {error_um:+.2f} µm from the true machine "
        f"(uncompensated: {float(from_internal(lengths[0] - lengths[2], 'µm')):+.1f} µm)"
    )


def main(ctx: DemoContext) -> None:
    ctx.rule("SAMBA calibration and a gauge block")
    ctx.write_text(ARTEFACT_YAML, "samba", "samba.yaml")  # as five_axis_machine.py writes it
    calibration_section(ctx)
    ctx.rule("Compensated coordinates")
    prediction_section(ctx)


if __name__ == "__main__":
    from mtmetrology.report.demo import run_example

    run_example(main, "samba_calibration")
