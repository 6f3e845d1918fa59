"""What a control does with a table: its interpolation, and the error that remains.

A :class:`ControlTable` is one table as a control holds it after reading the file: the
input-axis positions, the correction applied for travel in the positive and negative
direction (always a *correction*, −E, whatever the file stores), and the control's rule
between the points:

``linear``
    linear interpolation between neighbouring points, the end values held beyond the ends
    (LinuxCNC ``emcmot_comp_t``; Sinumerik K3 §4.4 "Linear interpolation between
    interpolation points"; ISG VolComp);
``staircase``
    incremental accumulation: the increment of a point is output when the axis passes it,
    so the correction is constant between points (Fanuc pitch-error compensation,
    parameter manual B-63980EN/01, §4 "Pitch error compensation", p. 100);
``modulo``
    (a flag) the table repeats with the period of a rotary axis.

Residual after compensation
---------------------------
At readings q the tool-point error of the machine is ``e(q) = p(q; θ) − p(q; 0)`` (the
kinematic chain).  A correction ``c_f`` of error function f enters the tool point through
the same chain as a constant value of that function would: ``S_f(q) = ∂p/∂θ_{f,0}`` (the
Jacobian column of a degree-0 coefficient of f).  The error left after the control applies
its tables is::

    r(q) = e(q; θ) + Σ_f S_f(q) c_f(q_f; θ̂)

with c_f the control's interpolation of the tables made from the estimate θ̂.  The sum
is evaluated as ``p(q; c) − p(q; 0)`` on the machine whose parameters are those degree-0
coefficients (and location errors), each point with its own values c: the chain is linear
in each factor's parameters, so this is ``Σ S_f c_f`` up to second order in the errors.  Its
estimate is ``r̂ = e(q; θ̂) + Σ_f S_f c_f(θ̂)`` (interpolation error and functions no table
carries); ``r − r̂ = J(q)(θ − θ̂)`` to first order, so its standard uncertainty per component
is ``sqrt(diag(J U Jᵀ))`` with ``J = ∂p/∂θ`` — for tables that carry every function
``J ≈ Σ_f S_f ∂c_f/∂θ``, the identification's uncertainty propagated through the tables.

References
----------
JCGM 100:2008 (GUM), §5.1.2 (law of propagation, first order).
ISO 230-1:2012, §3.4 (error motions of the tool relative to the workpiece).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mtmetrology.kinematics.machine import Machine

__all__ = ["RULES", "ControlTable", "residual"]

RULES = ("linear", "staircase")


@dataclass(frozen=True)
class ControlTable:
    """One compensation table as the control applies it.

    Attributes
    ----------
    function : str
        The ISO 230-1 error function it compensates (``E_XX``; ``E_YX`` for a cross table
        whose input is X and whose output is Y).
    positions : ndarray, shape (n,)
        Input-axis positions, internal units, ascending and equally spaced.
    forward, reverse : ndarray, shape (n,)
        Corrections (−E, internal units) for positive and negative travel.
    rule : {"linear", "staircase"}
    period : float or None
        Period of a modulo (rotary) table, internal units.
    reference_index : int
        Index of the reference point (the staircase accumulates from it).
    """

    function: str
    positions: np.ndarray
    forward: np.ndarray
    reverse: np.ndarray
    rule: str = "linear"
    period: float | None = None
    reference_index: int = 0

    @property
    def axis(self) -> str:
        """The input (moving) axis."""
        return self.function[3]

    @property
    def output(self) -> str:
        """The direction compensated: the error direction of the function."""
        return self.function[2]

    def correction(self, q: np.ndarray, senses: np.ndarray | None = None) -> np.ndarray:
        """The control's correction at input positions ``q`` (internal units).

        Parameters
        ----------
        q : ndarray, shape (...)
        senses : ndarray, shape (...), optional
            +1 / −1 sense of travel; +1 (forward table) when omitted.

        Returns
        -------
        ndarray, shape (...)
        """
        q = np.asarray(q, dtype=float)
        flat = q.reshape(-1, 1)
        sense = None if senses is None else np.broadcast_to(senses, q.shape).reshape(-1, 1)
        return _corrections([self], flat, sense, [0])[0].reshape(q.shape)


def _corrections(tables: list[ControlTable], q: np.ndarray, senses, cols) -> np.ndarray:
    """Corrections of all tables at readings ``q`` (b, n_axes), shape (F, b).

    :meth:`ControlTable.correction` vectorised: tables on one axis with the same points
    and rule share the interval index, found arithmetically (the points of every control
    table are equally spaced), and are gathered as one stacked array.
    """
    out = np.empty((len(tables), q.shape[0]))
    groups: dict = {}
    for f, (t, k) in enumerate(zip(tables, cols, strict=True)):
        key = (k, t.rule, t.period, t.positions.tobytes())
        groups.setdefault(key, []).append(f)
    for (k, rule, period, _), members in groups.items():
        x = tables[members[0]].positions
        qk = q[:, k] if period is None else x[0] + np.mod(q[:, k] - x[0], period)
        h = np.diff(x)
        if np.allclose(h, h[0], rtol=1e-12, atol=0.0):  # equally spaced: the index by arithmetic
            position = (qk - x[0]) / h[0]
            i = np.clip(np.floor(position).astype(np.intp), 0, x.size - 1)
        else:
            i = np.clip(np.searchsorted(x, qk, side="right") - 1, 0, x.size - 1)
            position = i + (qk - x[i]) / np.append(h, 1.0)[i]
        both = senses is not None and any(
            not np.array_equal(tables[f].forward, tables[f].reverse) for f in members
        )
        directions = ("forward", "reverse") if both else ("forward",)
        values = []
        for d in directions:
            stack = np.stack([getattr(tables[f], d) for f in members])  # (F_g, n)
            value = np.take(stack, i, axis=1)
            if rule == "linear":  # + slope of the interval × fraction of it travelled
                slope = np.diff(stack, axis=1, append=stack[:, -1:])
                value += np.clip(position - i, 0.0, 1.0) * np.take(slope, i, axis=1)
            values.append(value)
        v = values[0] if not both else np.where(senses[:, k] < 0, values[1], values[0])
        out[members] = v
    return out


def residual(
    machine: Machine,
    theta: np.ndarray,
    covariance: np.ndarray | None,
    tables: list[ControlTable],
    readings: np.ndarray,
    senses: np.ndarray | None = None,
    *,
    constants: tuple[tuple[str, float], ...] = (),
    factors: np.ndarray | None = None,
    chunk: int = 65536,
) -> tuple[np.ndarray, np.ndarray | None]:
    """Tool-point error left after the control applies ``tables`` (module notes).

    Parameters
    ----------
    machine : Machine
        With the parameter set's model active.
    theta : ndarray, shape (P,)
        Parameter estimate, internal units.
    covariance : ndarray, shape (P, P) or None
    tables : list of ControlTable
    readings : ndarray, shape (N, n_axes)
        Axis readings, internal units.
    senses : ndarray, shape (N, n_axes), optional
        Sense of travel per axis; +1 when omitted.
    constants : tuple of (name, correction)
        Location errors the control corrects (internal units), e.g. by a volumetric
        compensation; they enter through their own Jacobian columns.
    factors : ndarray, shape (3,), optional
        Per Cartesian component, what the control does with the tool-point correction:
        1 (applied), −1 (negated, ISG ``negate``) or 0 (ISG ``set_to_zero``).
    chunk : int
        Poses per block (bounds memory: the Jacobian of a block is chunk × 3 × P).

    Returns
    -------
    r : ndarray, shape (N, 3)
        Estimated residual error, mm.
    u : ndarray, shape (N, 3) or None
        Its standard uncertainty per component, mm.
    """
    readings = np.asarray(readings, dtype=float)
    n = readings.shape[0]
    if senses is None and any(p.kind == "reversal" for p in machine.parameters):
        senses = np.ones_like(readings)  # travel in the positive direction
    r = np.empty((n, 3))
    u = None if covariance is None else np.empty((n, 3))
    factor = None
    if covariance is not None:
        w, v = np.linalg.eigh(covariance)
        factor = v * np.sqrt(np.clip(w, 0.0, None))  # U = F Fᵀ
    # tables of one function add up (an SSFK list and a volumetric table of one axis)
    functions = list(dict.fromkeys(t.function for t in tables))
    member = np.array([functions.index(t.function) for t in tables], dtype=np.intp)
    names = [f"{f}0" for f in functions] + [name for name, _ in constants]
    fixed = np.array([value for _, value in constants])
    cols = [machine.axis_names.index(t.axis) for t in tables]
    applied = machine.with_parameters(names) if names else None
    factors = np.ones(3) if factors is None else np.asarray(factors, dtype=float)
    for start in range(0, n, chunk):
        q = readings[start : start + chunk]
        s = None if senses is None else senses[start : start + chunk]
        ev = machine.evaluate(q, theta, senses=s, d_params=covariance is not None)
        nominal = machine.forward(q)
        e = ev.position - nominal
        if applied is not None:
            c = np.zeros((len(names), q.shape[0]))  # (F, b): each parameter contiguous
            if tables:
                np.add.at(c, member, _corrections(tables, q, s, cols))
            c[len(functions) :] = fixed[:, None]
            e += factors * (applied.forward(q, c.T) - nominal)  # Σ_f S_f c_f (module notes)
        r[start : start + chunk] = e
        if factor is not None:
            jf = ev.d_params @ factor  # (b, 3, P)
            u[start : start + chunk] = np.sqrt(np.einsum("bip,bip->bi", jf, jf))
    return r, u
