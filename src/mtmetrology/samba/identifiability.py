"""Identifiability of a SAMBA probing set-up, before any measurement (``mtm machine
identifiability``).

The Jacobian of the ball-centre indications with respect to the machine's error
parameters, the ball centres, the tool offset (one per stylus) and the scale bars'
lengths is evaluated at the nominal point (zero errors), weighted by the indication
uncertainty σ, and analysed for rank, conditioning and the combinations no set of
measurements of this programme can separate (Alami Mchichi (2018), §4.3: the
observability of the 13- and 84-parameter models).

References
----------
M. Alami Mchichi, *Calibration of five-axis machine tools with the SAMBA method*,
Polytechnique Montréal, 2018, §4.3.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.identification import (
    BallCentreProblem,
    IdentifiabilityReport,
    analyse_identifiability,
    senses_from_sequence,
)
from mtmetrology.io.tables import read_csv_table
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.readings_table import readings_from_table, senses_from_table
from mtmetrology.samba.artefact import load_artefact
from mtmetrology.samba.notebook import SambaNotebookRepr
from mtmetrology.units import to_internal

__all__ = ["SetupIdentifiability", "setup_identifiability"]


@dataclass(frozen=True, eq=False)
class SetupIdentifiability(SambaNotebookRepr):
    """The identifiability of a probing set-up (:func:`setup_identifiability`).

    Attributes
    ----------
    diagnosis : IdentifiabilityReport
        Rank, condition numbers, observability and null directions.
    machine : str
        The machine's name and error model.
    n_params, n_balls, n_indications, n_scale_bars : int
        What the Jacobian was formed from.
    estimate_tool : bool
        Whether the tool offset (one per stylus) is among the unknowns.
    sigma_um : float
        Standard uncertainty of one indication coordinate, µm (the row weight).
    """

    diagnosis: IdentifiabilityReport
    machine: str
    n_params: int
    n_balls: int
    n_indications: int
    n_scale_bars: int
    estimate_tool: bool
    sigma_um: float

    def to_dict(self) -> dict:
        """The diagnosis's document with the indication σ it was weighted with (µm)."""
        return {**self.diagnosis.to_dict(), "sigma_um": self.sigma_um}

    def setup_rows(self) -> list[list]:
        """(item, value) rows of the set-up, for the console and the report."""
        return [
            ["machine", self.machine],
            ["parameters", self.n_params],
            ["balls", self.n_balls],
            ["indications", self.n_indications],
            ["scale bars", self.n_scale_bars],
            ["tool offset", "estimated" if self.estimate_tool else "known"],
            ["indication σ (µm)", self.sigma_um],
        ]


def _styli(table, artefact, path) -> dict:
    """``tools``/``tool_index`` of a programme with a ``tool`` column (several styli, their
    vectors from the artefact's ``tools``), ``{}`` without one."""
    if not table.has("tool"):
        return {}
    names = table.strings("tool")
    listed = [t.id for t in (artefact.tools or [])] if artefact else []
    bad = next((i for i, t in enumerate(names) if t not in listed), None)
    if bad is not None:
        raise InputError(
            f"{path}, line {table.lines[bad]}: tool {names[bad]!r} is not in the artefact's "
            f"tools ({', '.join(listed) or 'give --artefact with tools'})"
        )
    return artefact.stylus_unknowns(names)


def setup_identifiability(
    machine: str | Path | Machine,
    poses: str | Path,
    *,
    model: str | None = None,
    artefact: str | Path | None = None,
    add: list[str] | None = None,
    estimate_tool: bool = True,
    sigma_um: float = 1.0,
) -> SetupIdentifiability:
    """Rank, conditioning and unidentifiable combinations of a probing programme.

    Parameters
    ----------
    machine : str, Path or Machine
        A preset name or machine file (with ``model``), or a machine.
    poses : str or Path
        Ball-centre indications CSV (``ball,X,Y,Z,B,C[,S][,tool]``); their readings are
        the nominal probing readings.
    model : str, optional
        The error model of a preset or file.
    artefact : str or Path, optional
        SAMBA artefact file: its scale bars, and the styli of a ``tool`` column.
    add : list of str, optional
        Extra error parameters to test (ISO 230-1 names).
    estimate_tool : bool
        The tool offset (one per stylus) among the unknowns.
    sigma_um : float
        Standard uncertainty of one indication coordinate, µm (row weights; a scale bar
        keeps its u from the artefact file).

    Returns
    -------
    SetupIdentifiability

    Raises
    ------
    InputError
        A non-positive σ, an unreadable file, or a tool not in the artefact's tools
        (named by file and line).
    """
    if not (np.isfinite(sigma_um) and sigma_um > 0):
        raise InputError(f"--sigma-um must be a positive number of µm, got {sigma_um}")
    m = machine if isinstance(machine, Machine) else Machine.load(machine, model)
    if add:
        m = m.with_parameters([*m.parameter_names, *add])
    table = read_csv_table(poses, required=["ball"])
    q = readings_from_table(m, table)
    senses = senses_from_table(m, table)
    if senses is None and m.chain.has_reversal:
        senses = senses_from_sequence(q)
    art = load_artefact(artefact) if artefact else None
    bars = art.scale_bars() if art else []
    problem = BallCentreProblem(
        m,
        q,
        table.strings("ball"),
        senses=senses,
        scale_bars=bars,
        estimate_tool=estimate_tool,
        sigma=float(to_internal(sigma_um, "µm")),
        **_styli(table, art, poses),
    )
    _, jac = problem.evaluate(problem.initial())
    diagnosis = analyse_identifiability(
        jac, problem.names, n_measurements=len(table), report_names=m.parameter_names
    )
    return SetupIdentifiability(
        diagnosis=diagnosis,
        machine=f"{m.name} model {m.model_name or 'custom'}",
        n_params=m.n_params,
        n_balls=problem.n_balls,
        n_indications=len(table),
        n_scale_bars=len(bars),
        estimate_tool=estimate_tool,
        sigma_um=float(sigma_um),
    )
