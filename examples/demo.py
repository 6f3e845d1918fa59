"""mtmetrology demo: the engines on the built-in five-axis machine (run by ``make demo``).

1. The machine and its parameter catalogue (Mitsui Seiki HU40-T, WCBXFZYST).
2. Identifiability of SAMBA set-ups: the 13-parameter and 84-coefficient models,
   and the confounds the sources report (digests 000/004, identifiability check).
3. A simulated SAMBA calibration: errors of the size of seed 000 Table 5-2 injected,
   1 µm probing noise, Gauss–Newton identification with uncertainties.
4. Compensated readings: the two probed points of seed 000 Table 7-1 and their gauge
   length (499.9966 mm), then the uncertainty engine on GUM H.1 and a sphere fit.

Every number printed is computed here; nothing is pasted from the sources.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from mtmetrology.fitting.features import GaugeLength
from mtmetrology.fitting.least_squares import fit_sphere
from mtmetrology.fitting.minimum_zone import sphericity
from mtmetrology.identification import (
    BallCentreProblem,
    ScaleBar,
    analyse_identifiability,
    gauss_newton,
    senses_from_sequence,
)
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.conventions import describe_parameter
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.samba import SambaSetup, probing_sequence
from mtmetrology.uncertainty.guf import guf
from mtmetrology.uncertainty.mcm import monte_carlo
from mtmetrology.uncertainty.modelfile import load_model
from mtmetrology.uncertainty.validation import validate_guf
from mtmetrology.units import from_internal, to_internal

console = Console(width=110)
SEED = 2026

SETUP = SambaSetup(
    balls={
        "1": (-80.0, -40.0, 100.0),
        "2": (80.0, -40.0, 150.0),
        "3": (80.0, 120.0, 75.0),
        "4": (-80.0, 120.0, 175.0),
    },
    scale_bar={"SB1": (-152.60525, 0.0, 30.0), "SB2": (152.60525, 0.0, 30.0)},
)
GRID = [(b, c) for b in (-90, -45, 0, 45, 90) for c in range(0, 360, 60)]

# Error values of the size identified in seed 000 Table 5-2 (µm, µrad, µm/m), used as the
# "true" machine of the simulation.
TRUE_ERRORS = {
    "E_A0B": -8.73, "E_C0B": -2.80, "E_X0C": -104.59, "E_A0C": -18.75, "E_B0C": -4.40,
    "E_B0Z": -12.23, "E_A0Y": -13.87, "E_C0Y": 25.81, "E_XX1": 75.6, "E_YY1": 102.0,
    "E_ZZ1": 113.4, "E_Y0S": 18.72, "E_X0S": -107.15,
}  # fmt: skip


def section(title: str) -> None:
    console.rule(f"[bold]{title}")


def identifiability_report(machine, pairs, *, bar_pairs=((0, 0), (0, 90)), backlash=False):
    ids, q = probing_sequence(machine, SETUP, pairs, bar_pairs_deg=bar_pairs)
    problem = BallCentreProblem(
        machine,
        q,
        ids,
        senses=senses_from_sequence(q) if backlash else None,
        scale_bars=[ScaleBar(("SB1", "SB2"), SETUP.scale_bar_length, u=0.001)],
        estimate_tool=True,
        sigma=0.001,
    )
    _, jac = problem.evaluate(problem.initial())
    return analyse_identifiability(jac, problem.names, report_names=machine.parameter_names)


def show_machine(m: Machine) -> None:
    section("1. Machine: five-axis-wcbxfzyst (Mitsui Seiki HU40-T)")
    console.print(f"topology {m.topology.string}; axes {', '.join(m.axis_names)}")
    console.print(
        f"catalogue of candidate errors (degree ≤ 3): {len(m.catalogue())} parameters; "
        f"error models: {', '.join(m.spec.error_models)}"
    )
    t = Table(title="13-parameter SAMBA model (seed 004 Table 5.1)")
    for col in ("parameter", "unit", "meaning"):
        t.add_column(col)
    for p, u in zip(m.parameters, m.parameter_units, strict=True):
        t.add_row(p.name, u, describe_parameter(m, p.name).positive)
    console.print(t)


def show_identifiability(m: Machine) -> None:
    section("2. Identifiability of SAMBA set-ups (4 balls + scale bar, spindle indexing)")
    t = Table()
    for col in ("set-up", "unknowns", "rank", "cond (scaled)", "unidentifiable"):
        t.add_column(col)

    def row(label, rep):
        cond = f"{rep.condition_scaled:.1f}" if rep.full_rank else "—"
        names = "; ".join(str(d) for d in rep.null_directions) or "none"
        t.add_row(label, str(rep.n_unknowns), str(rep.rank), cond, names)

    row("13 parameters, B×C grid 5×6", identifiability_report(m, GRID))
    for extra in ("E_Y0C", "E_A0Z"):
        row(
            f"13 + {extra}",
            identifiability_report(m.with_parameters([*m.parameter_names, extra]), GRID),
        )
    m84 = Machine.load("five-axis-wcbxfzyst", "84")
    rng = np.random.default_rng(SEED)
    cands = [(b, c) for b in range(-90, 91, 15) for c in range(0, 360, 15) if (b, c) != (0, 0)]
    pairs17 = sorted([(0, 0)] + [cands[i] for i in rng.choice(len(cands), 16, replace=False)])
    row(
        "84 coefficients, 17 non-linear (B, C)", identifiability_report(m84, pairs17, backlash=True)
    )
    line = [(b, 3 * b) for b in range(-90, 91, 15)]
    row(
        "84 coefficients, c = 3b (seed 004 Table 4.1)",
        identifiability_report(m84, line, bar_pairs=((0, 0),), backlash=True),
    )
    console.print(t)


def simulated_calibration(m: Machine) -> ParameterSet:
    section("3. Simulated SAMBA calibration (13 parameters, 1 µm probing noise)")
    truth = np.array(
        [
            to_internal(TRUE_ERRORS[n], u)
            for n, u in zip(m.parameter_names, m.parameter_units, strict=True)
        ]
    )
    ids, q0 = probing_sequence(m, SETUP, GRID)
    targets = np.array([SETUP.balls.get(i, SETUP.scale_bar.get(i)) for i in ids])
    q = m.inverse(targets, q0, truth)
    rng = np.random.default_rng(SEED)
    q[:, :3] += 0.001 * rng.standard_normal((len(ids), 3))
    bar = ScaleBar(("SB1", "SB2"), SETUP.scale_bar_length, u=0.0012)
    result = gauss_newton(
        BallCentreProblem(m, q, ids, scale_bars=[bar], estimate_tool=True, sigma=0.001)
    )
    console.print(f"{len(ids)} ball-centre indications; {result.message}")
    t = Table()
    for col in ("parameter", "unit", "true", "identified", "u (k=1)"):
        t.add_column(col, justify="right")
    est = result.estimate[: m.n_params]
    u = result.standard_uncertainty[: m.n_params]
    for i, (n, unit) in enumerate(zip(m.parameter_names, m.parameter_units, strict=True)):
        t.add_row(
            n,
            unit,
            f"{TRUE_ERRORS[n]:.2f}",
            f"{from_internal(est[i], unit):.2f}",
            f"{from_internal(u[i], unit):.2f}",
        )
    console.print(t)
    return result.parameter_set(m, {"source": "make demo, simulated SAMBA"})


def compensated_readings(m: Machine, pset: ParameterSet) -> None:
    section("4. Compensated readings: seed 000 Table 7-1 gauge-block bipoint")
    readings = {"X": [-138.5650, -61.2880], "Y": [94.6560, 48.3440], "Z": [196.2320, 246.8170],
                "B": [-42.0, -64.0], "C": [-293.0, -124.0]}  # fmt: skip
    q = m.readings_from_customary(readings)
    nominal = m.forward(q)
    compensated = m.forward(q, pset.vector_for(m))
    t = Table()
    for col in ("point", "readings X, Y, Z (mm), B, C (°)", "nominal x, y, z (mm)",
                "compensated x, y, z (mm)"):  # fmt: skip
        t.add_column(col)
    for i in range(2):
        r = ", ".join(f"{readings[a][i]:g}" for a in "XYZBC")
        t.add_row(str(i + 1), r, ", ".join(f"{v:.4f}" for v in nominal[i]),
                  ", ".join(f"{v:.4f}" for v in compensated[i]))  # fmt: skip
    console.print(t)
    gauge = GaugeLength(tip_diameter=5.925)
    published = np.array([[-178.6461, -178.6461, 53.1107], [179.1009, 179.0881, 53.1067]])
    console.print(
        f"gauge length from the published compensated points: "
        f"{float(gauge.value(published)):.4f} mm (seed 000: 499.9966 mm); "
        f"nominal model: {float(gauge.value(nominal)):.4f} mm; "
        f"compensated with the simulation's parameters (not the thesis's machine): "
        f"{float(gauge.value(compensated)):.4f} mm"
    )


def uncertainty_and_fit() -> None:
    section("5. Uncertainty engine (GUM H.1) and geometric elements")
    model = load_model(Path(__file__).with_name("gum-h1-end-gauge.yaml"))
    g = guf(model.model, model.inputs, p=0.99)
    mc = monte_carlo(model.model, model.inputs, trials=200_000, seed=SEED, p=0.99)
    report = validate_guf(g.estimate, g.covariance, mc, tolerance=0.5, p=0.99,
                          guf_interval=g.interval)  # fmt: skip
    console.print(
        f"end gauge: GUF u_c = {g.standard_uncertainty[0]:.1f} nm (GUM H.1: 32 nm), "
        f"ν_eff = {g.dof_effective[0]:.1f}, U99 = {g.expanded_uncertainty[0]:.0f} nm; "
        f"Monte Carlo u = {mc.standard_uncertainty[0]:.1f} nm; "
        f"GUF validated at δ = 0.5 nm: {'yes' if report.passed else 'no'} (the product terms "
        f"δα·θ and α_s·δθ are not linear: GUM H.1.7 gives 34 nm to second order)"
    )
    rng = np.random.default_rng(SEED)
    d = rng.standard_normal((25, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d[:, 2] = np.abs(d[:, 2])  # upper hemisphere, as probed on a mounted sphere
    points = np.array([10.0, -20.0, 5.0]) + (12.7 + 0.002 * rng.standard_normal(25))[:, None] * d
    ls = fit_sphere(points)
    mz = sphericity(points)
    console.print(
        f"sphere, 25 points with 2 µm form error: LS radius {ls.element.radius:.4f} mm, "
        f"LS sphericity {1e3 * ls.form_error:.2f} µm, minimum-zone sphericity "
        f"{1e3 * mz.form_error:.2f} µm"
    )


def main() -> None:
    m = Machine.load("five-axis-wcbxfzyst")
    show_machine(m)
    show_identifiability(m)
    pset = simulated_calibration(m)
    compensated_readings(m, pset)
    uncertainty_and_fit()


if __name__ == "__main__":
    main()
