"""Task uncertainty and ISO 14253-1 conformity on the calibrated five-axis machine: the
gauge length and a sphere probed at several (B, C), with the coverage of the intervals.

Uses the files ``samba_calibration.py`` writes (its parameter set with covariance, the
gauge-block readings, the residual vectors' covariance); run on its own into an empty
folder, it runs that calibration first. The sphere's probed points come from the SAMBA
simulator on the *true* machine (1 µm noise per linear reading), so one kinematic engine
serves the simulation and the evaluation. Each task is one ``mtm task uncertainty`` run on
a file the script writes, and its command is printed. Coverage: the simulation knows the
true sphere diameter and the true gauge length, so the fraction of the task intervals
(value ± U) that contain the truth is counted. Run it on its own::

    python examples/task_uncertainty.py [OUT]

References
----------
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, ch. 6–7. ISO 14253-1:2017.
JCGM 100:2008 (GUM), §6.2–6.3; JCGM 101:2008, §7.9.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.stats import binom

from _five_axis import GAUGE_TOLERANCE, NOISE_UM, PRESET
from mtmetrology.fitting.composite import CombinedFeature
from mtmetrology.fitting.features import GaugeLength, SphereDiameter, Sphericity
from mtmetrology.formatting import format_k, format_uncertainty, format_value
from mtmetrology.io import read_csv_table
from mtmetrology.io.tables import write_csv_table
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.kinematics.readings_table import readings_from_table  # the reader of `mtm task`
from mtmetrology.omm.task import task_uncertainty
from mtmetrology.omm.unexplained import load_unexplained_covariance
from mtmetrology.report import figures
from mtmetrology.report.demo import DemoContext
from mtmetrology.report.results import add_result
from mtmetrology.samba import simulate_records
from mtmetrology.samba.artefact import SambaArtefact
from mtmetrology.samba.simulate import ProbingProgramme
from mtmetrology.uncertainty.conformity import Tolerance, decide
from mtmetrology.units import from_internal, to_internal

SPHERE_DIAMETER_MM = 25.0
SPHERE_CENTRE_MM = (20.0, 30.0, 60.0)  # workpiece frame
SPHERE_POINTS = 25  # 24 on the equator and the pole (machine axes)
# The orientations of the sphere measurement, degrees.
SPHERE_BC = ((-40, 30), (-20, 150), (0, 0), (0, 270), (20, 90), (40, 210))
SPHERE_TOLERANCE = f"{SPHERE_DIAMETER_MM},-0.008,0.008"
# The gauge-block indexations (of gauge/gauge.csv) evaluated for the coverage check.
COVERAGE_PAIRS = 10
# The end-face centres of the demo's gauge block (workpiece frame, mm).
GAUGE_ENDS = (np.array([-100.0, -100.0, 40.0]), np.array([100.0, 100.0, 40.0]))


@dataclass(frozen=True)
class Coverage:
    """How many task intervals contain the true value.

    Attributes
    ----------
    n : int
        Number of tasks.
    covered : int
        Intervals ``[y − U, y + U]`` that contain the truth.
    p : float
        The coverage probability the intervals claim.
    p_at_most : float
        Binomial probability of at most ``covered`` successes in ``n`` trials at ``p``.
    tasks : tuple of dict
        Per task: ``feature``, ``value``, ``U``, ``k``, ``true`` (mm) and ``covered``.
    """

    n: int
    covered: int
    p: float
    p_at_most: float
    tasks: tuple[dict, ...]

    def to_dict(self) -> dict:
        return {
            "kind": "task-coverage",
            "version": 1,
            "n_tasks": self.n,
            "covered": self.covered,
            "coverage_probability": self.p,
            "binomial_p_at_most_covered": self.p_at_most,
            "unit": "mm",
            "tasks": list(self.tasks),
        }


def _simulate_sphere(ctx: DemoContext, m: Machine, truth: np.ndarray, seed: int) -> list[str]:
    """The sphere probed at every orientation on the true machine; one CSV per
    orientation in the ``mtm task uncertainty`` format. Returns their file names."""
    artefact = SambaArtefact(
        balls=[{"id": "S", "diameter_mm": SPHERE_DIAMETER_MM}],
        stylus_tip_diameter_mm=2.0 * m.tip_radius,
    )
    bc = np.array(SPHERE_BC, dtype=float)
    programme = ProbingProgramme(("S",) * len(bc), bc[:, 0], bc[:, 1], np.zeros(len(bc)))
    records = simulate_records(
        m,
        truth,
        {"S": np.array(SPHERE_CENTRE_MM)},
        programme,
        artefact,
        noise=float(to_internal(NOISE_UM, "µm")),
        raw_points=True,
        points_per_ball=SPHERE_POINTS,
        seed=seed,
    )
    # measurement,ball,axes...,i,j,k -> point,axes...,i,j,k
    header = ["point", *records.header[2:]]
    names = []
    for k, (b, c) in enumerate(SPHERE_BC):
        rows = [r[2:] for r in records.rows if r[0] == str(k + 1)]
        name = f"sphere-B{b:+03d}-C{c:03d}.csv"
        write_csv_table(
            ctx.path("task", name), header, ([str(n + 1), *r] for n, r in enumerate(rows))
        )
        names.append(name)
    return names


def _evaluate(m: Machine, pset: ParameterSet, readings, feature, unexplained):
    """GUF of a feature over the calibration's covariance (the compensation uses its
    estimate) and the unexplained volumetric error; the virtual machine does not drift."""
    return task_uncertainty(
        m,
        readings,
        pset.vector_for(m),
        pset.covariance,
        feature,
        recalibrated=True,
        unexplained_covariance=unexplained,
    )


def sphere_task_section(ctx: DemoContext, *, preset: str) -> None:
    """Sphere diameter at each (B, C) with u, U, decision; coverage over sphere and gauge."""
    base = Machine.load(preset)
    truth = ParameterSet.load(ctx.path("samba", "truth.json"), base).vector_for(base)
    pset = ParameterSet.load(ctx.path("samba", "params.json"), base)
    m = pset.machine_for(base)
    unexplained = load_unexplained_covariance(ctx.path("task", "unexplained.json"))
    tolerance = Tolerance.parse(SPHERE_TOLERANCE)
    # What `mtm task uncertainty --feature sphere` evaluates: the diameter and the sphericity.
    sphere = CombinedFeature((SphereDiameter(2.0 * m.tip_radius, inner=False), Sphericity()))
    rows, intervals, big_u_um = [], [], []
    with ctx.step(
        f"a {SPHERE_DIAMETER_MM:g} mm sphere at {len(SPHERE_BC)} (B, C): task uncertainty"
    ):
        names = _simulate_sphere(ctx, base, truth, ctx.seed + 4)
        for name, (b, c) in zip(names, SPHERE_BC, strict=True):
            readings = readings_from_table(
                m, read_csv_table(ctx.path("task", name), required=("point",))
            )
            result = _evaluate(m, pset, readings, sphere, unexplained)
            g = result.guf
            value, big_u = float(g.estimate[0]), float(g.expanded_uncertainty[0])
            decision = decide(value, big_u, tolerance, unit="mm")
            document = {**result.to_dict(), "decision": decision.to_dict()}
            stem = name.removesuffix(".csv")
            ctx.write_json(document, "task", f"{stem}.json")
            intervals.append(
                (stem, value, big_u, float(g.coverage_factor[0]), g.p, SPHERE_DIAMETER_MM)
            )
            big_u_um.append(float(from_internal(big_u, "µm")))
            u = float(g.standard_uncertainty[0])
            error_um = float(from_internal(value - SPHERE_DIAMETER_MM, "µm"))
            rows.append([
                f"{b:+d}", f"{c:d}", format_value(value, u),
                format_uncertainty(float(from_internal(u, "µm"))),
                format_uncertainty(big_u_um[-1]),
                ("+" if error_um >= 0 else "") + format_value(error_um, from_internal(u, "µm")),
                decision.decision.value,
            ])  # fmt: skip
    first = names[0].removesuffix(".csv")
    ctx.command(
        f"the sphere diameter at B = {SPHERE_BC[0][0]}°, C = {SPHERE_BC[0][1]}° with its "
        "ISO 14253-1 decision",
        "task", "uncertainty", ctx.shown("task", names[0]), "--machine", preset,
        "--params", ctx.shown("samba", "params.json"), "--feature", "sphere", "--recalibrated",
        "--unexplained", ctx.shown("task", "unexplained.json"),
        "--tolerance", SPHERE_TOLERANCE, "-o", ctx.shown("task", f"{first}.json"),
    )  # fmt: skip
    decisions = [r[-1] for r in rows]
    ctx.report.section(
        "A sphere measured at several orientations",
        f"A {SPHERE_DIAMETER_MM:g} mm precision sphere centred at "
        f"({', '.join(f'{v:g}' for v in SPHERE_CENTRE_MM)}) mm on the table, probed with "
        f"{SPHERE_POINTS} points (24 on the equator of the machine axes and the pole, "
        "with their approach directions) at each (B, C) on the virtual machine with its "
        f"true errors and {NOISE_UM:g} µm noise per linear reading. The diameter is "
        "compensated with the calibrated parameters, its uncertainty is the full-covariance "
        "GUF of the task section, and the decision follows ISO 14253-1:2017 with guard "
        f"bands of U: tolerance {tolerance.lower_limit:.3f} to {tolerance.upper_limit:.3f} mm.",
    )
    ctx.report.table(
        ["B (°)", "C (°)", "diameter (mm)", "u (µm)", "U (µm)", "error (µm)", "decision"], rows
    )
    worst = max(intervals, key=lambda t: abs(t[1] - SPHERE_DIAMETER_MM))
    ctx.report.figure(
        figures.conformity_zones(
            worst[1],
            worst[2],
            tolerance.lower_limit,
            tolerance.upper_limit,
            name=f"sphere diameter ({worst[0]})",
            unit="mm",
        ),
        caption="The orientation farthest from the nominal diameter: value ± U against the "
        "tolerance and its ISO 14253-1 conformance zone.",
    )
    coverage = _coverage(ctx, m, pset, unexplained, intervals)
    ctx.summary.append(
        f"sphere {SPHERE_DIAMETER_MM:g} mm at {len(SPHERE_BC)} (B, C): U = "
        f"{format_uncertainty(min(big_u_um))}–{format_uncertainty(max(big_u_um))} µm "
        f"(k = {format_k(intervals[0][3])}); "
        f"ISO 14253-1: {decisions.count('conformance')} conformance of {len(decisions)}"
    )
    ctx.summary.append(
        f"coverage: {coverage.covered}/{coverage.n} task intervals contain the truth "
        f"(expected {100 * coverage.p:.1f} %; P(≤ {coverage.covered}) = "
        f"{coverage.p_at_most:.2f} for independent intervals)"
    )


def _coverage(ctx: DemoContext, m, pset, unexplained, intervals) -> Coverage:
    """Count the gauge and sphere intervals that contain the truth; report and write it."""
    table = read_csv_table(ctx.path("gauge", "gauge.csv"), required=("pair", "end"))
    readings = readings_from_table(m, table)
    gauge = GaugeLength(tip_diameter=2.0 * m.tip_radius)
    true_length = float(np.linalg.norm(GAUGE_ENDS[1] - GAUGE_ENDS[0]))
    pairs = table.strings("pair")
    with ctx.step(f"coverage: {COVERAGE_PAIRS} gauge-length tasks against the truth"):
        for pair in range(1, COVERAGE_PAIRS + 1):
            rows = [k for k, p in enumerate(pairs) if p == str(pair)]
            g = _evaluate(m, pset, readings[rows], gauge, unexplained).guf
            value, big_u = float(g.estimate[0]), float(g.expanded_uncertainty[0])
            k = float(g.coverage_factor[0])
            intervals.append((f"gauge-pair-{pair}", value, big_u, k, g.p, true_length))
    fields = ("feature", "value", "U", "k", "p", "true")
    tasks = [dict(zip(fields, t, strict=True)) for t in intervals]
    for t in tasks:
        t["covered"] = bool(abs(t["value"] - t["true"]) <= t["U"])
    n, covered = len(tasks), sum(t["covered"] for t in tasks)
    p = float(np.mean([t.pop("p") for t in tasks]))
    k = float(np.mean([t["k"] for t in tasks]))
    coverage = Coverage(n, covered, p, float(binom.cdf(covered, n, p)), tuple(tasks))
    ctx.write_json(coverage.to_dict(), "task", "coverage.json")
    ctx.report.section(
        "Coverage of the task intervals against the truth",
        f"{n} simulated tasks ({len(SPHERE_BC)} sphere diameters, {COVERAGE_PAIRS} gauge "
        f"lengths): {covered} intervals value ± U (k = {k:.2f}) contain the true "
        f"value; expected rate {100 * p:.1f} %. For {n} independent intervals the binomial "
        f"probability of at most {covered} covered is {coverage.p_at_most:.3f}. The tasks "
        "share one calibration (its parameter errors are common to all), so they are not "
        "independent: the count is a check, not a test of the coverage probability.",
    )
    ctx.report.table(
        ["tasks", "covered", "expected rate", "P(at most covered)"],
        [[n, covered, f"{100 * p:.1f} %", f"{coverage.p_at_most:.3f}"]],
    )
    return coverage


def task_section(ctx: DemoContext, *, preset: str) -> None:
    """The gauge length of the first indexation with its u, U and conformity decision."""

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
            format_value(g.value, g.u), format_uncertainty(u_um), format_uncertainty(big_u_um),
            format_k(g.k),
            "[{}, {}]".format(*(format_value(x, g.u) for x in decision.acceptance_zone)),
            decision.decision.value,
        ]],
    )  # fmt: skip
    add_result(ctx.report, result.guf)
    add_result(
        ctx.report,
        result.validation,
        units=dict(zip(result.guf.names, result.guf.units, strict=True)),
    )
    validated = "validated" if result.validation.passed else "NOT validated"
    ctx.summary.append(
        f"task: gauge length {format_value(g.value, g.u)} mm, u = {format_uncertainty(u_um)} µm, "
        f"U = {format_uncertainty(big_u_um)} µm "
        f"(k = {format_k(g.k)}, Monte Carlo, {result.mcm.trials} trials; GUF {validated}); "
        f"ISO 14253-1: {decision.decision.value}"
    )


def main(ctx: DemoContext) -> None:
    if not ctx.path("samba", "params.json").exists():  # run on its own: calibrate first
        import samba_calibration

        samba_calibration.main(ctx)
    ctx.rule("Task uncertainty and conformity")
    task_section(ctx, preset=PRESET)
    ctx.rule("A sphere at several B/C; coverage")
    sphere_task_section(ctx, preset=PRESET)


if __name__ == "__main__":
    from mtmetrology.report.demo import run_example

    run_example(main, "task_uncertainty")
