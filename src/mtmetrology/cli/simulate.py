"""``mtm samba simulate`` and ``mtm length simulate``: records of a virtual machine with chosen
errors (commands of the ``mtm samba`` and ``mtm length`` groups)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from mtmetrology.cli._common import (
    ArtefactOption,
    ErrorModelOption,
    MachineOption,
    parse_tools,
    user_errors,
    vector_option,
)
from mtmetrology.errors import InputError

if TYPE_CHECKING:
    from mtmetrology.kinematics.machine import Machine

app = typer.Typer(help="Simulate measurements on a virtual machine.", no_args_is_help=True)

SIMULATE_HELP = """Records of a SAMBA test on a virtual machine with chosen errors.

TRUTH.json: a parameter set (kind parameter-set, or a samba-calibration result) with
the true errors, e.g. {"kind": "parameter-set", "version": 1, "machine":
"five-axis-wcbxfzyst", "parameters": [{"name": "E_X0C", "value": -104.6, "unit":
"µm"}, ...]}; parameters it does not list are zero.

BALLS.yaml: true ball centres in the workpiece frame:

  kind: samba-balls
  balls:
    - {id: "1", centre_mm: [-50, -50, 50]}
    - {id: SB1, centre_mm: [-152.78, 0, 30]}

ARTEFACT.yaml: as for 'mtm samba calibrate' (ball and stylus tip diameters).

POSES.csv: the probing programme, one probing per row in probing order:
ball,B,C[,S][,tool] (degrees).

Several styli: --tool ID=x,y,z (mm, the true vector from the spindle nose to the stylus
centre) once per stylus, ids as in the artefact's tools; each probing uses the tool of
its POSES.csv tool column, or, without one, the whole programme is repeated with each
tool in turn.  A POSES.csv tool column without --tool uses the artefact's vectors.

RECORDS.csv is written in the format 'mtm samba calibrate' reads: ball,X,Y,Z,B,C,S
(ball-centre indications), or measurement,ball,X,Y,Z,B,C,S,i,j,k with --raw-points
(i,j,k: approach direction in machine axes), with a leading campaign column when
--campaigns K > 1, sense_<axis> columns when the model has reversal terms and a tool
column with several styli.
"""

LENGTH_HELP = """Readings of a gauge-block length check on a virtual machine.

Writes READINGS.csv (pair,end,X,Y,Z,B,C[,S]) for 'mtm length verify': the stylus
centre against end a and end b of a length whose end-face centres END_A and END_B
(workpiece frame, mm) are given, at --pairs random (B, C) indexations.
"""


def _truth(machine: Machine, truth: Path | None):
    from mtmetrology.kinematics.parameter_set import ParameterSet

    if truth is None:
        return machine, None
    pset = ParameterSet.load(truth, machine)
    missing = [n for n in pset.names if n not in machine.parameter_names]
    if missing:
        machine = machine.with_parameters([*machine.parameter_names, *missing])
    return machine, pset.vector_for(machine)


@app.command("samba", help=SIMULATE_HELP)
@user_errors
def samba(
    machine: MachineOption,
    artefact: ArtefactOption,
    balls: Annotated[Path, typer.Option("--balls", help="BALLS.yaml (true ball centres).")],
    poses: Annotated[Path, typer.Option("--poses", help="POSES.csv: ball,B,C[,S].")],
    output: Annotated[Path, typer.Option("-o", "--output", help="RECORDS.csv to write.")],
    model: ErrorModelOption = None,
    truth: Annotated[
        Path | None, typer.Option("--truth", help="TRUTH.json (zero errors if omitted).")
    ] = None,
    noise_um: Annotated[
        float, typer.Option("--noise-um", help="Std. deviation of each reading, µm.")
    ] = 0.5,
    raw_points: Annotated[
        bool, typer.Option("--raw-points", help="Write raw probed points.")
    ] = False,
    points_per_ball: Annotated[
        int, typer.Option("--points-per-ball", help="Points per probing (>= 5).")
    ] = 5,
    campaigns: Annotated[int, typer.Option("--campaigns", help="Repetitions K.")] = 1,
    drift_um: Annotated[
        float, typer.Option("--drift-um", help="Linear drift over each campaign, µm.")
    ] = 0.0,
    tool_offset_um: Annotated[
        str | None,
        typer.Option("--tool-offset-um", help="True tool-vector correction dx,dy,dz (µm)."),
    ] = None,
    tool: Annotated[
        list[str] | None,
        typer.Option("--tool", help="A stylus ID=x,y,z (mm); repeat for each stylus."),
    ] = None,
    seed: Annotated[int | None, typer.Option("--seed", help="Random seed.")] = None,
) -> None:
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.samba import load_artefact, load_balls, read_poses, simulate_records
    from mtmetrology.units import to_internal

    if noise_um < 0 or drift_um < 0:
        raise InputError("--noise-um and --drift-um must be >= 0")
    m, theta = _truth(Machine.load(machine, model), truth)
    offset = (0.0, 0.0, 0.0)
    if tool_offset_um:
        um = vector_option(tool_offset_um, "--tool-offset-um", "µm")
        offset = tuple(float(to_internal(v, "µm")) for v in um)
    rec = simulate_records(
        m,
        theta,
        load_balls(balls).centres(),
        read_poses(poses),
        load_artefact(artefact),
        noise=float(to_internal(noise_um, "µm")),
        raw_points=raw_points,
        points_per_ball=points_per_ball,
        campaigns=campaigns,
        drift=float(to_internal(drift_um, "µm")),
        tool_offset=offset,
        tools=parse_tools(tool),
        seed=seed,
    )
    rec.write(output)
    typer.echo(f"wrote {len(rec)} rows to {output}", err=True)


@app.command("length", help=LENGTH_HELP)
@user_errors
def length(
    machine: MachineOption,
    end_a: Annotated[str, typer.Option("--end-a", help="Centre of end face a: x,y,z (mm).")],
    end_b: Annotated[str, typer.Option("--end-b", help="Centre of end face b: x,y,z (mm).")],
    output: Annotated[Path, typer.Option("-o", "--output", help="READINGS.csv to write.")],
    model: ErrorModelOption = None,
    truth: Annotated[Path | None, typer.Option("--truth", help="TRUTH.json.")] = None,
    pairs: Annotated[int, typer.Option("--pairs", help="Number of (B, C) indexations.")] = 20,
    b_max_deg: Annotated[
        float, typer.Option("--b-max-deg", help="Largest |B| of the random indexations.")
    ] = 45.0,
    noise_um: Annotated[float, typer.Option("--noise-um", help="Reading noise, µm.")] = 0.0,
    seed: Annotated[int | None, typer.Option("--seed", help="Random seed.")] = None,
) -> None:
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.samba import simulate_length_check
    from mtmetrology.units import to_internal

    m, theta = _truth(Machine.load(machine, model), truth)
    check = simulate_length_check(
        m,
        theta,
        vector_option(end_a, "--end-a"),
        vector_option(end_b, "--end-b"),
        pairs=pairs,
        b_max_deg=b_max_deg,
        noise=float(to_internal(noise_um, "µm")),
        seed=seed,
    )
    check.write(output)
    typer.echo(f"wrote {pairs} pairs to {output}", err=True)
