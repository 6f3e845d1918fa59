"""The kinematic chain: forward kinematics and analytic Jacobians for any topology.

Model
-----
Each axis k carries, from its parent body outwards (F -> W or F -> T)::

    T_k(q) = Trans(o_k) · L_k · M_k(q) · E_k(q)

``o_k``
    nominal offset of the axis reference point in the parent frame at zero reading
    (a rotary axis turns about the line through this point);
``L_k``
    location errors ``E_X0k … E_C0k``: a small displacement of the axis relative to its
    parent, at its reference point, in the parent frame;
``M_k(q)``
    exact nominal motion: ``Trans(s_k q u_k)`` (linear) or ``Rot(u_k, s_k q)`` (rotary),
    ``u_k`` the axis direction and ``s_k = ±1`` its sign convention.  With the machine
    reading convention (relative tool motion is +q) table-carrying axes have ``s = −1``;
    this reproduces ``q = R_z(C) R_y(B) p`` of seed 000 (digest 000 §3.2.2);
``E_k(q)``
    error motions and reversal terms of the moving component, at the axis frame origin:
    translations ``δ = (E_Xk, E_Yk, E_Zk)(q)`` and rotations ``ε = (E_Ak, E_Bk, E_Ck)(q)``,
    each ``Σ_d c_d φ_d(q) + c_b · sense``.

Every error transform is the first-order (small-angle) matrix::

        | 1    -εc    εb   δx |
    E = | εc    1    -εa   δy |      (digest 004 §3.5)
        | -εb   εa    1    δz |

so a positive error displaces the component (the body carried by the axis, and
everything it carries) in the positive direction relative to its carrier, rotations by
the right-hand rule.  On the workpiece branch this is the table's own error: a positive
``E_XX1`` on a table-carrying X (``s = −1``) shortens the relative tool travel.

The stylus-centre position in the workpiece frame is the chain from W to T,
``p = T_W⁻¹ · T_T · t`` with ``t`` the tool (stylus-centre) vector in the last tool-axis
frame.  ``T_W⁻¹`` is formed factor by factor: nominal offsets and motions are inverted
exactly, each error transform ``E`` by its first-order inverse ``I − G`` (equal to
``E⁻¹`` up to second order in the errors).  The model is thus a product of factors each
*linear* in its error parameters, so the Jacobians below are exact derivatives of the
model (first order in the small errors by construction, exact in the nominal motion).

Jacobians
---------
With the chain written as ``p = F_1 F_2 … F_n t`` (W to T), the derivative with respect
to a parameter of factor ``F_i = I + ς G(θ)`` is ``A_i · ς (∂δ + ∂ε × r_i)`` where
``A_i`` is the linear part of ``F_1 … F_{i−1}`` and ``r_i = F_{i+1} … F_n t`` the point
entering factor i.  One right-to-left pass gives every ``r_i``, one left-to-right pass of
3×3 products every ``A_i``; all arrays are vectorised over (trial, point).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mtmetrology.kinematics.basis import Basis
from mtmetrology.kinematics.parameters import ErrorParameter
from mtmetrology.kinematics.topology import LINEAR_AXES, Topology

__all__ = ["AxisGeometry", "ChainEvaluation", "KinematicChain"]


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
    varsign: float  # +1 tool branch, -1 workpiece branch (first-order inverse)
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


def _cross_const(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """u × v for a constant 3-vector u and v of shape (..., 3)."""
    out = np.empty_like(v)
    out[..., 0] = u[1] * v[..., 2] - u[2] * v[..., 1]
    out[..., 1] = u[2] * v[..., 0] - u[0] * v[..., 2]
    out[..., 2] = u[0] * v[..., 1] - u[1] * v[..., 0]
    return out


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def _rotate(u: np.ndarray, angle: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rodrigues: rotate v (..., 3) about unit u by angle (...)."""
    c = np.cos(angle)[..., None]
    s = np.sin(angle)[..., None]
    return v * c + _cross_const(u, v) * s + u * ((v @ u)[..., None] * (1.0 - c))


def _rotation_matrix(u: np.ndarray, angle: np.ndarray) -> np.ndarray:
    c = np.cos(angle)[..., None, None]
    s = np.sin(angle)[..., None, None]
    ux = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    return c * np.eye(3) + s * ux + (1.0 - c) * np.outer(u, u)


def _skew(e: np.ndarray) -> np.ndarray:
    m = np.zeros((*e.shape[:-1], 3, 3))
    m[..., 0, 1], m[..., 0, 2] = -e[..., 2], e[..., 1]
    m[..., 1, 0], m[..., 1, 2] = e[..., 2], -e[..., 0]
    m[..., 2, 0], m[..., 2, 1] = -e[..., 1], e[..., 0]
    return m


def _rot_generator_cols(r: np.ndarray) -> np.ndarray:
    """Columns e_c × r for c = A, B, C: shape (..., 3, 3), column c = e_c × r."""
    g = np.zeros((*r.shape[:-1], 3, 3))
    # e_x × r = (0, -r_z, r_y); e_y × r = (r_z, 0, -r_x); e_z × r = (-r_y, r_x, 0)
    g[..., 1, 0], g[..., 2, 0] = -r[..., 2], r[..., 1]
    g[..., 0, 1], g[..., 2, 1] = r[..., 2], -r[..., 0]
    g[..., 0, 2], g[..., 1, 2] = -r[..., 1], r[..., 0]
    return g


def _apply_lin(a: np.ndarray | None, x: np.ndarray) -> np.ndarray:
    """a @ x for a (..., 3, 3) (None is the identity) and a vector x (..., 3)."""
    if a is None:
        return x
    return np.einsum("...ij,...j->...i", a, x)


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
            self._elements.append(self._errors(name, col[name], ("motion", "reversal"), -1.0))
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
        """
        q = readings
        theta = np.zeros(self.n_params) if params is None else params
        t = np.zeros(3) if tool is None else tool
        if senses is None and self.has_reversal:
            rev = [i for i, p in enumerate(self.parameters) if p.kind == "reversal"]
            if d_params or np.any(theta[..., rev] != 0):
                raise ValueError(
                    "this error model has reversal (backlash) terms: the sense of motion of "
                    "each axis is needed"
                )
            senses = np.zeros(q.shape)
        shape = np.broadcast_shapes(q.shape[:-1], theta.shape[:-1], t.shape[:-1])
        if senses is not None:
            shape = np.broadcast_shapes(shape, senses.shape[:-1])

        # Error values of each block: (delta_eps (...,6), derivative wrt q (...,6), factors).
        block_data: dict[int, tuple] = {}
        for i, el in enumerate(self._elements):
            if isinstance(el, _Errors):
                block_data[i] = self._block_values(el, q, theta, senses, need_dq=d_axes)

        # Right-to-left pass: inputs[i] is the point entering element i.
        v = np.broadcast_to(t, (*shape, 3)).astype(float, copy=True)
        need_inputs = d_params or d_axes
        inputs: list = [None] * len(self._elements)
        for i in range(len(self._elements) - 1, -1, -1):
            el = self._elements[i]
            if need_inputs:
                inputs[i] = v
            if isinstance(el, _Offset):
                v = v + el.vector
            elif isinstance(el, _Motion):
                qk = q[..., el.axis]
                if el.linear:
                    v = v + (el.sigma * qk)[..., None] * el.direction
                else:
                    v = _rotate(el.direction, el.sigma * qk, v)
            else:
                de = block_data[i][0]
                v = v + el.varsign * (de[..., :3] + _cross(de[..., 3:], v))
        position = v
        if not (d_params or d_axes or d_tool):
            return ChainEvaluation(position)

        jp = np.zeros((*shape, 3, self.n_params)) if d_params else None
        ja = np.zeros((*shape, 3, self.n_axes)) if d_axes else None
        a = None  # linear part of the prefix F_1 ... F_{i-1}; None is the identity
        for i, el in enumerate(self._elements):
            if isinstance(el, _Offset):
                continue
            if isinstance(el, _Motion):
                qk = q[..., el.axis]
                if el.linear:
                    if d_axes:
                        ja[..., :, el.axis] += el.sigma * _apply_lin(
                            a, np.broadcast_to(el.direction, (*shape, 3))
                        )
                    continue
                r = _rotation_matrix(el.direction, el.sigma * qk)
                if d_axes:
                    out = inputs[i - 1] if i > 0 else position
                    # d/dq Rot(u, σq) v = σ u × (Rot v), applied through the prefix.
                    ja[..., :, el.axis] += el.sigma * _apply_lin(a, _cross_const(el.direction, out))
                a = r if a is None else a @ r
                continue
            de, dde, factors = block_data[i]
            r_in = inputs[i]
            gs = el.varsign
            trans_cols = None
            rot_cols = None
            if d_params or d_axes:
                if any(c < 3 for c in el.components):
                    trans_cols = np.broadcast_to(np.eye(3), (*shape, 3, 3)) if a is None else a
                if el.has_rotation:
                    g = _rot_generator_cols(r_in)
                    rot_cols = g if a is None else a @ g
            if d_params:
                for k, j in enumerate(el.params):
                    c = el.components[k]
                    base = trans_cols[..., :, c] if c < 3 else rot_cols[..., :, c - 3]
                    jp[..., :, j] += gs * factors[k][..., None] * base
            if d_axes and dde is not None:
                contrib = np.zeros((*shape, 3))
                if trans_cols is not None:
                    contrib += np.einsum("...ij,...j->...i", trans_cols, dde[..., :3])
                if rot_cols is not None:
                    contrib += np.einsum("...ij,...j->...i", rot_cols, dde[..., 3:])
                ja[..., :, el.axis] += gs * contrib
            if el.has_rotation:
                # Linear part of I + ς[ε]×.
                skew = gs * _skew(de[..., 3:])
                a = np.eye(3) + skew if a is None else a + a @ skew
        dt = None
        if d_tool:
            dt = np.broadcast_to(np.eye(3), (*shape, 3, 3)).copy() if a is None else a
        return ChainEvaluation(position, jp, ja, dt)

    def _block_values(self, el: _Errors, q, theta, senses, need_dq: bool):
        """δε (..., 6) of an error block, its q-derivative, and each term's factor."""
        qk = q[..., el.axis]
        phi = dphi = None
        if el.max_degree >= 0:
            phi, dphi = el.basis.values(qk, el.max_degree)
        factors = []
        de = None
        dde = None
        for k, j in enumerate(el.params):
            kind = el.kinds[k]
            if kind == "location":
                f = np.ones(qk.shape)
            elif kind == "reversal":
                f = senses[..., el.axis] * np.ones(qk.shape)
            else:
                f = phi[el.degrees[k]]
            factors.append(f)
            val = theta[..., j] * f
            if de is None:
                de = np.zeros((*np.broadcast_shapes(val.shape, qk.shape), 6))
            de[..., el.components[k]] += val
            if need_dq and kind == "motion":
                if dde is None:
                    dde = np.zeros_like(de)
                dde[..., el.components[k]] += theta[..., j] * dphi[el.degrees[k]]
        return de, dde, factors
