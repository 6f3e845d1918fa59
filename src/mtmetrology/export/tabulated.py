"""A measured pitch table as the error model of an export: the table itself, point by point.

An ISO 230-2 run gives, at each target ``t_i`` of an axis, the mean deviation of each
direction x̄_i↑, x̄_i↓ and their mean x̄_i (ISO 230-2:2014, §3.3 and §3.4).  Exported as
measured, the positioning error ``E_XX`` of the axis is the piecewise-linear function through
those values,

    E_s(q) = x̄_i,s + (q − t_i)(x̄_{i+1},s − x̄_i,s)/(t_{i+1} − t_i),   t_i ≤ q ≤ t_{i+1},

held at the end values outside [t_1, t_m] (as the controls hold their tables), with s the
sense of travel; no function is fitted.  The control's table on its equally spaced grid
``g_k`` holds ``E_s(g_k)`` (per direction where the control has two tables, the mean
``(E_↑ + E_↓)/2`` otherwise) and interpolates linearly between them, so the residual

    r_s(q) = E_s(q) − I_h[Ē](q)     (Ē the tabulated values)

is piecewise linear with kinks at the targets and the grid points only: its largest value
over the axis is attained at a target, ``max_i |E_s(t_i) − I_h[Ē](t_i)|`` — the exact
interpolation bound of the measured table at that pitch (:func:`interpolation_bound`).

Uncertainty: each direction's mean carries ``u_i,s`` (the scatter of its n runs, s_i/√n,
and the laser's ISO/TR 230-9 budget, :meth:`PositioningResult.pitch_table`).  Between
targets ``u(q)`` is the linear interpolation of ``u_i,s`` — the standard uncertainty of the
interpolated value for fully correlated neighbours, and an upper bound for any correlation
(``√((1−w)²u_1² + w²u_2² + 2ρw(1−w)u_1u_2) ≤ (1−w)u_1 + w u_2``, JCGM 100:2008, §5.2.2).
The values the control applies are fixed numbers, so the residual's uncertainty is that of
the machine's error, ``u(r_s(q)) = u_s(q)`` (through the chain's column of ``E_XX``).

References
----------
ISO 230-2:2014, *Test code for machine tools — Part 2: Determination of accuracy and
repeatability of positioning of numerically controlled axes*, §3.3, §3.4.
JCGM 100:2008 (GUM), §5.2.2 (correlated input quantities).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.export.control import ControlTable, residual
from mtmetrology.export.model import FLAGS, CompensationModel, ErrorTable, axis_grid
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.units import to_internal

__all__ = [
    "RESULT_KIND",
    "MeasuredTable",
    "interpolation_bound",
    "measured_error",
    "residual_after",
    "tabulated_model",
]

#: The result document that holds a pitch table (``mtm laser analyse``).
RESULT_KIND = "iso230-2-positioning"
_KEYS = ("position_mm", "forward_um", "reverse_um", "u_forward_um", "u_reverse_um")


@dataclass(frozen=True)
class MeasuredTable:
    """The positioning error of one axis as measured: per target and direction.

    Attributes
    ----------
    axis : str
    positions : ndarray, shape (m,)
        Targets t_i, mm, strictly ascending.
    forward, reverse : ndarray, shape (m,)
        The machine's error E (x̄_i↑, x̄_i↓), mm: what it does in each sense of travel.
    u_forward, u_reverse : ndarray, shape (m,)
        Their standard uncertainties, mm.
    bidirectional : bool
        Tabulate each direction (a control with forward and reverse tables); False: the
        mean x̄_i of both, the reversal left to the control's backlash setting.
    provenance : dict
    """

    axis: str
    positions: np.ndarray
    forward: np.ndarray
    reverse: np.ndarray
    u_forward: np.ndarray
    u_reverse: np.ndarray
    bidirectional: bool = True
    provenance: dict = field(default_factory=dict)

    @property
    def function(self) -> str:
        """The ISO 230-1 function the table is: ``E_XX`` for axis X."""
        return f"E_{self.axis}{self.axis}"

    def written(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The errors the control's table holds at ``q`` (mm): per direction, or the mean."""
        fwd = np.interp(q, self.positions, self.forward)
        rev = np.interp(q, self.positions, self.reverse)
        if not self.bidirectional:
            fwd = rev = 0.5 * (fwd + rev)
        return fwd, rev

    def error_table(self) -> ControlTable:
        """The machine's error as a table of +E (summed with the control's corrections −E
        it gives the residual through the same chain column)."""
        return ControlTable(self.function, self.positions, self.forward, self.reverse)

    def u_table(self) -> ControlTable:
        """The standard uncertainties as a table (linear between targets, module notes)."""
        return ControlTable(self.function, self.positions, self.u_forward, self.u_reverse)

    @classmethod
    def from_result(
        cls, doc: dict, source: str = "", *, bidirectional: bool = True, machine: str = ""
    ) -> MeasuredTable:
        """The pitch table of an ``iso230-2-positioning`` result document.

        Parameters
        ----------
        doc : dict
            The document ``mtm laser analyse`` writes.
        source : str
            File name, for messages and provenance.
        bidirectional : bool
            Tabulate each direction (True) or the mean x̄_i.
        machine : str
            The machine exported to: a document of another machine is refused.

        Raises
        ------
        InputError
            Not such a document, a missing or malformed column, another machine.
        """
        where = source or "result"
        if not isinstance(doc, dict) or doc.get("kind") != RESULT_KIND:
            raise InputError(f"{where}: kind: not an {RESULT_KIND} result (mtm laser analyse)")
        if machine and doc.get("machine") not in (None, machine):
            raise InputError(f"{where}: machine: {doc.get('machine')!r}, not {machine!r}")
        table = doc.get("pitch_table")
        if not isinstance(table, dict):
            raise InputError(f"{where}: pitch_table: missing")
        cols = {}
        for key in _KEYS:
            try:
                cols[key] = np.asarray(table[key], dtype=float)
            except (KeyError, TypeError, ValueError):
                raise InputError(f"{where}: pitch_table.{key}: missing or not numbers") from None
        t = cols["position_mm"]
        if t.ndim != 1 or t.size < 2 or any(c.shape != t.shape for c in cols.values()):
            raise InputError(f"{where}: pitch_table: columns of unequal length or < 2 targets")
        if not np.all(np.isfinite(np.stack(list(cols.values())))):
            raise InputError(f"{where}: pitch_table: a value is not finite")
        if np.any(np.diff(t) <= 0):
            raise InputError(f"{where}: pitch_table.position_mm: not strictly ascending")
        axis = str(doc.get("axis", "")).upper()
        if axis not in ("X", "Y", "Z"):
            raise InputError(f"{where}: axis: {doc.get('axis')!r} is not X, Y or Z")
        mm = {k: to_internal(cols[k], "µm") for k in _KEYS[1:]}
        return cls(
            axis,
            t,
            mm["forward_um"],
            mm["reverse_um"],
            mm["u_forward_um"],
            mm["u_reverse_um"],
            bidirectional,
            {"pitch_table": where, "tabulated": "per direction" if bidirectional else "mean"},
        )


def tabulated_model(
    machine: Machine,
    measured: MeasuredTable,
    *,
    pitch: float | None = None,
    points: int | None = None,
    axes: Sequence[str] | None = None,
    flag: str = "correction",
    reference: dict | None = None,
) -> CompensationModel:
    """The compensation model of a measured table: its values on the control's grid.

    Parameters
    ----------
    machine : Machine
    measured : MeasuredTable
    pitch, points : float or int
        Grid spacing (mm) or number of points over the axis travel (one of them).
    axes : sequence of str, optional
        Must include the table's axis when given.
    flag : {"error", "correction"}
    reference : dict of str to float, optional
        Reference position of the axis (mm); travel minimum otherwise.

    Returns
    -------
    CompensationModel
        On ``machine`` with the one parameter ``E_XX0`` (value 0: the error is the measured
        table, :attr:`CompensationModel.measured`); the table's covariance is diagonal with
        the interpolated u² (module notes).

    Raises
    ------
    InputError
        The axis not in the machine or not among ``axes``, targets outside the travel, a
        bad grid or flag.
    """
    if flag not in FLAGS:
        raise InputError(f"flag: {flag!r} is not one of {', '.join(FLAGS)}")
    a = measured.axis
    if a not in machine.axis_names:
        raise InputError(f"pitch table: axis {a} is not an axis of {machine.name}")
    if axes and a not in [x.upper() for x in axes]:
        raise InputError(f"axes: the pitch table is of axis {a}, not of {', '.join(axes)}")
    for ax in reference or {}:
        if ax != a:
            raise InputError(f"--reference: the pitch table is of axis {a}, not {ax}")
    lo, hi = machine.axes[a].travel or (-np.inf, np.inf)
    t = measured.positions
    if t[0] < lo - 1e-9 or t[-1] > hi + 1e-9:
        raise InputError(
            f"pitch table: targets {t[0]:g} to {t[-1]:g} mm outside the travel of {a} "
            f"({lo:g} to {hi:g} mm)"
        )
    q = axis_grid(machine, a, pitch=pitch, points=points)
    sign = 1.0 if flag == "error" else -1.0
    fwd, rev = measured.written(q)
    u_f = np.interp(q, t, measured.u_forward)
    u_r = np.interp(q, t, measured.u_reverse)
    if not measured.bidirectional:
        u_f = u_r = np.interp(q, t, 0.5 * (measured.u_forward + measured.u_reverse))
    n = q.size
    # the written values are the measured table's interpolation: its rows are the weights
    # of the targets (∂v/∂x̄), a (2n, 2m) map from (x̄↑, x̄↓) to (forward, reverse)
    weights = np.stack([np.interp(q, t, e) for e in np.eye(t.size)], axis=1)
    m = t.size
    sens = np.zeros((2 * n, 2 * m))
    if measured.bidirectional:
        sens[:n, :m], sens[n:, m:] = weights, weights
    else:
        sens[:n, :m] = sens[:n, m:] = sens[n:, :m] = sens[n:, m:] = 0.5 * weights
    same = np.array_equal(fwd, rev)
    cov = np.diag(u_f**2) if same else np.diag(np.concatenate([u_f, u_r]) ** 2)
    function = measured.function
    table = ErrorTable(
        function, a, a, machine.topology.side(a), q, sign * fwd, sign * rev, sign * sens, cov
    )
    sub = machine.with_parameters([f"{function}0"])
    pset = ParameterSet(
        sub.parameter_names,
        np.zeros(1),
        sub.parameter_units,
        provenance=dict(measured.provenance),
        machine=machine.name,
    )
    ref = q[0] if not reference else float(reference[a])
    return CompensationModel(sub, pset, flag, (table,), (), {a: ref}, (measured,))


def interpolation_bound(model: CompensationModel) -> float:
    """Largest residual over the axis of the linear interpolation of the model's tables
    against the measured piecewise-linear error, mm (module notes: attained at a target).

    Per direction ``max_i |E_s(t_i) + c_s(t_i)|``, c the tabulated corrections (−E) between
    their grid points; the unwritten reversal of a mean table is part of it.
    """
    bound = 0.0
    for m in model.measured:
        t = model.table(m.function)
        s = -model.sign  # the tables as corrections
        for err, values in ((m.forward, t.forward), (m.reverse, t.reverse)):
            c = np.interp(m.positions, t.positions, s * values)
            bound = max(bound, float(np.abs(err + c).max()))
    return bound


def measured_error(
    model: CompensationModel, readings: np.ndarray, senses: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The machine's tool-point error from the measured tables and its standard uncertainty
    per component at ``readings``, mm (n, 3): ``S_f(q) E_f(q)`` and ``|S_f(q)| u_f(q)``
    combined over the tables (independent axes), S_f the chain's column of ``E_XX``."""
    m = model.machine
    zero = np.zeros(m.n_params)
    e, _ = residual(m, zero, None, [t.error_table() for t in model.measured], readings, senses)
    var = np.zeros_like(e)
    for t in model.measured:
        d, _ = residual(m, zero, None, [t.u_table()], readings, senses)
        var += d**2
    return e, np.sqrt(var)


def residual_after(
    model: CompensationModel,
    tables: list[ControlTable],
    constants,
    readings: np.ndarray,
    senses: np.ndarray | None = None,
    factors: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Residual r̂ and its u (mm, (n, 3)) after the control applies ``tables`` to a machine
    whose error is the measured table: ``S_f E_f + S_f c_f`` (the control's ``factors``
    act on its corrections only)."""
    e, u = measured_error(model, readings, senses)
    zero = np.zeros(model.machine.n_params)
    c, _ = residual(
        model.machine, zero, None, tables, readings, senses, constants=constants, factors=factors
    )
    return e + c, u
