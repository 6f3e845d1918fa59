"""The sections of ``mtm demo``, in order (:data:`DEMO_SECTIONS`).

The simulated machine is the five-axis preset with errors of the size identified by
Sepahi Boroujeni (2021), Table 5-2, probed on a SAMBA artefact of four master balls and a
305 mm scale bar with 1 µm probing noise. Every number printed is computed here; nothing is
pasted from the sources. Sections share what they made through ``ctx.out``/``ctx.work``
files (the calibration's parameter set feeds the prediction).

References
----------
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine Tool
Metrology*. PhD thesis, Polytechnique Montréal. Alami Mchichi, N. (2018). *Étalonnage des
machines-outils à cinq axes : configuration optimisée des artefacts et de la séquence de
mesure de la méthode SAMBA en vue d'une estimation efficace des erreurs géométriques*. PhD
thesis, École Polytechnique de Montréal. JCGM 100:2008 (GUM), annex H.1; JCGM 101:2008.
"""

from __future__ import annotations

import numpy as np

from mtmetrology.cli.demo import DemoContext, DemoSection
from mtmetrology.cli.demo_cmm import cmm_section
from mtmetrology.cli.demo_planning import planning_section
from mtmetrology.cli.demo_samba import samba_calibration_section, task_section
from mtmetrology.cli.demo_sphere import sphere_task_section
from mtmetrology.fitting.documents import fit_document
from mtmetrology.fitting.least_squares import fit_sphere
from mtmetrology.fitting.minimum_zone import sphericity
from mtmetrology.identification import (
    BallCentreProblem,
    ScaleBar,
    analyse_identifiability,
)
from mtmetrology.io.tables import format_decimal, write_csv_table
from mtmetrology.kinematics.conventions import describe_parameters
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.report.results import add_fit_document, add_result
from mtmetrology.samba import SambaSetup, probing_sequence
from mtmetrology.units import from_internal, to_internal

__all__ = ["DEMO_SECTIONS"]

PRESET = "five-axis-wcbxfzyst"
SETUP = SambaSetup(
    balls={
        "1": (-80.0, -40.0, 100.0),
        "2": (80.0, -40.0, 150.0),
        "3": (80.0, 120.0, 75.0),
        "4": (-80.0, 120.0, 125.0),
    },
    scale_bar={"SB1": (-152.60525, 0.0, 30.0), "SB2": (152.60525, 0.0, 30.0)},
)
ARTEFACT_YAML = """kind: samba-artefact
balls:
  - {id: "1", diameter_mm: 12.7}
  - {id: "2", diameter_mm: 12.7}
  - {id: "3", diameter_mm: 12.7}
  - {id: "4", diameter_mm: 12.7}
  - {id: SB1, diameter_mm: 12.7}
  - {id: SB2, diameter_mm: 12.7}
scale_bar: {ends: [SB1, SB2], length_mm: 305.2105, u_mm: 0.0012}
stylus_tip_diameter_mm: 5.925
"""
# B within ±45°: beyond it the scale-bar and corner balls leave the X and Z travel.
GRID = [(b, c) for b in (-45, -20, 0, 20, 45) for c in range(0, 360, 60)]
PROBING_SIGMA_UM = 1.0
BAR_U_MM = 0.0012

# The "true" machine of the simulation: errors of the size of Sepahi Boroujeni (2021),
# Table 5-2 (µm, µrad, µm/m).
TRUE_ERRORS = {
    "E_A0B": -8.73,
    "E_C0B": -2.80,
    "E_X0C": -104.59,
    "E_A0C": -18.75,
    "E_B0C": -4.40,
    "E_B0Z": -12.23,
    "E_A0Y": -13.87,
    "E_C0Y": 25.81,
    "E_XX1": 75.6,
    "E_YY1": 102.0,
    "E_ZZ1": 113.4,
    "E_Y0S": 18.72,
    "E_X0S": -107.15,
}

# The gauge-block bipoint of Sepahi Boroujeni (2021), Table 7-1 (mm and degrees).
GAUGE_READINGS = {
    "X": [-138.5650, -61.2880],
    "Y": [94.6560, 48.3440],
    "Z": [196.2320, 246.8170],
    "B": [-42.0, -64.0],
    "C": [-293.0, -124.0],
}

GUM_H1_YAML = """kind: measurement-model
version: 1
name: GUM H.1 end-gauge calibration
inputs:
  - {name: l_s, value: 50000623.6, u: 25, unit: nm, dof: 18}
  - {name: d, value: 215, u: 9.7, unit: nm, dof: 25.6}
  - {name: alpha_s, value: 11.5e-6, u: 1.2e-6, unit: /°C}
  - {name: theta, value: -0.1, u: 0.41, unit: °C}
  - {name: dalpha, value: 0.0, u: 0.58e-6, unit: /°C, dof: 50}
  - {name: dtheta, value: 0.0, u: 0.029, unit: °C, dof: 2}
outputs:
  - {name: l, unit: nm, expression: "l_s + d - l_s * (alpha_s * dtheta + dalpha * theta)"}
"""


def _rng(ctx: DemoContext, stream: int) -> np.random.Generator:
    """An independent stream per section, from the root seed."""
    return np.random.default_rng(np.random.SeedSequence(ctx.seed).spawn(stream + 1)[stream])


def _truth(m: Machine) -> np.ndarray:
    units = m.parameter_units
    return np.array(
        [to_internal(TRUE_ERRORS[n], u) for n, u in zip(m.parameter_names, units, strict=True)]
    )


def _indications_csv(ctx: DemoContext, m: Machine, ids, q, *parts: str) -> None:
    rows = (
        [i, *(f"{v:.6f}" for v in r)] for i, r in zip(ids, m.readings_to_customary(q), strict=True)
    )
    write_csv_table(ctx.path(*parts), ["ball", *m.axis_names], rows)


# -- sections ------------------------------------------------------------------------------
def machine_section(ctx: DemoContext) -> None:
    m = Machine.load(PRESET)
    ctx.report.section(
        "The machine",
        f"{m.name}: topology {m.topology.string} (the table carries X, B and C; the spindle "
        f"head Z, Y and the spindle S). Its {m.n_params}-parameter SAMBA model (Alami Mchichi "
        "(2018), Table 5.1), with what a positive value does to the tool relative to the "
        "workpiece and where each parameter is referred to:",
    )
    ctx.report.table(
        ["parameter", "unit", "a positive value", "referred to"],
        [[c.name, c.unit, c.positive, c.reference] for c in describe_parameters(m)],
    )
    ctx.command("the parameters and their conventions", "machine", "show", PRESET)
    ctx.summary.append(f"machine: {m.name}, {m.n_params} parameters of model {m.model_name}")


def identifiability_section(ctx: DemoContext) -> None:
    m = Machine.load(PRESET)
    ids, q = probing_sequence(m, SETUP, GRID)
    _indications_csv(ctx, m, ids, q, "samba", "plan.csv")
    ctx.write_text(ARTEFACT_YAML, "samba", "samba.yaml")
    bar = ScaleBar(("SB1", "SB2"), SETUP.scale_bar_length, u=BAR_U_MM)
    sigma = float(to_internal(PROBING_SIGMA_UM, "µm"))
    reports = {}
    with ctx.step("identifiability of the plan: 13 parameters, then 13 + E_Y0C"):
        for label, model in (
            ("13 parameters", m),
            ("13 + E_Y0C", m.with_parameters([*m.parameter_names, "E_Y0C"])),
        ):
            problem = BallCentreProblem(
                model, q, ids, scale_bars=[bar], estimate_tool=True, sigma=sigma
            )
            _, jac = problem.evaluate(problem.initial())
            reports[label] = analyse_identifiability(
                jac, problem.names, n_measurements=len(ids), report_names=model.parameter_names
            )
    ctx.report.section(
        "Is the SAMBA plan good enough?",
        f"Four master balls and a scale bar probed at {len(GRID)} (B, C) orientations with "
        "spindle indexing: the ball centres and the tool offset are unknown too. The plan "
        "identifies the 13 parameters; adding E_Y0C makes it rank deficient, and the "
        "confounded parameters are named.",
    )
    ctx.report.table(
        ["model", "unknowns", "rank", "condition (scaled)", "unidentifiable"],
        [
            [
                label,
                r.n_unknowns,
                r.rank,
                f"{r.condition_scaled:.4g}" if r.full_rank else "—",
                "; ".join(map(str, r.null_directions)) or "none",
            ]
            for label, r in reports.items()
        ],
    )
    add_result(ctx.report, reports["13 parameters"])
    plan, artefact = ctx.shown("samba", "plan.csv"), ctx.shown("samba", "samba.yaml")
    check = ("machine", "identifiability", PRESET, plan, "--artefact", artefact)
    ctx.command("identifiability of the plan", *check)
    ctx.command("the confound E_Y0C ~ E_Y0S (exits with code 2)", *check, "--add", "E_Y0C")
    deficient = reports["13 + E_Y0C"]
    ctx.summary.append(
        f"SAMBA plan: rank {reports['13 parameters'].rank}/{reports['13 parameters'].n_unknowns}"
        f"; with E_Y0C rank {deficient.rank}/{deficient.n_unknowns} "
        f"({'; '.join(map(str, deficient.null_directions))})"
    )


def calibration_section(ctx: DemoContext) -> None:
    m = Machine.load(PRESET)
    truth = ParameterSet(
        m.parameter_names,
        _truth(m),
        m.parameter_units,
        machine=m.name,
        model=m.model_name,
        provenance={"source": "mtm demo: the simulated truth"},
    )
    plan = probing_sequence(m, SETUP, GRID)
    samba_calibration_section(ctx, preset=PRESET, setup=SETUP, plan=plan, truth=truth)


def task_uncertainty_section(ctx: DemoContext) -> None:
    task_section(ctx, preset=PRESET)


def sphere_section(ctx: DemoContext) -> None:
    sphere_task_section(ctx, preset=PRESET)


def prediction_section(ctx: DemoContext) -> None:
    from mtmetrology.cli.predict import add_compensation

    m = Machine.load(PRESET)
    pset = ParameterSet.load(ctx.path("samba", "params.json"), m)
    q = m.readings_from_customary(GAUGE_READINGS)
    header = ["id", *GAUGE_READINGS]
    rows = [[f"p{i + 1}", *(f"{GAUGE_READINGS[a][i]:g}" for a in GAUGE_READINGS)] for i in range(2)]
    write_csv_table(ctx.path("prediction", "gauge.csv"), header, rows)
    nominal, true = (m.forward(q, theta) for theta in (None, _truth(m)))
    # compensated as `mtm predict` does: the identified parameters and tool vector
    identified = pset.machine_for(m).forward(q, pset.values)
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
    add_compensation(ctx.report, m, identified, nominal)
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


def uncertainty_section(ctx: DemoContext) -> None:
    from mtmetrology.cli.uncertainty import Method, evaluate_model
    from mtmetrology.uncertainty.modelfile import load_model

    ctx.write_text(GUM_H1_YAML, "uncertainty", "gum-h1.yaml")
    loaded = load_model(ctx.path("uncertainty", "gum-h1.yaml"))
    with ctx.step("GUM H.1 by GUF and adaptive Monte Carlo (2 significant digits)"):
        document, g, r, validation = evaluate_model(
            loaded,
            ctx.path("uncertainty", "gum-h1.yaml"),
            Method.both,
            adaptive=True,
            digits=2,
            seed=ctx.seed,
            p=0.99,
        )
    ctx.write_json(document, "uncertainty", "gum-h1-result.json")
    ctx.report.section(
        "Uncertainty of a measurement model: GUM H.1",
        "The end-gauge calibration of JCGM 100:2008, annex H.1: the GUF gives u = 32 nm and "
        "U_99 = 93 nm as the annex; the adaptive Monte Carlo method of JCGM 101:2008 gives "
        "u = 34 nm, as the annex's second-order analysis (H.1.7), and a shorter 99 % "
        "interval, so the GUF is not validated at two significant digits.",
    )
    add_result(ctx.report, validation)
    add_result(ctx.report, g)
    add_result(ctx.report, r, names=loaded.output_names, units=loaded.output_units, guf=g)
    ctx.command(
        "GUF, Monte Carlo and validation",
        "uncertainty",
        "run",
        ctx.shown("uncertainty", "gum-h1.yaml"),
        "--method",
        "both",
        "--adaptive",
        "--seed",
        str(ctx.seed),
        "--p",
        "0.99",
    )
    ctx.summary.append(
        f"GUM H.1: GUF u = {g.standard_uncertainty[0]:.1f} nm, Monte Carlo u = "
        f"{r.standard_uncertainty[0]:.1f} nm ({r.trials} trials), GUF "
        f"{'validated' if validation.passed else 'not validated'} at p = 0.99"
    )


def fitting_section(ctx: DemoContext) -> None:
    rng = _rng(ctx, 2)
    d = rng.standard_normal((25, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d[:, 2] = np.abs(d[:, 2])  # the upper hemisphere, as probed on a mounted sphere
    form = float(to_internal(2.0, "µm"))
    points = np.array([10.0, -20.0, 5.0]) + (12.7 + form * rng.standard_normal(25))[:, None] * d
    write_csv_table(
        ctx.path("fitting", "sphere.csv"),
        ["x", "y", "z"],
        ([f"{v:.6f}" for v in p] for p in points),
    )
    ls = fit_sphere(points)
    zone = sphericity(points)
    source = ctx.shown("fitting", "sphere.csv")
    document = fit_document(
        "sphere",
        "minimum-zone",
        source,
        zone.element,
        zone.residuals,
        zone.form_error,
        {"message": zone.message},
    )
    ctx.write_json(document, "fitting", "sphere-result.json")
    ctx.report.section(
        "A sphere: least squares and minimum zone",
        "25 points on the upper half of a 12.7 mm sphere, radial deviations of 2 µm standard "
        "deviation. The "
        f"least-squares sphericity (peak to valley) is "
        f"{float(from_internal(ls.form_error, 'µm')):.2f} µm; the minimum zone, which a form "
        f"tolerance is checked against, {float(from_internal(zone.form_error, 'µm')):.2f} µm.",
    )
    add_fit_document(ctx.report, document, zone.residuals, points)
    ctx.command("the minimum-zone sphere", "fit", "sphere", source, "--method", "minimum-zone")
    ctx.summary.append(
        f"sphere: radius {zone.element.radius:.4f} mm, sphericity "
        f"{float(from_internal(zone.form_error, 'µm')):.2f} µm (least squares "
        f"{float(from_internal(ls.form_error, 'µm')):.2f} µm)"
    )


#: The demo, in order. An application appends its section here.
DEMO_SECTIONS: list[DemoSection] = [
    DemoSection("machine", "The five-axis machine", machine_section),
    DemoSection("samba", "SAMBA plan: identifiability", identifiability_section),
    DemoSection("planning", "Planning a SAMBA test by DETMAX", planning_section),
    DemoSection("calibration", "SAMBA calibration and a gauge block", calibration_section),
    DemoSection("prediction", "Compensated coordinates", prediction_section),
    DemoSection("task", "Task uncertainty and conformity", task_uncertainty_section),
    DemoSection("sphere", "A sphere at several B/C; coverage", sphere_section),
    DemoSection("uncertainty", "GUM H.1: GUF and Monte Carlo", uncertainty_section),
    DemoSection("fitting", "Geometric elements", fitting_section),
    DemoSection("cmm", "Bridge CMM: ball plate, kinematic and GP models", cmm_section),
]
