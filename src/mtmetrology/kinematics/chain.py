"""The kinematic chain: forward kinematics and analytic Jacobians for any topology.

Model
-----
Each axis k carries, from its parent body outwards (F -> W or F -> T)::

    T_k(q) = Trans(o_k) · L_k · M_k(q) · E_k(q)

``o_k``
    nominal offset of the axis reference point in the parent frame at zero reading
    (a rotary axis turns about the line through this point);
``L_k``
    location errors ``E_X0k … E_C0k``: a small displacement of the axis average line,
    with everything the axis carries, relative to its parent, about the axis reference
    point, in the parent frame (the machine frame when the parent axes read zero);
``M_k(q)``
    exact nominal motion: ``Trans(s_k q u_k)`` (linear) or ``Rot(u_k, s_k q)`` (rotary),
    ``u_k`` the axis direction and ``s_k = ±1`` its sign convention.  With the machine
    reading convention (relative tool motion is +q) table-carrying axes have ``s = −1``;
    this reproduces ``q = R_z(C) R_y(B) p`` of seed 000 (digest 000 §3.2.2);
``E_k(q)``
    error motions and reversal terms of axis k at its reference point (the frame origin
    that moves with the axis): translations ``δ = (E_Xk, E_Yk, E_Zk)(q)`` and rotations
    ``ε = (E_Ak, E_Bk, E_Ck)(q)``, each ``Σ_d c_d φ_d(q) + c_b · sense``.

Every error transform is the first-order (small-angle) matrix::

        | 1    -εc    εb   δx |
    G = | εc    1    -εa   δy |      (E = I + G; digest 004 §3.5)
        | -εb   εa    1    δz |

Sign conventions (ISO 230-1:2012, ISO 841)
-------------------------------------------
*Error motions and reversal terms* are deviations of the tool relative to the workpiece,
positive in the positive direction of the principal axes (rotations by the right-hand
rule), whichever component moves.  A tool-side axis carries ``E_k = I + G``; a
table-side axis carries the opposite displacement of the table, ``E_k = I − G``, so the
tool relative to the workpiece again deviates by ``+G``.  Thus ``E_XX1 = +100 µm/m``
puts the stylus at x = 200.02 mm for X = 200 mm whether X moves the table or the
spindle, and a positioning slope measured per ISO 230-2 enters with the same sign on
every axis.

*Location errors* state the position and orientation of the axis average line in the
machine frame, right-hand rule, about the axis reference point (``o_k`` and the offsets
of its parents): ``E_X0C > 0`` displaces the C axis (and the table it carries) by +X;
``E_B0C > 0`` tilts it about +Y.  Changing the reference point of an orientation error
by a lever r changes the position errors of the same line by ``r × ε``; the presets
state their reference points (:mod:`mtmetrology.kinematics.conventions`).

The stylus-centre position in the workpiece frame is the chain from W to T,
``p = T_W⁻¹ · T_T · t`` with ``t`` the tool (stylus-centre) vector in the last tool-axis
frame.  ``T_W⁻¹`` is formed factor by factor: nominal offsets and motions are inverted
exactly, each small error factor ``I ± G`` by its first-order inverse ``I ∓ G`` (equal
to the exact inverse up to second order in the errors).  In the W -> T product every
error factor is thus ``I + ς G`` with ``ς = +1`` for tool-side location errors and for
all error motions, ``ς = −1`` for table-side location errors.  The model is a product of
factors each *linear* in its error parameters, so the Jacobians below are exact
derivatives of the model (first order in the small errors by construction, exact in the
nominal motion).

Jacobians
---------
With the chain written as ``p = F_1 F_2 … F_n t`` (W to T), the derivative with respect
to a parameter of factor ``F_i = I + ς G(θ)`` is ``A_i · ς (∂δ + ∂ε × r_i)`` where
``A_i`` is the linear part of ``F_1 … F_{i−1}`` and ``r_i = F_{i+1} … F_n t`` the point
entering factor i.  One right-to-left pass gives every ``r_i``, one left-to-right pass of
3×3 products every ``A_i``; all arrays are vectorised over (trial, point).

References
----------
ISO 230-1:2012, *Test code for machine tools — Part 1: Geometric accuracy of machines
operating under no-load or quasi-static conditions*, §3 and Annex A (error motions,
location errors, ISO 841 axis directions).
ISO 841:2001, *Industrial automation systems and integration — Numerical control of
machines — Coordinate system and motion nomenclature*.
I. Alami Mchichi, *Calibration of five-axis machine tools with the SAMBA method: optimized
artefact layout and measurement sequence*, Polytechnique Montréal, 2018, §3.5 (HTM chain).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mtmetrology._backend import compiled_module, from_environment
from mtmetrology.kinematics import _sparse3 as s3
from mtmetrology.kinematics._program import JACOBIAN, POSITION, Program
from mtmetrology.kinematics.basis import Basis
from mtmetrology.kinematics.parameters import ErrorParameter
from mtmetrology.kinematics.topology import LINEAR_AXES, Topology

__all__ = ["BACKEND", "AxisGeometry", "ChainEvaluation", "KinematicChain"]

#: ``"numba"``: many trials sharing their poses run in a compiled kernel (when numba is
#: installed); ``"numpy"``: numpy blocks only.  From ``MTMETROLOGY_BACKEND`` at import
#: (:mod:`mtmetrology._backend`); may be changed at run time.
BACKEND = from_environment()


def _compiled_kernel():
    """The compiled kernel module, or None when numba is not installed."""
    return compiled_module("mtmetrology.kinematics._kernel")


@dataclass(frozen=True)
class AxisGeometry:
    """Nominal geometry of one axis, in internal units (mm, rad).

    Attributes
    ----------
    name : str
        Axis letter.
    direction : ndarray, shape (3,)
        Unit direction of the axis in its parent frame.
    sign : float
        +1 or −1: ``M(q) = Trans(sign·q·u)`` or ``Rot(u, sign·q)``.
    offset : ndarray, shape (3,)
        Reference point of the axis in the parent frame at zero reading (mm).
    travel : tuple of float or None
        (min, max) in mm or rad.
    resolution : float or None
        Reading resolution in mm or rad.
    basis : Basis
        Basis of the axis's error motions.
    """

    name: str
    direction: np.ndarray
    sign: float = 1.0
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    travel: tuple[float, float] | None = None
    resolution: float | None = None
    basis: Basis = field(default_factory=Basis)

    @property
    def linear(self) -> bool:
        return self.name in LINEAR_AXES


@dataclass(frozen=True)
class _Offset:
    vector: np.ndarray


@dataclass(frozen=True)
class _Motion:
    axis: int  # column in the readings array
    linear: bool
    direction: np.ndarray
    sigma: float  # effective sign in the W -> T chain


@dataclass(frozen=True)
class _Errors:
    axis: int
    varsign: float  # ς of the factor I + ς G in the W -> T chain (module notes)
    params: tuple[int, ...]  # indices into the parameter vector
    components: tuple[int, ...]
    kinds: tuple[str, ...]
    degrees: tuple[int, ...]  # -1 for location / reversal
    basis: Basis

    @property
    def has_rotation(self) -> bool:
        return any(c >= 3 for c in self.components)

    @property
    def max_degree(self) -> int:
        return max((d for d in self.degrees), default=-1)


@dataclass(frozen=True)
class ChainEvaluation:
    """Result of :meth:`KinematicChain.evaluate`.

    Attributes
    ----------
    position : ndarray, shape (..., 3)
        Stylus-centre position in the workpiece frame (mm).
    d_params : ndarray, shape (..., 3, n_params) or None
    d_axes : ndarray, shape (..., 3, n_axes) or None
        Derivative with respect to the readings (mm per mm, mm per rad).
    d_tool : ndarray, shape (..., 3, 3) or None
    """

    position: np.ndarray
    d_params: np.ndarray | None = None
    d_axes: np.ndarray | None = None
    d_tool: np.ndarray | None = None


def _accumulate(out: list, j: int, col, factor) -> None:
    """out[i][j] += factor · col[i] for sparse entries; ``out`` is [3][n]."""
    for i in range(3):
        if col[i] is not s3.ZERO:
            out[i][j] = s3.add(out[i][j], s3.mul(factor, col[i]))


def _trial_split(shape: tuple, theta: np.ndarray, poses: list) -> int | None:
    """Index splitting ``shape`` into trial dimensions (where only the parameters vary)
    and pose dimensions (where only readings, tool and senses vary); None if they mix."""
    n = len(shape)

    def padded(a: np.ndarray) -> tuple:
        return (1,) * (n - a.ndim + 1) + a.shape[:-1]

    first_pose = min(next((d for d, m in enumerate(padded(a)) if m > 1), n) for a in poses)
    last_trial = max((d for d, m in enumerate(padded(theta)) if m > 1), default=-1)
    return last_trial + 1 if last_trial < first_pose else None


def _separate(shape: tuple, split: int, readings, senses, tool, theta):
    """Pose arrays (n_poses, k) and parameters (n_trials, n_params) of a split call.

    A tool of shape (3,) stays a constant vector.
    """
    pose_shape, trial_shape = shape[split:], shape[:split]
    n_poses = math.prod(pose_shape)

    def per_pose(a: np.ndarray) -> np.ndarray:
        lead = a.shape[:-1][max(0, a.ndim - 1 - len(pose_shape)) :]  # drop size-1 trial dims
        a = a.reshape(*lead, a.shape[-1])
        return np.broadcast_to(a, (*pose_shape, a.shape[-1])).reshape(n_poses, a.shape[-1])

    lead = ((1,) * (len(shape) - theta.ndim + 1) + theta.shape[:-1])[:split]
    th = np.broadcast_to(theta.reshape(*lead, theta.shape[-1]), (*trial_shape, theta.shape[-1]))
    return (
        per_pose(readings),
        None if senses is None else per_pose(senses),
        tool if tool.ndim == 1 else per_pose(tool),
        np.ascontiguousarray(th.reshape(math.prod(trial_shape), theta.shape[-1])),
    )


def _views(out: ChainEvaluation, lead: tuple) -> list:
    """The arrays of ``out`` with their leading dimensions reshaped to ``lead`` (views)."""
    arrays = (out.position, out.d_params, out.d_axes, out.d_tool)
    trailing = (1, 2, 2, 2)
    return [
        None if a is None else a.reshape(*lead, *a.shape[a.ndim - k :])
        for a, k in zip(arrays, trailing, strict=True)
    ]


class _Parameters:
    """The error parameters as registers of a program: ``theta[..., j]`` is register j."""

    ndim = 1

    def __init__(self, registers: list):
        self.registers = registers

    def __getitem__(self, key):
        return self.registers[key[-1]]


def _dense(entry):
    """A sparse entry as something numpy assigns: 0.0, 1.0 or the value."""
    if entry is s3.ZERO:
        return 0.0
    return 1.0 if entry is s3.ONE else entry


class KinematicChain:
    """Forward kinematics of a serial machine with an error model.

    Parameters
    ----------
    topology : Topology
    axes : dict of str to AxisGeometry
        Geometry of every axis of the topology.
    parameters : sequence of ErrorParameter
        The active error parameters, in the order of the parameter vector.
    workpiece_offset : array_like, shape (3,)
        Origin of the workpiece frame W in the frame of the last workpiece axis (mm).
    """

    def __init__(
        self,
        topology: Topology,
        axes: dict[str, AxisGeometry],
        parameters: list[ErrorParameter],
        workpiece_offset=(0.0, 0.0, 0.0),
    ):
        self.topology = topology
        self.axis_names = topology.axes
        self.axes = axes
        self.parameters = list(parameters)
        self.workpiece_offset = np.asarray(workpiece_offset, dtype=float)
        col = {a: i for i, a in enumerate(self.axis_names)}
        for p in self.parameters:
            if p.axis not in col:
                raise ValueError(
                    f"parameter {p.name} belongs to axis {p.axis}, "
                    f"which is not in topology {topology.string}"
                )
        self._elements: list = []
        # Workpiece branch, W -> F: inverse factors of the F -> W chain.
        if np.any(self.workpiece_offset):
            self._elements.append(_Offset(-self.workpiece_offset))
        for name in reversed(topology.workpiece_axes):
            g = axes[name]
            # ISO 230-1: table error motions are stated as the tool relative to the
            # workpiece, so the table's own displacement is I - G and its inverse I + G.
            self._elements.append(self._errors(name, col[name], ("motion", "reversal"), 1.0))
            self._elements.append(_Motion(col[name], g.linear, g.direction, -g.sign))
            self._elements.append(self._errors(name, col[name], ("location",), -1.0))
            if np.any(g.offset):
                self._elements.append(_Offset(-g.offset))
        # Tool branch, F -> T.
        for name in topology.tool_axes:
            g = axes[name]
            if np.any(g.offset):
                self._elements.append(_Offset(g.offset))
            self._elements.append(self._errors(name, col[name], ("location",), 1.0))
            self._elements.append(_Motion(col[name], g.linear, g.direction, g.sign))
            self._elements.append(self._errors(name, col[name], ("motion", "reversal"), 1.0))
        self._elements = [e for e in self._elements if e is not None]
        self.has_reversal = any(p.kind == "reversal" for p in self.parameters)

    def _errors(self, axis: str, column: int, kinds: tuple[str, ...], varsign: float):
        idx = [i for i, p in enumerate(self.parameters) if p.axis == axis and p.kind in kinds]
        if not idx:
            return None
        ps = [self.parameters[i] for i in idx]
        return _Errors(
            axis=column,
            varsign=varsign,
            params=tuple(idx),
            components=tuple(p.component for p in ps),
            kinds=tuple(p.kind for p in ps),
            degrees=tuple(p.degree if p.kind == "motion" else -1 for p in ps),
            basis=self.axes[axis].basis,
        )

    @property
    def n_params(self) -> int:
        return len(self.parameters)

    @property
    def n_axes(self) -> int:
        return len(self.axis_names)

    #: (trial, point) pairs per block of the numpy backend: arrays of this size stay in
    #: the CPU cache, which makes the many small element-wise operations several times
    #: faster.
    chunk_size = 16384
    #: The compiled backend runs when a call has at least this many (trial, pose) pairs
    #: and this many trials (below, the numpy blocks are as fast and need no compiler).
    compiled_min_pairs = 20_000
    compiled_min_trials = 16
    #: From this many pairs, a position-only call compiles its own kernel (once per
    #: machine and model; see :mod:`mtmetrology.kinematics._kernel`).
    generated_min_pairs = 1_000_000

    def evaluate(
        self,
        readings: np.ndarray,
        params: np.ndarray | None = None,
        *,
        senses: np.ndarray | None = None,
        tool: np.ndarray | None = None,
        d_params: bool = False,
        d_axes: bool = False,
        d_tool: bool = False,
    ) -> ChainEvaluation:
        """Evaluate the chain; see the module docstring for the model.

        Parameters
        ----------
        readings : ndarray, shape (..., n_axes)
            Axis readings in internal units (mm, rad), columns in ``axis_names`` order.
        params : ndarray, shape (..., n_params), optional
            Error parameters in internal units; zeros when omitted.
        senses : ndarray, shape (..., n_axes), optional
            Sense of motion (+1/−1) used to reach each reading; needed when the model
            has reversal terms.
        tool : ndarray, shape (..., 3), optional
            Tool (stylus-centre) vector in the last tool-axis frame (mm); zeros if omitted.
        d_params, d_axes, d_tool : bool
            Which Jacobians to compute.

        Returns
        -------
        ChainEvaluation
            Arrays of the broadcast shape of the inputs' leading dimensions.

        Notes
        -----
        Two backends compute the same model (they agree to rounding, ~1e-13 relative):
        numpy blocks of :attr:`chunk_size` pairs, and, for many trials sharing their
        poses (readings, senses and tool broadcast over leading "trial" dimensions, the
        parameters over trailing "pose" dimensions) and no readings/tool Jacobian, a
        compiled kernel (:mod:`mtmetrology.kinematics._program`).  :data:`BACKEND`
        (environment variable ``MTMETROLOGY_BACKEND``) selects ``"numba"`` or
        ``"numpy"``; without numba installed the numpy backend runs.  In both, the
        nominal trigonometry and basis values are computed once per pose and block, not
        per trial.
        """
        theta = np.zeros(self.n_params) if params is None else params
        t = np.zeros(3) if tool is None else tool
        if senses is None and self.has_reversal:
            rev = [i for i, p in enumerate(self.parameters) if p.kind == "reversal"]
            if d_params or np.any(theta[..., rev] != 0):
                raise ValueError(
                    "this error model has reversal (backlash) terms: the sense of motion of "
                    "each axis is needed"
                )
            senses = np.zeros(readings.shape)
        poses = [readings, t] + ([] if senses is None else [senses])
        shape = np.broadcast_shapes(theta.shape[:-1], *(a.shape[:-1] for a in poses))
        split = _trial_split(shape, theta, poses)
        if (
            split is not None
            and not (d_axes or d_tool)
            and BACKEND == "numba"
            and math.prod(shape) >= self.compiled_min_pairs
            and math.prod(shape[:split]) >= self.compiled_min_trials
            and _compiled_kernel() is not None
        ):
            return self._evaluate_compiled(readings, theta, senses, t, shape, split, d_params)
        out = ChainEvaluation(
            np.empty((*shape, 3)),
            np.empty((*shape, 3, self.n_params)) if d_params else None,
            np.empty((*shape, 3, self.n_axes)) if d_axes else None,
            np.empty((*shape, 3, 3)) if d_tool else None,
        )
        total = math.prod(shape)
        if total <= self.chunk_size:
            self._evaluate_block(readings, theta, senses, t, out)
            return out
        if split is not None and math.prod(shape[split:]) <= self.chunk_size // 2:
            # Blocks of whole trials: the pose arrays are not broadcast over the trials,
            # so sin/cos and basis values are computed once per pose and block.
            q, s, tt, th = _separate(shape, split, readings, senses, t, theta)
            n_trials, n_poses = th.shape[0], q.shape[0]
            step = self.chunk_size // n_poses
            flat = _views(out, (n_trials, n_poses))
            for start in range(0, n_trials, step):
                sl = slice(start, start + step)
                part = ChainEvaluation(*(None if a is None else a[sl] for a in flat))
                self._evaluate_block(q, th[sl, None, :], s, tt, part)
            return out
        arrays = [readings, theta, t] + ([] if senses is None else [senses])
        inner = math.prod(shape[1:])
        if len(shape) > 1 and inner <= self.chunk_size:
            # Blocks of whole rows of the first dimension, each broadcast on its own: the
            # broadcast of every input at once (e.g. per-trial parameters over the points
            # of per-trial readings in a Monte Carlo) would copy them ``inner`` times.
            step = self.chunk_size // inner
            flat = _views(out, (shape[0], inner))
            for start in range(0, shape[0], step):
                sl = slice(start, start + step)
                part = [
                    a
                    if a.ndim == 1
                    else np.broadcast_to(a, (*shape, a.shape[-1]))[sl].reshape(-1, a.shape[-1])
                    for a in arrays
                ]
                views = (None if a is None else a[sl].reshape(-1, *a.shape[2:]) for a in flat)
                self._evaluate_block(
                    part[0],
                    part[1],
                    part[3] if senses is not None else None,
                    part[2],
                    ChainEvaluation(*views),
                )
            return out
        flat_in = [
            a if a.ndim == 1 else np.broadcast_to(a, (*shape, a.shape[-1])).reshape(total, -1)
            for a in arrays
        ]
        flat = _views(out, (total,))
        for start in range(0, total, self.chunk_size):
            sl = slice(start, start + self.chunk_size)
            part = [a if a.ndim == 1 else a[sl] for a in flat_in]
            self._evaluate_block(
                part[0],
                part[1],
                part[3] if senses is not None else None,
                part[2],
                ChainEvaluation(*(None if a is None else a[sl] for a in flat)),
            )
        return out

    def _evaluate_block(self, q, theta, senses, t, out: ChainEvaluation) -> None:
        """One numpy block of :meth:`evaluate`, written into the views of ``out``."""
        if theta.ndim > 1:
            # one contiguous copy instead of a strided read per parameter
            theta = np.moveaxis(np.ascontiguousarray(np.moveaxis(theta, -1, 0)), 0, -1)
        v, jp, ja, a = self._sparse_chain(
            q,
            theta,
            senses,
            t,
            out.d_params is not None,
            out.d_axes is not None,
            out.d_tool is not None,
        )
        for i in range(3):
            out.position[..., i] = _dense(v[i])
            if jp is not None:
                for j in range(self.n_params):
                    out.d_params[..., i, j] = _dense(jp[i][j])
            if ja is not None:
                for j in range(self.n_axes):
                    out.d_axes[..., i, j] = _dense(ja[i][j])
            if a is not None:
                for j in range(3):
                    out.d_tool[..., i, j] = _dense(a[i][j])

    def _evaluate_compiled(self, readings, theta, senses, t, shape, split, d_params):
        """Many trials sharing their poses: record the chain once, run it compiled."""
        q, s, tt, th = _separate(shape, split, readings, senses, t, theta)
        n_trials, n_poses = th.shape[0], q.shape[0]
        program = Program(n_poses, self.n_params)
        v, jp, _, _ = self._sparse_chain(
            q, _Parameters(program.inputs()), s, tt, d_params, False, False
        )
        for i in range(3):
            program.store(POSITION, i, v[i])
            if d_params:
                for j in range(self.n_params):
                    program.store(JACOBIAN, i * self.n_params + j, jp[i][j])
        ops, n_registers = program.compile()
        position = np.empty((n_trials * n_poses, 3))
        jacobian = np.empty((n_trials * n_poses, 3 * self.n_params) if d_params else (1, 1))
        generate = n_trials * n_poses >= self.generated_min_pairs
        _compiled_kernel().run(ops, program.table(), th, n_registers, position, jacobian, generate)
        return ChainEvaluation(
            position.reshape(*shape, 3),
            jacobian.reshape(*shape, 3, self.n_params) if d_params else None,
        )

    def _sparse_chain(self, q, theta, senses, t, d_params, d_axes, d_tool):
        """Both passes of the chain on sparse entries (:mod:`._sparse3`).

        ``q``, ``senses``, ``t`` and ``theta`` may be arrays of any broadcastable shapes
        (numpy backend) or, for the compiled backend, pose arrays and the registers of a
        :class:`~mtmetrology.kinematics._program.Program`: the same code serves both.

        Returns
        -------
        v : 3-tuple of entries
            Position.
        jp, ja : lists [3][n] of entries or None
            Parameter and readings Jacobians.
        a : 3×3 tuple of entries or None
            Tool Jacobian (the linear part of the whole chain).
        """
        elements = self._elements

        # Per element: sparse error values (δ, ε), their q-derivatives, term factors;
        # rotation matrices of rotary motions.  Arrays keep their own (broadcastable)
        # shapes: a rotation depends on the points only, not on the trials.
        data: list = [None] * len(elements)
        for i, el in enumerate(elements):
            if isinstance(el, _Errors):
                data[i] = self._block_values(el, q, theta, senses, need_dq=d_axes)
            elif isinstance(el, _Motion) and not el.linear:
                data[i] = s3.axis_rotation(el.direction, el.sigma * q[..., el.axis])

        # Right-to-left pass: inputs[i] is the point entering element i.
        v = (t[..., 0], t[..., 1], t[..., 2])
        need_inputs = d_params or d_axes
        inputs: list = [None] * len(elements)
        for i in range(len(elements) - 1, -1, -1):
            el = elements[i]
            if need_inputs:
                inputs[i] = v
            if isinstance(el, _Offset):
                v = tuple(s3.add(v[k], float(el.vector[k])) for k in range(3))
            elif isinstance(el, _Motion):
                if el.linear:
                    step = el.sigma * q[..., el.axis]
                    v = tuple(
                        s3.add(v[k], step * el.direction[k]) if el.direction[k] else v[k]
                        for k in range(3)
                    )
                else:
                    v = s3.matvec(data[i], v)
            else:
                de = data[i][0]
                w = s3.add_vectors(de[:3], s3.cross(de[3:], v))
                v = tuple(s3.add(v[k], w[k] if el.varsign > 0 else s3.neg(w[k])) for k in range(3))
        if not (d_params or d_axes or d_tool):
            return v, None, None, None

        # Left-to-right pass: a is the linear part of F_1 ... F_{i-1}.  The last element
        # that needs it bounds the pass (no product is formed for nothing).
        needs = [
            i
            for i, el in enumerate(elements)
            if (isinstance(el, _Errors) and (d_params or (d_axes and data[i][1] is not None)))
            or (isinstance(el, _Motion) and d_axes)
        ]
        last = len(elements) - 1 if d_tool else (max(needs) if needs else -1)
        jp = [[s3.ZERO] * self.n_params for _ in range(3)] if d_params else None
        ja = [[s3.ZERO] * self.n_axes for _ in range(3)] if d_axes else None
        a = s3.IDENTITY
        for i, el in enumerate(elements[: last + 1]):
            if isinstance(el, _Offset):
                continue
            if isinstance(el, _Motion):
                if d_axes:
                    if el.linear:
                        # d/dq (v + σ q u) = σ u
                        u = tuple(float(x) for x in el.direction)
                        col = s3.matvec(a, tuple(x if x else s3.ZERO for x in u))
                    else:
                        # d/dq Rot(u, σq) v = σ u × (Rot v), through the prefix
                        out = inputs[i - 1] if i > 0 else v
                        u = tuple(float(x) if x else s3.ZERO for x in el.direction)
                        col = s3.matvec(a, s3.cross(u, out))
                    _accumulate(ja, el.axis, col, el.sigma)
                if not el.linear and (i < last or d_tool):
                    a = s3.matmul(a, data[i])
                continue
            de, dde, factors = data[i]
            r_in = inputs[i]
            gs = el.varsign
            cols = {}
            # the columns serve the parameter and reading Jacobians only (the inputs r_in
            # are recorded for those); the tool Jacobian needs the linear part alone
            wanted = d_params or (d_axes and dde is not None)
            for c in set(el.components) if wanted else ():
                if c < 3:
                    cols[c] = (a[0][c], a[1][c], a[2][c])
                else:
                    e = [s3.ZERO, s3.ZERO, s3.ZERO]
                    e[c - 3] = s3.ONE
                    cols[c] = s3.matvec(a, s3.cross(tuple(e), r_in))
            if d_params:
                for k, j in enumerate(el.params):
                    _accumulate(jp, j, cols[el.components[k]], gs * factors[k])
            if d_axes and dde is not None:
                for c, col in cols.items():
                    if dde[c] is not s3.ZERO:
                        _accumulate(ja, el.axis, col, gs * dde[c])
            if el.has_rotation and (i < last or d_tool):
                eps = de[3:] if gs > 0 else tuple(s3.neg(x) for x in de[3:])
                # linear part of I + ς[ε]×
                a = s3.add_matrices(a, s3.matmul(a, s3.skew(eps)))
        return v, jp, ja, (a if d_tool else None)

    def _block_values(self, el: _Errors, q, theta, senses, need_dq: bool):
        """Sparse δε (6 entries) of an error block, its q-derivative, each term's factor."""
        qk = q[..., el.axis]
        phi = dphi = None
        if el.max_degree >= 0:
            phi, dphi = el.basis.values(qk, el.max_degree)
        factors = []
        de = [s3.ZERO] * 6
        dde = [s3.ZERO] * 6
        has_motion = False
        for k, j in enumerate(el.params):
            kind = el.kinds[k]
            if kind == "location":
                f = 1.0
            elif kind == "reversal":
                f = senses[..., el.axis]
            else:
                f = phi[el.degrees[k]]
            factors.append(f)
            c = el.components[k]
            de[c] = s3.add(de[c], theta[..., j] * f)
            if need_dq and kind == "motion":
                has_motion = True
                dde[c] = s3.add(dde[c], theta[..., j] * dphi[el.degrees[k]])
        return tuple(de), (tuple(dde) if has_motion else None), factors
