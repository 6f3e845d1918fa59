"""Simulated SAMBA records: a virtual machine with chosen errors probes a virtual artefact.

The balls sit at known centres in the workpiece frame; a probing programme lists
``ball,B,C[,S]`` rows in probing order (the planner's format).  For every row the
inverse kinematics of the *erroneous* machine (:meth:`Machine.inverse`) finds the linear
readings that put the stylus centre on the target, so the records carry exactly the
machine's errors; Gaussian noise of standard deviation σ is then added to every linear
reading (probing repeatability).

With ``raw_points`` each probing becomes ``points_per_ball`` triggers: the stylus centre
touches the ball at distance ρ = (ball diameter + tip diameter)/2 from its centre, on the
equator (machine X/Y directions, evenly spaced) and at the pole (machine +Z, the spindle
direction) — the five-point probing of Alami Mchichi (2018) — each point with its own noise; the
approach direction (i, j, k) of the probe, in machine axes, is written with it.

K campaigns repeat the programme with independent noise; a drift adds to campaign k a
ramp of the linear readings from 0 to ``drift`` along a random unit direction over the
programme (a thermal drift during the test).

Files
-----
``BALLS.yaml``::

    kind: samba-balls
    balls:
      - {id: "1", centre_mm: [-80.0, -40.0, 100.0]}
      - {id: SB1, centre_mm: [-152.785, 0.0, 30.0]}

``POSES.csv``: ``ball,B,C[,S][,tool]`` (degrees), one probing per row, in probing order.

Several styli (Alami Mchichi (2018) Table 4.4: a second stylus length separates the pairs
one length confounds, e.g. E_AY1 ~ E_YY1): each probing is made with the tool its
``tool`` column names; without that column the whole programme is repeated with every
tool in turn.  The records then carry the ``tool`` column :func:`read_records
<mtmetrology.samba.read_records>` reads, and the tool ids must be the artefact's ``tools``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from mtmetrology.identification import senses_from_sequence
from mtmetrology.io.documents import load_document
from mtmetrology.io.files import InputFileError
from mtmetrology.io.schema import describe_validation_error
from mtmetrology.io.tables import read_csv_table, write_csv_table
from mtmetrology.kinematics.machine import Machine
from mtmetrology.rng import SeedLike, as_generator
from mtmetrology.samba.artefact import SambaArtefact
from mtmetrology.samba.records import check_travel

__all__ = [
    "BallLayout",
    "ProbingProgramme",
    "SimulatedRecords",
    "load_balls",
    "read_poses",
    "simulate_records",
]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class _BallPosition(_Strict):
    id: str
    centre_mm: tuple[float, float, float]


class BallLayout(_Strict):
    """Ball centres of a virtual artefact in the workpiece frame (mm)."""

    kind: str = Field(pattern="^samba-balls$", default="samba-balls")
    balls: list[_BallPosition] = Field(min_length=1)

    def centres(self) -> dict[str, np.ndarray]:
        return {b.id: np.asarray(b.centre_mm, dtype=float) for b in self.balls}


def load_balls(path: str | Path) -> BallLayout:
    """Read a ``samba-balls`` YAML file (strict; errors name the file and field)."""
    data = load_document(path, "SAMBA ball layout")
    try:
        layout = BallLayout.model_validate(data)
    except ValidationError as err:
        raise InputFileError(describe_validation_error(str(path), "ball layout", err)) from None
    ids = [b.id for b in layout.balls]
    dup = sorted({i for i in ids if ids.count(i) > 1})
    if dup:
        raise InputFileError(f"{path}: balls: id(s) listed twice: {', '.join(dup)}")
    return layout


@dataclass(frozen=True, eq=False)
class ProbingProgramme:
    """Probings in order: ball ids, their rotary readings (degrees) and, optionally, the
    tool (stylus) id of each probing."""

    balls: tuple[str, ...]
    b_deg: np.ndarray
    c_deg: np.ndarray
    s_deg: np.ndarray
    tools: tuple[str, ...] | None = None

    def __len__(self) -> int:
        return len(self.balls)


def read_poses(path: str | Path) -> ProbingProgramme:
    """Read a probing programme CSV ``ball,B,C[,S][,tool]`` (degrees)."""
    table = read_csv_table(path, required=["ball", "B", "C"])
    s = table.floats("S") if table.has("S") else np.zeros(len(table))
    tools = tuple(table.strings("tool")) if table.has("tool") else None
    return ProbingProgramme(
        tuple(table.strings("ball")), table.floats("B"), table.floats("C"), s, tools
    )


def _with_tools(
    programme: ProbingProgramme, artefact: SambaArtefact, tools
) -> tuple[ProbingProgramme, np.ndarray | None]:
    """The programme with a tool id per probing and the (n, 3) true tool vectors (None for
    one unnamed tool): the programme repeated per tool when it names none."""
    listed = {t.id: np.asarray(t.vector_mm, dtype=float) for t in artefact.tools or []}
    if tools is None and programme.tools is None:
        return programme, None
    vectors = listed if tools is None else {k: np.asarray(v, dtype=float) for k, v in tools.items()}
    if not vectors:
        raise InputFileError(
            "poses: a tool column needs the styli: list them under tools in the artefact "
            "file (or give --tool ID=x,y,z)"
        )
    unknown = [t for t in vectors if t not in listed]
    if unknown:
        raise InputFileError(
            f"tool {unknown[0]!r} is not in the artefact's tools "
            f"({', '.join(listed) or 'none listed'}); mtm samba calibrate reads its nominal "
            "vector there"
        )
    if programme.tools is None:
        k = len(vectors)
        programme = ProbingProgramme(
            programme.balls * k,
            np.tile(programme.b_deg, k),
            np.tile(programme.c_deg, k),
            np.tile(programme.s_deg, k),
            tuple(t for t in vectors for _ in programme.balls),
        )
    missing = next((i for i, t in enumerate(programme.tools) if t not in vectors), None)
    if missing is not None:
        raise InputFileError(
            f"{_probing(missing)}: tool {programme.tools[missing]!r} is not among the tools "
            f"({', '.join(vectors)})"
        )
    return programme, np.array([vectors[t] for t in programme.tools])


@dataclass(frozen=True, eq=False)
class SimulatedRecords:
    """Records in the user's CSV format (header and formatted rows)."""

    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]

    def write(self, path: str | Path) -> None:
        """Write the CSV atomically."""
        write_csv_table(path, self.header, self.rows)

    def __len__(self) -> int:
        return len(self.rows)


def _equator_and_pole(count: int) -> np.ndarray:
    """Unit approach normals (count, 3) in machine axes: equator points and the pole."""
    k = count - 1
    angles = 2.0 * np.pi * np.arange(k) / k
    ring = np.column_stack([np.cos(angles), np.sin(angles), np.zeros(k)])
    return np.vstack([ring, [0.0, 0.0, 1.0]])


def simulate_records(
    machine: Machine,
    truth: np.ndarray | None,
    balls: dict[str, np.ndarray],
    programme: ProbingProgramme,
    artefact: SambaArtefact,
    *,
    noise: float = 0.0,
    raw_points: bool = False,
    points_per_ball: int = 5,
    campaigns: int = 1,
    drift: float = 0.0,
    tool_offset=(0.0, 0.0, 0.0),
    tools: dict | None = None,
    seed: SeedLike = None,
) -> SimulatedRecords:
    """Records of a SAMBA test on a virtual machine.

    Parameters
    ----------
    machine : Machine
        The machine with the error model of ``truth``.
    truth : (n_params,) ndarray or None
        True error parameters, internal units (zero when None).
    balls : dict of str to (3,) array
        True ball centres in the workpiece frame, mm.
    programme : ProbingProgramme
        Probings in order.
    artefact : SambaArtefact
        Ball diameters and stylus tip diameter (raw points).
    noise : float
        Standard deviation of each linear reading, mm.
    raw_points : bool
        Write raw probed points instead of ball-centre indications.
    points_per_ball : int
        Points per probing (≥ 5: equator points and the pole).
    campaigns : int
        Repetitions K of the whole programme (a ``campaign`` column when K > 1).
    drift : float
        Amplitude of the linear drift over each campaign, mm.
    tool_offset : (3,) array_like
        True tool-vector correction (mm) of the virtual probe (of every tool).
    tools : dict of str to (3,) array_like, optional
        True vector (mm, spindle nose to stylus centre, as the machine's ``tool``) of each
        stylus of a test with several; ids must be the artefact's ``tools``.  When omitted
        and the programme names tools, the artefact's nominal vectors are used.  A
        programme without a ``tool`` column is repeated with each tool in turn; the
        records get a ``tool`` column.
    seed : int, SeedSequence or Generator

    Returns
    -------
    SimulatedRecords

    Raises
    ------
    InputFileError
        A probing of a ball that is not in the layout or the artefact, a reading outside
        the travel, too few points per ball.

    Examples
    --------
    >>> from mtmetrology.samba.artefact import SambaArtefact
    >>> m = Machine.load("five-axis-wcbxfzyst", "13")
    >>> art = SambaArtefact(balls=[{"id": "1", "diameter_mm": 19.05}])
    >>> prog = ProbingProgramme(("1", "1"), np.array([0.0, 90.0]), np.zeros(2), np.zeros(2))
    >>> rec = simulate_records(m, None, {"1": np.array([10.0, 0.0, 100.0])}, prog, art)
    >>> rec.header
    ('ball', 'X', 'Y', 'Z', 'B', 'C', 'S')
    >>> rec.rows[1][:4]   # at B = 90° the point (x, y, z) is read at X = −z, Z = x
    ('1', '-100.000000', '0.000000', '10.000000')
    """
    if points_per_ball < 5 and raw_points:
        raise InputFileError(f"points per ball must be at least 5, got {points_per_ball}")
    if campaigns < 1:
        raise InputFileError(f"campaigns must be at least 1, got {campaigns}")
    diameters = {b.id: b.diameter_mm for b in artefact.balls}
    for b in dict.fromkeys(programme.balls):
        if b not in balls:
            raise InputFileError(f"poses: ball {b!r} has no centre in the ball layout")
        if b not in diameters:
            raise InputFileError(f"poses: ball {b!r} is not in the artefact file")
    if raw_points and artefact.stylus_tip_diameter_mm is None:
        raise InputFileError("raw points need stylus_tip_diameter_mm in the artefact file")
    programme, tool_rows = _with_tools(programme, artefact, tools)
    rng = as_generator(seed)
    has_s = "S" in machine.axis_names
    values = {"B": programme.b_deg, "C": programme.c_deg}
    if has_s:
        values["S"] = programme.s_deg
    values.update({a: np.zeros(len(programme)) for a in machine.linear_axes})
    start = machine.readings_from_customary(values)
    check_travel(machine, start, _probing)
    senses = senses_from_sequence(start)
    reversal = any(p.kind == "reversal" for p in machine.parameters)
    offset = np.asarray(tool_offset, dtype=float)
    tool = machine.tool + offset if tool_rows is None else tool_rows + offset
    centres = np.array([balls[b] for b in programme.balls])
    linear = [i for i, a in enumerate(machine.axis_names) if a in machine.linear_axes]
    n = len(programme)
    q = machine.inverse(centres, start, truth, senses=senses, tool=tool)
    per = 1
    normals = np.zeros((1, 3))
    if raw_points:
        normals = _equator_and_pole(points_per_ball)  # (P, 3) machine axes
        per = normals.shape[0]
        # workpiece direction of each machine direction at the probing: A n / ‖A n‖
        a = machine.axis_jacobian(q, truth, senses=senses, tool=tool)[:, :, linear]  # (n,3,3)
        tool = tool if tool_rows is None else tool[:, None, :]
        dirs = np.einsum("kij,pj->kpi", a, normals)
        dirs /= np.linalg.norm(dirs, axis=2, keepdims=True)
        rho = np.array(
            [0.5 * (diameters[b] + artefact.stylus_tip_diameter_mm) for b in programme.balls]
        )
        targets = centres[:, None, :] + rho[:, None, None] * dirs  # (n, P, 3)
        q = machine.inverse(
            targets,
            np.repeat(q[:, None, :], per, axis=1),
            truth,
            senses=senses[:, None, :],
            tool=tool,
        )  # (n, P, n_axes)
    else:
        q = q[:, None, :]
    check_travel(machine, q.reshape(-1, machine.n_axes), lambda i: _probing(i // per))
    header = ["campaign"] if campaigns > 1 else []
    header += ["measurement"] if raw_points else []
    header += ["ball", *machine.axis_names]
    header += ["i", "j", "k"] if raw_points else []
    header += [f"sense_{a}" for a in machine.axis_names] if reversal else []
    header += ["tool"] if tool_rows is not None else []
    rows = []
    ramp = np.linspace(0.0, 1.0, n) if n > 1 else np.zeros(1)
    for c in range(campaigns):
        noisy = q.copy()
        noisy[..., linear] += noise * rng.standard_normal((n, per, len(linear)))
        if drift:
            direction = rng.standard_normal(len(linear))
            direction /= np.linalg.norm(direction)
            noisy[..., linear] += drift * ramp[:, None, None] * direction
        custom = machine.readings_to_customary(noisy)
        for k in range(n):
            for j in range(per):
                row = [str(c + 1)] if campaigns > 1 else []
                row += [str(k + 1)] if raw_points else []
                row.append(programme.balls[k])
                row += [_fmt(v) for v in custom[k, j]]
                row += [_fmt(-v) for v in normals[j]] if raw_points else []
                row += [f"{int(s):+d}" for s in senses[k]] if reversal else []
                row += [programme.tools[k]] if tool_rows is not None else []
                rows.append(tuple(row))
    return SimulatedRecords(tuple(header), tuple(rows))


def _probing(i: int) -> str:
    return f"poses: probing {i + 1}"


def _fmt(v: float) -> str:
    # 1 nm resolution on lengths and 1e-6 degree on angles: below any probing noise
    return f"{v:.6f}" if v != 0 else "0.000000"
