"""The neutral compensation model: ISO 230-1 error functions tabulated over their axes.

A calibration identifies error parameters θ with covariance U (a
:class:`~mtmetrology.kinematics.parameter_set.ParameterSet`).  Each error motion of the
machine is a function of one axis position, ``E_XX(x) = Σ_d θ_d φ_d(x)`` in the basis of the
machine definition (:mod:`mtmetrology.kinematics.basis`, the same values the kinematic chain
uses), plus a reversal term ``E_XXb · sense``.  On a grid ``q_1 … q_n`` over the axis travel
the tabulated values are linear in the coefficients,

    v = s · (A θ),   A[i, d] = φ_d(q_i)   (+ ±1 in the column of the reversal term),

with ``s = +1`` for an error table and ``s = −1`` for a correction table (correction =
− error).  Their covariance follows exactly (no linearisation is involved)::

    Cov(v) = A U Aᵀ.

Location errors (``E_C0Y``, ``E_X0C`` …) are position independent; they are carried as
constants with their own covariance block.  Every value keeps the ISO 230-1 sign: a
positive error motion is a deviation of the tool relative to the workpiece in the positive
direction of the principal axis, whichever component (tool side or workpiece side) moves
(ISO 230-1:2012, §3.4; ISO 841), so a correction table has the same meaning on a
table-side and a tool-side axis; the side is stated for the controls that need it.

References
----------
ISO 230-1:2012, *Test code for machine tools — Part 1: Geometric accuracy of machines
operating under no-load or quasi-static conditions*, §3 (error motions, location errors).
JCGM 100:2008 (GUM), §5.2 (law of propagation of uncertainty; exact for a linear model).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mtmetrology._memory import require_memory
from mtmetrology.errors import InputError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.kinematics.parameters import COMPONENTS
from mtmetrology.kinematics.topology import LINEAR_AXES

__all__ = [
    "FLAGS",
    "CompensationModel",
    "ErrorTable",
    "axis_grid",
    "compensation_model",
    "design",
    "function_columns",
]

#: ``error``: the table holds E(q); ``correction``: it holds −E(q).
FLAGS = ("error", "correction")
_DEG = np.pi / 180.0


@dataclass(frozen=True)
class ErrorTable:
    """One ISO 230-1 error function tabulated over its axis.

    Attributes
    ----------
    function : str
        ISO 230-1 name of the function, e.g. ``"E_XX"`` (error direction, moving axis).
    axis : str
        The moving axis; ``component`` the error direction (``X`` … ``C``).
    side : {"tool", "workpiece"}
        The branch of the chain that carries the axis.
    positions : ndarray, shape (n,)
        Equally spaced axis positions, internal units (mm or rad), ascending.
    forward, reverse : ndarray, shape (n,)
        Tabulated values for travel in the positive and negative direction (equal when the
        model has no reversal term), internal units (mm or rad), with the model's flag.
    sensitivity : ndarray, shape (2n, n_params)
        ``∂(forward, reverse)/∂θ``: the linear map from the parameters to the values.
    covariance : ndarray, shape (2n, 2n) or (n, n), or None
        ``A U Aᵀ`` of (forward, reverse), internal units — of the forward values alone when
        the table has no reversal term (the reverse values are the same); None without a
        parameter covariance.
    """

    function: str
    axis: str
    component: str
    side: str
    positions: np.ndarray
    forward: np.ndarray
    reverse: np.ndarray
    sensitivity: np.ndarray
    covariance: np.ndarray | None

    @property
    def is_rotation(self) -> bool:
        """True for an angular error function (``E_A*``, ``E_B*``, ``E_C*``)."""
        return self.component in "ABC"

    @property
    def unit(self) -> str:
        """Customary unit of the values: µm or µrad."""
        return "µrad" if self.is_rotation else "µm"

    @property
    def pitch(self) -> float:
        """Spacing of the positions (internal units)."""
        return float(self.positions[1] - self.positions[0])

    @property
    def bidirectional(self) -> bool:
        """Whether the forward and reverse values differ (a reversal term is modelled)."""
        return not np.array_equal(self.forward, self.reverse)

    @property
    def u_forward(self) -> np.ndarray | None:
        """Standard uncertainties of the forward values (internal units)."""
        if self.covariance is None:
            return None
        n = self.positions.size
        return np.sqrt(np.clip(np.diag(self.covariance)[:n], 0.0, None))

    @property
    def u_reverse(self) -> np.ndarray | None:
        """Standard uncertainties of the reverse values (internal units)."""
        if self.covariance is None:
            return None
        n = self.positions.size
        d = np.diag(self.covariance)
        return np.sqrt(np.clip(d[n:] if d.size == 2 * n else d, 0.0, None))


@dataclass(frozen=True)
class CompensationModel:
    """Error functions of a machine tabulated over its axes, with their covariance.

    Attributes
    ----------
    machine : Machine
        The machine with the parameter set's error model active.
    parameters : ParameterSet
    flag : {"error", "correction"}
    tables : tuple of ErrorTable
        One per error function of the model on the selected axes.
    constants : tuple of (str, float)
        Location errors (name, value with the flag, internal units).
    reference : dict of str to float
        Reference position of each tabulated axis (internal units): the axis position the
        control's reference point is at (travel minimum unless given).
    measured : tuple of MeasuredTable
        Error functions known as measured tables rather than parameters (an ISO 230-2
        pitch table, :mod:`mtmetrology.export.tabulated`); the residual check takes the
        machine's error from them.  Empty for a model of a parameter set.
    """

    machine: Machine
    parameters: ParameterSet
    flag: str
    tables: tuple[ErrorTable, ...]
    constants: tuple[tuple[str, float], ...]
    reference: dict
    measured: tuple = ()

    @property
    def sign(self) -> float:
        """+1 for an error model, −1 for a correction model."""
        return 1.0 if self.flag == "error" else -1.0

    def table(self, function: str) -> ErrorTable:
        """The table of ``function`` (``"E_XX"``)."""
        for t in self.tables:
            if t.function == function:
                return t
        raise InputError(
            f"{function}: not an error function of this model "
            f"(functions: {', '.join(t.function for t in self.tables) or 'none'})"
        )

    @property
    def theta(self) -> np.ndarray:
        """Parameter values ordered as the machine's parameters (internal units)."""
        return self.parameters.vector_for(self.machine)


def axis_points(
    machine: Machine,
    axis: str,
    *,
    pitch: float | None = None,
    points: int | None = None,
) -> int:
    """How many positions :func:`axis_grid` gives, refused the same way, without building
    them: the size every table limit and memory bound is checked on first.

    Raises
    ------
    InputError
        No travel, a pitch not positive or larger than the travel, fewer than 2 points.
    """
    geom = machine.axes[axis]
    if geom.travel is None:
        raise InputError(f"{machine.name}: axes.{axis}: no travel stated; a table needs one")
    lo, hi = geom.travel
    length = hi - lo
    unit = "mm" if axis in LINEAR_AXES else "°"
    scale = 1.0 if axis in LINEAR_AXES else _DEG
    if (pitch is None) == (points is None):
        raise InputError("give exactly one of pitch and points")
    if pitch is not None:
        if not (np.isfinite(pitch) and pitch > 0):
            raise InputError(f"pitch: {pitch:g} {unit} must be positive")
        step = pitch * scale
        if step > length * (1 + 1e-12):
            raise InputError(
                f"pitch: {pitch:g} {unit} is larger than the travel of {axis} "
                f"({length / scale:g} {unit})"
            )
        return int(np.ceil(length / step - 1e-9)) + 1
    if points < 2:
        raise InputError(f"points: {points} < 2; a table needs two points at least")
    return int(points)


def axis_grid(
    machine: Machine,
    axis: str,
    *,
    pitch: float | None = None,
    points: int | None = None,
) -> np.ndarray:
    """Equally spaced positions over the travel of ``axis`` (internal units).

    Parameters
    ----------
    machine : Machine
    axis : str
    pitch : float, optional
        Spacing in mm (linear axis) or degrees (rotary axis); the grid starts at the travel
        minimum and its last point is the first at or beyond the travel maximum.
    points : int, optional
        Number of points from travel minimum to maximum (≥ 2); exclusive with ``pitch``.

    Raises
    ------
    InputError
        No travel, a pitch not positive or larger than the travel, fewer than 2 points.
    """
    n = axis_points(machine, axis, pitch=pitch, points=points)
    lo, hi = machine.axes[axis].travel
    if pitch is not None:
        step = pitch * (1.0 if axis in LINEAR_AXES else _DEG)
        return lo + step * np.arange(n)
    return np.linspace(lo, hi, n)


def table_sizes(
    machine: Machine,
    *,
    pitch: float | dict | None = None,
    points: int | dict | None = None,
    axes: Sequence[str] | None = None,
) -> dict[str, int]:
    """Points of each table :func:`compensation_model` would build (function -> n), from
    the travels alone."""
    wanted = [a.upper() for a in axes] if axes else None
    out = {}
    for function in function_columns(machine):
        axis = function[3]
        if (wanted is not None and axis not in wanted) or axis not in machine.axis_names:
            continue
        pa = pitch.get(axis) if isinstance(pitch, dict) else pitch
        pn = points.get(axis) if isinstance(points, dict) else points
        out[function] = axis_points(machine, axis, pitch=pa, points=pn)
    return out


def design(machine: Machine, columns: Sequence[int], q: np.ndarray, sign: float) -> np.ndarray:
    """``∂(forward, reverse)/∂θ`` of one error function at positions ``q``, shape (2n, P).

    ``columns`` are the indices (in ``machine.parameters``) of the function's motion
    coefficients and reversal term; the basis values are the kinematic chain's own
    (:meth:`~mtmetrology.kinematics.basis.Basis.values`).
    """
    q = np.asarray(q, dtype=float)
    n = q.size
    axis = machine.parameters[columns[0]].axis
    motions = [machine.parameters[j] for j in columns if machine.parameters[j].kind == "motion"]
    phi, _ = machine.axes[axis].basis.values(q, max((p.degree for p in motions), default=0))
    a = np.zeros((2 * n, machine.n_params))
    for j in columns:
        p = machine.parameters[j]
        if p.kind == "motion":
            a[:n, j] = phi[p.degree]
            a[n:, j] = phi[p.degree]
        else:  # the reversal term times the sense of motion
            a[:n, j] = 1.0
            a[n:, j] = -1.0
    return sign * a


def function_columns(machine: Machine) -> dict[str, list[int]]:
    """Parameter indices of each error function (``"E_XX"`` -> motion and reversal terms)."""
    out: dict[str, list[int]] = {}
    for j, p in enumerate(machine.parameters):
        if p.kind != "location":
            out.setdefault(f"E_{COMPONENTS[p.component]}{p.axis}", []).append(j)
    return out


def _covariance(a: np.ndarray, cols: list[int], cov: np.ndarray, n: int) -> np.ndarray:
    """``A U Aᵀ`` from the function's own columns (A is zero elsewhere); of the forward
    values alone, shape (n, n), when the reverse values are the same (no reversal term)."""
    rows = a[:, cols] if not np.array_equal(a[:n], a[n:]) else a[:n, cols]
    return rows @ cov[np.ix_(cols, cols)] @ rows.T


def _sides(machine: Machine) -> dict[str, str]:
    return {a: machine.topology.side(a) for a in machine.axis_names}


def compensation_model(
    machine: Machine,
    parameters: ParameterSet,
    *,
    pitch: float | dict | None = None,
    points: int | dict | None = None,
    axes: Sequence[str] | None = None,
    flag: str = "correction",
    reference: dict | None = None,
    covariance: bool = True,
) -> CompensationModel:
    """Tabulate every error function of a parameter set over its axis.

    Parameters
    ----------
    machine : Machine
        The machine the parameters belong to (its travels define the grids).
    parameters : ParameterSet
        Identified parameters with covariance (any calibration).
    pitch, points : float or int, or dict of axis to value
        Grid spacing (mm or degrees) or number of points, one for all axes or per axis.
    axes : sequence of str, optional
        Axes to tabulate; all axes with error functions otherwise.
    flag : {"error", "correction"}
        Tabulate E(q) or −E(q).
    reference : dict of str to float, optional
        Reference position per axis (mm or degrees); travel minimum otherwise.
    covariance : bool
        Also form ``A U Aᵀ`` of every table (False: values only).

    Returns
    -------
    CompensationModel

    Raises
    ------
    InputError
        A parameter set of another machine, an axis not in the machine, a bad grid.
    ResourceLimitError
        Tables (and their covariances) larger than the memory holds, before any is built.

    Notes
    -----
    ``v_i = s Σ_d θ_d φ_d(q_i) ± s θ_b`` and ``Cov(v) = A U Aᵀ`` (module notes).
    """
    if flag not in FLAGS:
        raise InputError(f"flag: {flag!r} is not one of {', '.join(FLAGS)}")
    m = parameters.machine_for(machine)
    theta = parameters.vector_for(m)
    cov = None
    if covariance and parameters.covariance is not None:
        order = [parameters.names.index(n) for n in m.parameter_names]
        cov = parameters.covariance[np.ix_(order, order)]
    sign = 1.0 if flag == "error" else -1.0
    constants = tuple(
        (p.name, sign * float(theta[j])) for j, p in enumerate(m.parameters) if p.kind == "location"
    )
    wanted = [a.upper() for a in axes] if axes else None
    if wanted:
        bad = [a for a in wanted if a not in m.axis_names]
        if bad:
            raise InputError(f"axes: {bad[0]} is not an axis of {m.name} ({''.join(m.axis_names)})")
    for axis in reference or {}:
        if axis not in m.axis_names or axis == "S":
            raise InputError(
                f"--reference: {axis} is not an axis of {m.name} ({''.join(m.axis_names)})"
            )
    # each table holds A (2n x its parameters) and, with the covariance, A U Aᵀ (2n x 2n)
    cols = function_columns(m)
    sizes = table_sizes(m, pitch=pitch, points=points, axes=wanted)
    need = sum(
        16 * n * (len(cols[f]) + (2 * n if cov is not None else 0)) for f, n in sizes.items()
    )
    given = f"pitch {pitch}" if pitch is not None else f"points {points}"
    require_memory(need, f"{given}: tables of up to {max(sizes.values(), default=0)} points")
    sides = _sides(m)
    tables = []
    refs = {}
    for function, cols in function_columns(m).items():
        axis = function[3]
        if wanted is not None and axis not in wanted:
            continue
        pa = pitch.get(axis) if isinstance(pitch, dict) else pitch
        pn = points.get(axis) if isinstance(points, dict) else points
        q = axis_grid(m, axis, pitch=pa, points=pn)
        n = q.size
        a = design(m, cols, q, sign)
        v = a @ theta
        tables.append(
            ErrorTable(
                function=function,
                axis=axis,
                component=function[2],
                side=sides[axis],
                positions=q,
                forward=v[:n],
                reverse=v[n:],
                sensitivity=a,
                covariance=None if cov is None else _covariance(a, cols, cov, n),
            )
        )
        scale = 1.0 if axis in LINEAR_AXES else _DEG
        given = (reference or {}).get(axis)
        refs[axis] = q[0] if given is None else float(given) * scale
    return CompensationModel(m, parameters, flag, tuple(tables), constants, refs)
