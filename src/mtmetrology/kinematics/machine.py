"""A machine: topology + nominal geometry + error model, with forward and inverse kinematics.

Examples
--------
>>> import numpy as np
>>> m = Machine.load("five-axis-wcbxfzyst")
>>> m.axis_names
('X', 'Y', 'Z', 'B', 'C', 'S')
>>> q = m.readings_from_customary({"X": 10.0, "Y": 0.0, "Z": 0.0, "B": 90.0, "C": 0.0})
>>> np.round(m.forward(q), 9)      # R_z(C) R_y(B) (x, y, z)
array([  0.,   0., -10.])
"""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from mtmetrology.errors import ConvergenceError, InputError
from mtmetrology.io.documents import parse_document
from mtmetrology.kinematics.basis import Basis
from mtmetrology.kinematics.chain import AxisGeometry, ChainEvaluation, KinematicChain
from mtmetrology.kinematics.config import (
    MachineFileError,
    MachineSpec,
    load_machine_spec,
    parse_machine_spec,
)
from mtmetrology.kinematics.parameters import (
    ErrorParameter,
    ParameterNameError,
    catalogue,
    coefficient_unit,
    parse_parameter,
)
from mtmetrology.kinematics.preset_registry import list_presets, preset_text
from mtmetrology.kinematics.topology import LINEAR_AXES, Topology, parse_topology
from mtmetrology.optimize import STATUS_MESSAGES, Status, least_squares_batch
from mtmetrology.units import parse_unit

__all__ = ["Machine"]

_UNIT_VECTORS = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}
_ROTARY_DIRECTION = {"A": "X", "B": "Y", "C": "Z", "S": "Z"}
_DEG = np.pi / 180.0


def _direction(spec, axis: str) -> np.ndarray:
    if spec is None:
        letter = axis if axis in LINEAR_AXES else _ROTARY_DIRECTION[axis]
        return np.array(_UNIT_VECTORS[letter])
    if isinstance(spec, str):
        s = spec.strip().upper()
        sign = -1.0 if s.startswith("-") else 1.0
        return sign * np.array(_UNIT_VECTORS[s.lstrip("+-")])
    v = np.asarray(spec, dtype=float)
    return v / np.linalg.norm(v)


class Machine:
    """A serial machine with an active error model.

    Build one with :meth:`load` (preset name or YAML file), :meth:`from_spec` or
    :meth:`from_topology`.  Readings arrays have one column per axis in
    :attr:`axis_names` order (linear axes, then rotary axes, then the spindle S), in
    internal units (mm, rad); parameter vectors follow :attr:`parameter_names`.

    Attributes
    ----------
    name : str
    topology : Topology
    axes : dict of str to AxisGeometry
    tool : ndarray, shape (3,)
        Nominal tool (stylus-centre) vector in the last tool-axis frame, mm.
    tip_radius : float
        Nominal probe tip radius, mm.
    model_name : str or None
        The named error model of the definition that is active.
    parameters : list of ErrorParameter
    """

    def __init__(
        self,
        name: str,
        topology: Topology,
        axes: dict[str, AxisGeometry],
        parameters: Sequence[ErrorParameter] = (),
        *,
        tool=(0.0, 0.0, 0.0),
        workpiece_offset=(0.0, 0.0, 0.0),
        tip_radius: float = 0.0,
        model_name: str | None = None,
        spec: MachineSpec | None = None,
    ):
        self.name = name
        self.topology = topology
        self.axes = axes
        self.tool = np.asarray(tool, dtype=float)
        self.workpiece_offset = np.asarray(workpiece_offset, dtype=float)
        self.tip_radius = float(tip_radius)
        self.model_name = model_name
        self.spec = spec
        names = [p.name for p in parameters]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ParameterNameError(f"parameter(s) listed twice: {', '.join(dup)}")
        self.parameters = list(parameters)
        self.chain = KinematicChain(topology, axes, self.parameters, self.workpiece_offset)
        self.parameter_units = tuple(
            coefficient_unit(p, normalised=self.axes[p.axis].basis.normalised)
            for p in self.parameters
        )
        self.parameter_scales = np.array([parse_unit(u).factor for u in self.parameter_units])

    # ------------------------------------------------------------------ construction
    @classmethod
    def load(cls, source: str | Path, model: str | None = None) -> Machine:
        """A machine from a preset name or a YAML file.

        Parameters
        ----------
        source : str or path
            Preset name (see :func:`list_presets`) or path to a machine YAML file.
        model : str, optional
            Name of the error model to activate; the file's ``default_model`` otherwise.
        """
        text = str(source)
        if not Path(text).is_file() and text in list_presets():
            data = parse_document(preset_text(text), f"preset {text}.yaml")
            spec = parse_machine_spec(data, f"preset {text}")
        elif Path(text).is_file():
            spec = load_machine_spec(text)
        else:
            raise MachineFileError(
                f"{text}: neither a machine file nor a preset "
                f"(presets: {', '.join(list_presets())})"
            )
        return cls.from_spec(spec, model=model, source=text)

    @classmethod
    def from_spec(cls, spec: MachineSpec, model: str | None = None, source: str = "") -> Machine:
        """Build a machine from a validated :class:`MachineSpec`."""
        where = source or spec.name
        try:
            topology = parse_topology(spec.topology)
        except ValueError as err:
            raise MachineFileError(f"{where}: topology: {err}") from None
        unknown = sorted(set(spec.axes) - set(topology.axes))
        if unknown:
            raise MachineFileError(
                f"{where}: axes.{unknown[0]}: axis not in topology {topology.string}"
            )
        model_name = model if model is not None else spec.default_model
        if model_name is None and len(spec.error_models) == 1:
            model_name = next(iter(spec.error_models))
        if model_name is not None and model_name not in spec.error_models:
            raise MachineFileError(
                f"{where}: no error model {model_name!r} "
                f"(models: {', '.join(spec.error_models) or 'none'})"
            )
        em = spec.error_models.get(model_name) if model_name is not None else None
        axes = {}
        for a in topology.axes:
            axes[a] = cls._axis_geometry(a, topology, spec, em, where)
        params = cls._model_parameters(topology, em, where) if em is not None else []
        return cls(
            spec.name,
            topology,
            axes,
            params,
            tool=spec.tool_mm,
            workpiece_offset=spec.workpiece_offset_mm,
            tip_radius=spec.probe.tip_radius_mm,
            model_name=model_name,
            spec=spec,
        )

    @staticmethod
    def _axis_geometry(a, topology, spec, em, where) -> AxisGeometry:
        ax = spec.axes.get(a)
        linear = a in LINEAR_AXES
        path = f"{where}: axes.{a}"
        if ax is not None:
            wrong = ("travel_deg", "resolution_deg") if linear else ("travel_mm", "resolution_mm")
            for f in wrong:
                if getattr(ax, f) is not None:
                    kind, unit = ("linear", "mm") if linear else ("rotary", "deg")
                    quantity = f.rsplit("_", 1)[0]
                    raise MachineFileError(f"{path}.{f}: a {kind} axis takes {quantity}_{unit}")
        default_sign = -1.0 if topology.side(a) == "workpiece" else 1.0
        sign = float(ax.sign) if ax is not None and ax.sign is not None else default_sign
        scale = 1.0 if linear else _DEG
        travel = None
        resolution = None
        if ax is not None:
            t = ax.travel_mm if linear else ax.travel_deg
            travel = (t[0] * scale, t[1] * scale) if t is not None else None
            r = ax.resolution_mm if linear else ax.resolution_deg
            resolution = r * scale if r is not None else None
        kind = (ax.basis if ax is not None and ax.basis else None) or (
            em.basis if em is not None else "monomial"
        )
        normalise = em.normalise if em is not None and em.normalise is not None else None
        if normalise is None:
            normalise = kind != "monomial"
        if normalise:
            if travel is None:
                raise MachineFileError(
                    f"{path}: the {kind} basis is normalised on the travel, "
                    f"so travel_{'mm' if linear else 'deg'} is required"
                )
            basis = Basis(kind, 0.5 * (travel[0] + travel[1]), 0.5 * (travel[1] - travel[0]))
        else:
            basis = Basis(kind)
        return AxisGeometry(
            name=a,
            direction=_direction(ax.direction if ax is not None else None, a),
            sign=sign,
            offset=np.asarray(ax.offset_mm if ax is not None else (0, 0, 0), dtype=float),
            travel=travel,
            resolution=resolution,
            basis=basis,
        )

    @staticmethod
    def _model_parameters(topology: Topology, em, where: str) -> list[ErrorParameter]:
        names: list[str] = []
        for func, degrees in em.motions.items():
            names.extend(f"{func.strip()}{d}" for d in degrees)
        names.extend(em.parameters)
        out = []
        for n in names:
            try:
                p = parse_parameter(n)
            except ParameterNameError as err:
                raise MachineFileError(f"{where}: error_models: {err}") from None
            if p.axis not in topology.axes:
                raise MachineFileError(
                    f"{where}: error_models: {p.name} refers to axis {p.axis}, "
                    f"not in topology {topology.string}"
                )
            out.append(p)
        seen: set[str] = set()
        for p in out:
            if p.name in seen:
                raise MachineFileError(f"{where}: error_models: {p.name} is listed twice")
            seen.add(p.name)
        return out

    @classmethod
    def from_topology(
        cls, topology: str, parameters: Sequence[str] = (), *, name: str = "", **kwargs
    ) -> Machine:
        """A machine with default geometry (unit axis directions, zero offsets).

        Workpiece-branch axes get sign −1 (relative tool motion is +q), tool-branch +1.
        """
        spec = MachineSpec(
            name=name or topology,
            topology=topology,
            error_models={"model": {"parameters": list(parameters)}},
            default_model="model",
            **kwargs,
        )
        return cls.from_spec(spec)

    def with_parameters(self, names: Sequence[str]) -> Machine:
        """The same machine with another list of active error parameters."""
        params = [parse_parameter(n) for n in names]
        for p in params:
            if p.axis not in self.topology.axes:
                raise ParameterNameError(
                    f"{p.name} refers to axis {p.axis}, not in topology {self.topology.string}"
                )
        return Machine(
            self.name,
            self.topology,
            self.axes,
            params,
            tool=self.tool,
            workpiece_offset=self.workpiece_offset,
            tip_radius=self.tip_radius,
            model_name=None,
            spec=self.spec,
        )

    def with_tool(self, tool) -> Machine:
        """The same machine with another tool (stylus-centre) vector, mm (e.g. a calibrated
        one, :attr:`ParameterSet.tool <mtmetrology.kinematics.parameter_set.ParameterSet>`)."""
        t = np.asarray(tool, dtype=float)
        if t.shape != (3,) or not np.all(np.isfinite(t)):
            raise ValueError(f"tool vector must be 3 finite values (mm), got {tool!r}")
        out = copy.copy(self)
        out.tool = t
        return out

    # ------------------------------------------------------------------ properties
    @property
    def axis_names(self) -> tuple[str, ...]:
        return self.topology.axes

    @property
    def n_axes(self) -> int:
        return len(self.axis_names)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def n_params(self) -> int:
        return len(self.parameters)

    @property
    def linear_axes(self) -> tuple[str, ...]:
        return tuple(a for a in self.axis_names if a in LINEAR_AXES)

    def catalogue(self, max_degree: int = 3) -> list[ErrorParameter]:
        """Every candidate error parameter of this machine's topology."""
        return catalogue(self.topology, max_degree)

    def unit_of(self, p: ErrorParameter) -> str:
        """Customary unit of any catalogue parameter under this machine's bases."""
        return coefficient_unit(p, normalised=self.axes[p.axis].basis.normalised)

    # ------------------------------------------------------------------ readings
    def readings_from_customary(
        self, values: Mapping[str, object] | np.ndarray, *, spindle_default: float = 0.0
    ) -> np.ndarray:
        """Internal readings from customary ones (linear mm, rotary degrees).

        Parameters
        ----------
        values : mapping of axis letter to array_like, or ndarray (..., n_axes)
            A missing spindle ``S`` takes ``spindle_default`` (degrees).
        """
        if isinstance(values, Mapping):
            cols = []
            for a in self.axis_names:
                if a in values:
                    cols.append(np.asarray(values[a], dtype=float))
                elif a == "S":
                    cols.append(np.asarray(spindle_default, dtype=float))
                else:
                    raise KeyError(f"missing reading for axis {a}")
            cols = np.broadcast_arrays(*cols)
            arr = np.stack(cols, axis=-1)
        else:
            arr = np.array(values, dtype=float)
            if arr.shape[-1] != self.n_axes:
                raise ValueError(
                    f"readings have {arr.shape[-1]} columns; this machine has axes "
                    f"{''.join(self.axis_names)}"
                )
        return arr * self._reading_scales()

    def readings_to_customary(self, readings: np.ndarray) -> np.ndarray:
        """Customary readings (mm, degrees) from internal ones."""
        return np.asarray(readings) / self._reading_scales()

    def _reading_scales(self) -> np.ndarray:
        return np.array([1.0 if a in LINEAR_AXES else _DEG for a in self.axis_names])

    def _check(self, readings, params):
        q = np.asarray(readings, dtype=float)
        if q.ndim == 0 or q.shape[-1] != self.n_axes:
            raise ValueError(
                f"readings must have shape (..., {self.n_axes}) for axes "
                f"{''.join(self.axis_names)}, got {q.shape}"
            )
        if params is None:
            theta = np.zeros(self.n_params)
        else:
            theta = np.asarray(params, dtype=float)
            if theta.ndim == 0 or theta.shape[-1] != self.n_params:
                raise ValueError(
                    f"parameters must have shape (..., {self.n_params}) for "
                    f"{', '.join(self.parameter_names) or 'no parameters'}, got {theta.shape}"
                )
        return q, theta

    # ------------------------------------------------------------------ kinematics
    def evaluate(
        self,
        readings,
        params=None,
        *,
        senses=None,
        tool=None,
        d_params=False,
        d_axes=False,
        d_tool=False,
    ) -> ChainEvaluation:
        """Tip position and the requested analytic Jacobians (see :class:`KinematicChain`).

        Parameters
        ----------
        readings : array_like, shape (..., n_axes)
            Axis readings, mm and rad.
        params : array_like, shape (..., n_params), optional
            Error parameters in internal units (mm, rad, 1, mm/rad, ...).
        senses : array_like, shape (..., n_axes), optional
            Sense of motion (+1/−1) per axis, for reversal terms.
        tool : array_like, shape (..., 3), optional
            Tool vector (mm); the machine's nominal tool when omitted.
        d_params, d_axes, d_tool : bool
            Also return ∂p/∂θ (..., 3, n_params), ∂p/∂q (..., 3, n_axes) and ∂p/∂t
            (..., 3, 3).

        Returns
        -------
        ChainEvaluation
            ``position`` (..., 3) mm in the workpiece frame and the Jacobians asked for
            (None otherwise); all inputs broadcast against each other.

        Raises
        ------
        InputError
            If the readings or parameters do not have the machine's trailing sizes.

        Notes
        -----
        The stylus centre is ``T_W⁻¹ · T_T · t`` with each branch a product of axis offsets,
        nominal motions and ISO 230-1 small-displacement matrices ``I + [ε]× | δ``; error
        motions are deviations of the tool relative to the workpiece whichever component
        moves (ISO 230-1:2012, §3; ISO 841:2001), location errors are referred to the axis
        reference points (:mod:`mtmetrology.kinematics.conventions`).

        References
        ----------
        ISO 230-1:2012, *Test code for machine tools — Part 1: Geometric accuracy of
        machines operating under no-load or quasi-static conditions*.
        ISO 841:2001, *Industrial automation systems and integration — Numerical control of
        machines — Coordinate system and motion nomenclature*.
        Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with
        On-Machine Tool Metrology*. PhD thesis, Polytechnique Montréal, Table 7-1.

        Examples
        --------
        Point 1 of Sepahi Boroujeni (2021), Table 7-1: readings X = −138.5650, Y = 94.6560,
        Z = 196.2320 mm, B = −42°, C = −293°, published compensated position (−178.6461,
        −178.6461, 53.1107) mm.  The nominal chain lands within 0.03 mm of it, the size of
        the machine's geometric errors:

        >>> import numpy as np
        >>> m = Machine.load("five-axis-wcbxfzyst")
        >>> q = m.readings_from_customary(
        ...     {"X": -138.565, "Y": 94.656, "Z": 196.232, "B": -42.0, "C": -293.0, "S": 0.0})
        >>> ev = m.evaluate(q, d_params=True)
        >>> published = np.array([-178.6461, -178.6461, 53.1107])
        >>> bool(np.abs(ev.position - published).max() < 0.03), ev.d_params.shape
        (True, (3, 13))
        """
        q, theta = self._check(readings, params)
        t = self.tool if tool is None else np.asarray(tool, dtype=float)
        s = None if senses is None else np.asarray(senses, dtype=float)
        return self.chain.evaluate(
            q, theta, senses=s, tool=t, d_params=d_params, d_axes=d_axes, d_tool=d_tool
        )

    def forward(self, readings, params=None, *, senses=None, tool=None) -> np.ndarray:
        """Stylus-centre position in the workpiece frame, shape (..., 3), mm.

        :meth:`evaluate` without Jacobians; the same parameters, conventions and
        references.

        Examples
        --------
        The two points of Sepahi Boroujeni (2021), Table 7-1: with zero errors the chain
        lands within 0.07 mm of the published compensated positions, the size of the
        machine's geometric errors:

        >>> import numpy as np
        >>> m = Machine.load("five-axis-wcbxfzyst")
        >>> q = m.readings_from_customary({"X": np.array([-138.565, -61.288]),
        ...     "Y": np.array([94.656, 48.344]), "Z": np.array([196.232, 246.817]),
        ...     "B": np.array([-42.0, -64.0]), "C": np.array([-293.0, -124.0]),
        ...     "S": np.zeros(2)})
        >>> published = np.array([[-178.6461, -178.6461, 53.1107], [179.1009, 179.0881, 53.1067]])
        >>> bool(np.abs(m.forward(q) - published).max() < 0.07)
        True
        """
        return self.evaluate(readings, params, senses=senses, tool=tool).position

    def jacobian(self, readings, params=None, *, senses=None, tool=None) -> np.ndarray:
        """∂p/∂θ, shape (..., 3, n_params): mm per internal parameter unit."""
        return self.evaluate(readings, params, senses=senses, tool=tool, d_params=True).d_params

    def axis_jacobian(self, readings, params=None, *, senses=None, tool=None) -> np.ndarray:
        """∂p/∂q, shape (..., 3, n_axes): mm per mm (linear), mm per rad (rotary)."""
        return self.evaluate(readings, params, senses=senses, tool=tool, d_axes=True).d_axes

    def inverse(
        self,
        points,
        readings,
        params=None,
        *,
        senses=None,
        tool=None,
        snap: bool = False,
        tol: float = 1e-12,
        max_iter: int = 20,
    ) -> np.ndarray:
        """Readings that put the stylus centre at workpiece points.

        Rotary (and spindle) readings are held at the values given; the linear
        readings are solved for.  The nominal chain is affine in the linear readings, so
        the first Newton step from any start is the nominal closed form; with errors the
        iteration converges quadratically (and in one step whenever the error model is
        affine in the linear axes, e.g. the 13-parameter model of Sepahi Boroujeni (2021),
        Table 5-1).  Each point is one square 3 × 3 problem of the batched least-squares
        core (:func:`mtmetrology.optimize.least_squares_batch`: Newton's step with the
        Levenberg–Marquardt safeguard, only the points still iterating evaluated).

        Parameters
        ----------
        points : array_like, shape (..., 3)
            Target stylus-centre positions in the workpiece frame, mm.
        readings : array_like, shape (..., n_axes)
            Rotary readings (rad) to hold; linear columns are starting values.
        params, senses, tool
            As in :meth:`evaluate`.
        snap : bool
            Round the linear readings to each axis's resolution afterwards
            (Sepahi Boroujeni (2021), Ch. 9 recommendation).
        tol : float
            Convergence tolerance on the position, mm.

        Returns
        -------
        ndarray, shape (..., n_axes)

        Raises
        ------
        InputError
            If the machine does not have exactly three linear axes, or ``points`` is not a
            finite (..., 3) array.
        ConvergenceError
            If Newton's iteration leaves a position residual above ``tol`` after
            ``max_iter`` steps (the message gives the largest residual and its point), or
            the position does not depend on the linear readings (singular Jacobian).
        """
        lin = [i for i, a in enumerate(self.axis_names) if a in LINEAR_AXES]
        if len(lin) != 3:
            raise InputError(
                f"inverse kinematics needs three linear axes; {self.name} has "
                f"{''.join(self.linear_axes) or 'none'}"
            )
        try:
            target = np.asarray(points, dtype=float)
        except (TypeError, ValueError) as exc:
            raise InputError(f"points must be a numeric (..., 3) array, mm ({exc})") from None
        if target.ndim == 0 or target.shape[-1] != 3 or not np.all(np.isfinite(target)):
            what = (
                f"shape {target.shape}"
                if target.ndim == 0 or target.shape[-1] != 3
                else f"NaN or inf in {int(np.sum(~np.isfinite(target)))} coordinate(s)"
            )
            raise InputError(f"points must be a finite (..., 3) array, mm; got {what}")
        q, theta = self._check(readings, params)
        shape = np.broadcast_shapes(target.shape[:-1], q.shape[:-1], theta.shape[:-1])
        n_points = int(np.prod(shape))
        start = np.broadcast_to(q, (*shape, self.n_axes)).reshape(n_points, self.n_axes).copy()
        goal = np.broadcast_to(target, (*shape, 3)).reshape(n_points, 3)
        per_point = {
            key: _point_rows(value, shape, n_points)
            for key, value in (("params", theta), ("senses", senses), ("tool", tool))
        }

        def normal_equations(linear, index):
            # r = p(q) − target with J = ∂p/∂q_linear (3 × 3): one small problem per point
            rows = start[index]
            rows[:, lin] = linear
            ev = self.evaluate(
                rows,
                _take(per_point["params"], index),
                senses=_take(per_point["senses"], index),
                tool=_take(per_point["tool"], index),
                d_axes=True,
            )
            jac = ev.d_axes[:, :, lin]
            resid = ev.position - goal[index]
            return (
                np.einsum("kji,kjl->kil", jac, jac),
                np.einsum("kji,kj->ki", jac, resid),
                np.einsum("kj,kj->k", resid, resid),
                3,
            )

        # Newton's method for the square system, on the batched core (Levenberg–Marquardt
        # safeguard, status per point); the step tolerance is the position tolerance since
        # the linear columns of ∂p/∂q are unit vectors up to the errors
        solved = least_squares_batch(
            normal_equations,
            start[:, lin],
            xtol=tol,
            max_iter=max_iter,
            residual_rounding=np.finfo(float).eps * np.maximum(np.max(np.abs(goal), axis=1), 1.0),
        )
        residual = np.sqrt(2.0 * solved.cost)
        failed = ~solved.success | ~(
            residual
            <= np.maximum(tol, 8 * np.finfo(float).eps * (np.max(np.abs(goal), axis=1) + 1.0))
        )
        if failed.any():
            singular = solved.status == Status.NOT_FINITE
            if np.any(singular & np.isfinite(residual)):
                raise ConvergenceError(
                    "inverse kinematics: the position does not depend on the linear readings "
                    "(singular Jacobian): check the machine's axis directions"
                )
            error = np.where(failed, np.nan_to_num(residual, nan=np.inf), 0.0)
            worst = int(np.argmax(error))
            at = np.unravel_index(worst, shape) if shape else ()
            where = f" at point {at[0] if len(at) == 1 else tuple(map(int, at))}" if at else ""
            raise ConvergenceError(
                f"inverse kinematics did not converge (residual {float(error[worst]):.3g} mm"
                f"{where} after {int(solved.nit[worst])} Newton steps, tol {tol:g} mm; "
                f"{STATUS_MESSAGES[Status(int(solved.status[worst]))]})"
            )
        start[:, lin] = solved.x
        q = start.reshape(*shape, self.n_axes)
        if snap:
            for i in lin:
                res = self.axes[self.axis_names[i]].resolution
                if res:
                    q[..., i] = np.round(q[..., i] / res) * res
        return q


def _point_rows(value, shape: tuple, n_points: int):
    """``value`` (…, k) as (n_points, k) rows when it varies by point; unchanged otherwise."""
    if value is None:
        return None
    value = np.asarray(value, dtype=float)
    if value.ndim <= 1:
        return value
    return np.broadcast_to(value, (*shape, value.shape[-1])).reshape(n_points, -1)


def _take(rows, index: np.ndarray):
    return rows if rows is None or rows.ndim <= 1 else rows[index]
