"""``export_compensation``: control tables from a parameter set, and the closed-loop check.

One call builds the neutral :class:`~mtmetrology.export.model.CompensationModel`, the
tables of one control format (with that control's limits: a table the control would
refuse is refused here, naming the limit), their files, and the residual tool-point error
after the control applies them (its own interpolation) on a grid over the travel, with the
identification's uncertainty (:mod:`mtmetrology.export.control`).  Nothing is written: the
result holds the file texts, the command line writes them.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from mtmetrology.display import NotebookRepr
from mtmetrology.errors import InputError
from mtmetrology.export import etalon, fanuc, grid, isg, linuxcnc, siemens, tabulated
from mtmetrology.export._common import check_points
from mtmetrology.export.control import ControlTable, residual
from mtmetrology.export.emulation import (
    SIGN_NOT_ESTABLISHED,
    Emulation,
    default_axis_names,
    emulate,
)
from mtmetrology.export.model import CompensationModel, compensation_model, table_sizes
from mtmetrology.export.tabulated import MeasuredTable, tabulated_model
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.kinematics.topology import LINEAR_AXES
from mtmetrology.kinematics.volumetric_map import VolumetricMap
from mtmetrology.units import from_internal

__all__ = ["FORMATS", "KIND", "ExportResult", "export_compensation", "residual_check"]

KIND = "compensation-export"
VERSION = 1
FORMATS = {
    "linuxcnc": linuxcnc,
    "fanuc": fanuc,
    "siemens": siemens,
    "isg": isg,
    "etalon": etalon,
}
#: Pitches the advisor tries, largest first (mm for linear axes, degrees for rotary).
ADVISOR_PITCHES = (100.0, 50.0, 40.0, 25.0, 20.0, 10.0, 5.0, 4.0, 2.5, 2.0, 1.0, 0.5)


@dataclass(frozen=True)
class ExportResult(NotebookRepr):
    """Control tables, their files and the residual error after the control applies them.

    Attributes
    ----------
    format : str
    machine, model : str
    files : dict of str to str
        File name -> text, as the control reads it.
    tables : list of dict
        Per table: function, points, pitch, unit (µm or µrad), largest |correction| and
        largest standard uncertainty of a tabulated value; the positions (mm or degrees),
        the corrections the control applies and their u.
    not_carried : list of str
        Error functions (and location errors) of the model the format cannot carry.
    residual : dict
        Over the check grid: points, largest and rms length of the residual vector r̂,
        largest expanded uncertainty U (k = 2) of a component, all in µm; the largest
        uncompensated error for scale; the check readings (mm, degrees) and r̂ (µm) at each.
    advisor : dict or None
        The pitch advisor's answer: bound (µm), pitch, whether met, and why.
    provenance : dict
    notes : list of str
        What the user must know to load the tables (e.g. a Fanuc reference offset, a sign
        the vendor's documentation does not establish).
    sign : dict or None
        What the vendors' documents establish of the sign: ``established``, ``statement``
        and per file kind the ``value`` (error or correction), ``sign_established`` and the
        ``source`` quoted (:mod:`mtmetrology.export.emulation`); None for the grid.
    at_points : dict or None
        At the user's readings: the residual ``r``, its ``U`` (k = 2) and the uncompensated
        error ``e``, arrays (n, 3) in µm, and the ``senses`` of travel (in the document:
        ``r_um``, ``U_um``, ``e_um``, ``senses`` and the largest values).
    """

    _renderer_module = "mtmetrology.export.report"

    format: str
    machine: str
    model: str | None
    files: dict
    tables: list
    not_carried: list
    residual: dict
    advisor: dict | None = None
    provenance: dict = field(default_factory=dict)
    at_points: dict | None = None
    notes: list = field(default_factory=list)
    sign: dict | None = None

    def to_dict(self) -> dict:
        """The JSON document (``kind``, ``version``); file texts are not repeated."""
        return {
            "kind": KIND,
            "version": VERSION,
            "format": self.format,
            "machine": self.machine,
            "model": self.model,
            "files": sorted(self.files),
            "tables": self.tables,
            "not_carried": self.not_carried,
            "residual": self.residual,
            "advisor": self.advisor,
            "provenance": self.provenance,
            "at_points": None if self.at_points is None else _at_document(self.at_points),
            "notes": self.notes,
            "sign": self.sign,
        }

    @classmethod
    def from_dict(cls, doc: dict, files: dict | None = None) -> ExportResult:
        """Rebuild from :meth:`to_dict` (file texts from ``files`` when given)."""
        if doc.get("kind") != KIND or doc.get("version") != VERSION:
            raise InputError(f"kind/version: not a {KIND} document of version {VERSION}")
        names = doc["files"]
        return cls(
            doc["format"],
            doc["machine"],
            doc["model"],
            {n: (files or {}).get(n, "") for n in names},
            doc["tables"],
            doc["not_carried"],
            doc["residual"],
            doc.get("advisor"),
            doc.get("provenance", {}),
            _at_arrays_from(doc.get("at_points")),
            doc.get("notes", []),
            doc.get("sign"),
        )


#: Offset of the check grid in its cells (the golden section): the check points fall between
#: the table points of any usual pitch, where the interpolation error lives.
_CHECK_OFFSET = (3 - 5**0.5) / 2


def _at_document(at: dict) -> dict:
    length = np.linalg.norm(at["r"], axis=1)
    return {
        "points": int(length.size),
        "max_um": float(length.max()),
        "max_U_um": None if at["U"] is None else float(np.max(at["U"])),
        "k": 2,
        "r_um": at["r"].tolist(),
        "U_um": None if at["U"] is None else at["U"].tolist(),
        "e_um": at["e"].tolist(),
        "senses": None if at.get("senses") is None else at["senses"].tolist(),
    }


def check_readings(machine: Machine, per_axis: int = 5) -> np.ndarray:
    """Readings of a full-factorial grid over the travel of every axis (spindle at 0); the
    residual is checked for travel in the positive direction of every axis, and when the
    model has reversal terms also in the negative direction (``residual["negative"]``).

    On each axis ``lo + (k + 0.382) (hi − lo) / per_axis``, k = 0 … per_axis − 1.
    """
    columns = []
    for a in machine.axis_names:
        travel = machine.axes[a].travel
        if a == "S" or travel is None:
            columns.append(np.zeros(1))
        else:
            k = np.arange(per_axis) + _CHECK_OFFSET
            columns.append(travel[0] + (travel[1] - travel[0]) * k / per_axis)
    return np.array(list(itertools.product(*columns)))


def check_table_limit(fmt: str, machine: Machine, pitch, points, axes) -> None:
    """Refuse, from the travels alone and before any table is built, a grid with more
    points in one table than the control accepts (the format's ``MAX_POINTS``: FANUC
    1024 over all axes, LinuxCNC 256, SINUMERIK 200 per table)."""
    limit = getattr(FORMATS[fmt], "MAX_POINTS", None)
    if limit is None:
        return
    for function, n in table_sizes(machine, pitch=pitch, points=points, axes=axes).items():
        given = f"--pitch {pitch:g}" if pitch is not None else f"--points {points}"
        check_points(fmt, f"{given}: {function}", n, limit, "checked before the tables are built")


def _build(fmt: str, model: CompensationModel, functions):
    module = FORMATS[fmt]
    tables = module.build(model, functions)
    constants = isg.constants(model) if fmt in ("isg", "etalon") else ()
    return module, tables, constants


def _render(fmt: str, module, tables, model: CompensationModel, axis_names) -> dict:
    if fmt == "siemens":
        return module.render(tables, model, axis_names=axis_names)
    return module.render(tables, model)


def residual_check(
    model: CompensationModel,
    tables,
    constants,
    readings: np.ndarray,
    senses=None,
    factors=None,
) -> tuple[np.ndarray, np.ndarray | None]:
    """Residual r̂ and u (mm) at ``readings`` after the control applies ``tables``; travel
    in the positive direction of every axis unless ``senses`` (±1 per reading and axis).
    A model of a measured table takes the machine's error from the table
    (:func:`mtmetrology.export.tabulated.residual_after`)."""
    if model.measured:
        return tabulated.residual_after(model, tables, constants, readings, senses, factors)
    cov = None
    if model.parameters.covariance is not None:
        p = model.parameters
        order = [p.names.index(n) for n in model.machine.parameter_names]
        cov = p.covariance[np.ix_(order, order)]
    return residual(
        model.machine,
        model.theta,
        cov,
        tables,
        readings,
        senses,
        constants=constants,
        factors=factors,
    )


def emulated_residual(
    model: CompensationModel, emulated: Emulation, readings: np.ndarray, senses=None
) -> tuple[np.ndarray, np.ndarray | None]:
    """Residual r̂ and u (mm) left by the control's emulation of the written files."""
    return residual_check(
        model, emulated.tables, emulated.constants, readings, senses, emulated.factors
    )


def _sign(emulated: Emulation) -> dict:
    """What the vendors' documents establish of the sign of the written files."""
    established = emulated.sign_established
    return {
        "established": established,
        "statement": (
            "sign established by the vendor's documentation"
            if established
            else SIGN_NOT_ESTABLISHED
            + ": before production, run the verification procedure (--verify-program, then "
            "mtm export check) to confirm the sign and size on the machine"
        ),
        "files": emulated.semantics,
    }


def _axis_names(fmt: str, machine: Machine, axis_names: dict | None) -> dict | None:
    """Checked control axis names (Sinumerik machine-axis names)."""
    if not axis_names:
        return None
    if fmt != "siemens":
        raise InputError(f"--axis-names: format {fmt} names its axes itself (siemens only)")
    out = default_axis_names(machine)
    for axis, name in axis_names.items():
        if axis not in out:
            raise InputError(f"--axis-names: {axis!r} is not an axis of {machine.name}")
        if not (isinstance(name, str) and name.isidentifier()):
            raise InputError(f"--axis-names: {axis}={name!r} is not a machine-axis name")
        out[axis] = name
    if len(set(out.values())) != len(out):
        raise InputError(f"--axis-names: two axes share a name ({out})")
    return out


def _interpolation_error(fmt, machine, parameters, functions, pitch, readings) -> float:
    """Largest tool-point effect of the control's interpolation at ``pitch`` (mm).

    The format's tables at ``pitch`` against linear tables 16 times finer (the error
    function itself to 1/256 of the linear interpolation error), aligned at each table's
    reference point (a Fanuc table is zero there).
    """
    model = compensation_model(machine, parameters, pitch=pitch, covariance=False)
    _, tables, constants = _build(fmt, model, functions)
    fine = compensation_model(machine, parameters, pitch=pitch / 16, covariance=False)
    exact = []
    for t in tables:
        f = fine.table(t.function)
        ref = t.positions[t.reference_index]
        shift = np.interp(ref, f.positions, f.forward) - t.forward[t.reference_index]
        c = f.forward - shift
        exact.append(ControlTable(t.function, f.positions, c, c, "linear", t.period))
    got = residual_check(model, tables, constants, readings)[0]
    want = residual_check(model, exact, constants, readings)[0]
    return float(np.abs(got - want).max())


def advise_pitch(fmt, machine, parameters, functions, bound_um: float, readings) -> dict:
    """The largest pitch of :data:`ADVISOR_PITCHES` whose interpolation error ≤ bound."""
    tried = None
    for pitch in ADVISOR_PITCHES:
        try:
            err = from_internal(
                _interpolation_error(fmt, machine, parameters, functions, pitch, readings), "µm"
            )
        except InputError as exc:  # beyond the travel (try smaller) or the control's limits
            if tried is None:
                continue
            reason = f"{tried}; a smaller pitch is refused: {exc}"
            return {"bound_um": bound_um, "pitch": None, "met": False, "reason": reason}
        if err <= bound_um:
            return {
                "bound_um": bound_um,
                "pitch": pitch,
                "met": True,
                "interpolation_error_um": err,
                "reason": f"pitch {pitch:g}: interpolation error {err:.2g} µm <= {bound_um:g} µm",
            }
        tried = f"pitch {pitch:g}: interpolation error {err:.2g} µm > {bound_um:g} µm"
    reason = tried or "no pitch of the list fits the travel"
    return {"bound_um": bound_um, "pitch": None, "met": False, "reason": reason}


def _at_arrays_from(doc: dict | None) -> dict | None:
    if doc is None:
        return None
    u, senses = doc["U_um"], doc.get("senses")
    return {
        "r": np.array(doc["r_um"]),
        "U": None if u is None else np.array(u),
        "e": np.array(doc["e_um"]),
        "senses": None if senses is None else np.array(senses),
    }


def _at_arrays(r: np.ndarray, u: np.ndarray | None, e: np.ndarray, senses=None) -> dict:
    """The residual r̂, its U (k = 2) and the uncompensated error e at the user's readings,
    µm (n, 3); ``senses`` (n, n_axes) the sense of travel of each axis there."""
    return {
        "r": from_internal(r, "µm"),
        "U": None if u is None else from_internal(2 * u, "µm"),
        "e": from_internal(e, "µm"),
        "senses": None if senses is None else np.asarray(senses, float),
    }


def _largest_um(values: np.ndarray) -> float:
    return float(from_internal(np.abs(values).max(), "µm"))


def _reversal_notes(model: CompensationModel, tables, fmt: str) -> list[str]:
    """Reversal terms a format drops (it writes the forward table only) or a mean pitch
    table leaves (the measured reversal, for the control's backlash setting)."""
    out = [
        f"{m.function}: the pitch table is tabulated as the mean of both directions; the "
        f"measured reversal of up to {_largest_um(m.forward - m.reverse):.3g} µm remains "
        "(the control's backlash setting)"
        for m in model.measured
        if not m.bidirectional
    ]
    for t in tables:
        src = model.table(t.function)
        if src.bidirectional and np.array_equal(t.forward, t.reverse):
            gap = float(from_internal(np.abs(src.forward - src.reverse).max(), src.unit))
            out.append(
                f"{t.function}: {fmt} carries the forward table only; travel in the negative "
                f"direction keeps the reversal of up to {gap:.3g} {src.unit}"
            )
    return out


def _figures(r: np.ndarray, u: np.ndarray | None, before: np.ndarray) -> dict:
    """Largest and rms residual length, largest U (k = 2) of a component and the largest
    uncompensated error (µm), and r̂ at each point."""
    return {
        "max_um": float(from_internal(np.linalg.norm(r, axis=1).max(), "µm")),
        "rms_um": float(from_internal(np.sqrt(np.mean(np.sum(r**2, axis=1))), "µm")),
        "max_U_um": None if u is None else float(from_internal(2 * u.max(), "µm")),
        "uncompensated_max_um": float(from_internal(np.linalg.norm(before, axis=1).max(), "µm")),
        "r_um": from_internal(r, "µm").tolist(),
    }


def _uncompensated(model: CompensationModel, readings, senses=None) -> np.ndarray:
    """The machine's tool-point error without compensation (mm): the parameters' or the
    measured table's."""
    if model.measured:
        return tabulated.measured_error(model, readings, senses)[0]
    return residual(model.machine, model.theta, None, [], readings, senses)[0]


def _summary(model, emulated: Emulation, readings, per_axis) -> dict:
    """The check on the grid, for travel in the positive and in the negative direction of
    every axis; the second is the first when nothing the machine or the control does
    depends on the sense of travel (no reversal term, no per-direction table, a measured
    table of one direction only)."""
    r, u = emulated_residual(model, emulated, readings)
    e0 = _uncompensated(model, readings)
    positive = _figures(r, u, e0)
    summary = {
        "points": int(readings.shape[0]),
        "per_axis": per_axis,
        "k": 2,
        "axes": list(model.machine.axis_names),
        "readings": model.machine.readings_to_customary(readings).tolist(),
        **positive,
    }
    by_sense = (
        any(p.kind == "reversal" for p in model.machine.parameters)
        or any(not np.array_equal(t.forward, t.reverse) for t in emulated.tables)
        or any(not np.array_equal(t.forward, t.reverse) for t in model.measured)
    )
    if model.measured:
        # exact for linear tables (module notes of export.tabulated); a staircase's own
        # error is not a linear interpolation's
        linear = all(t.rule == "linear" for t in emulated.tables)
        summary["interpolation_bound_um"] = (
            float(from_internal(tabulated.interpolation_bound(model), "µm")) if linear else None
        )
    if by_sense:
        senses = -np.ones_like(readings)
        r, u = emulated_residual(model, emulated, readings, senses)
        e0 = _uncompensated(model, readings, senses)
        summary["negative"] = _figures(r, u, e0)
    else:
        summary["negative"] = positive
    return summary


def _grid_slice(field: VolumetricMap) -> dict:
    """The grid's middle z-plane for the report: |e| and the largest u per node (µm)."""
    k = field.shape[2] // 2
    x, y, z = field.axes
    nodes = np.stack(np.meshgrid(x, y, [z[k]], indexing="ij"), axis=-1).reshape(-1, 3)
    length = np.linalg.norm(field.error(nodes), axis=1).reshape(x.size, y.size)
    u = grid.node_uncertainty(field, nodes)
    return {
        "z_mm": float(z[k]),
        "x_mm": x.tolist(),
        "y_mm": y.tolist(),
        "length_um": from_internal(length, "µm").tolist(),
        "max_u_um": None
        if u is None
        else from_internal(u.max(axis=1).reshape(x.size, y.size), "µm").tolist(),
    }


def _export_grid(machine, source, pitch, points, region, per_axis, at) -> ExportResult:
    """The volumetric grid from a parameter set or a measured map, and the residual left by
    the control's trilinear interpolation at check points off the nodes
    (:mod:`mtmetrology.export.grid`)."""
    if isinstance(source, VolumetricMap):
        if source.machine and source.machine != machine.name:
            raise InputError(f"map: made for machine {source.machine!r}, not {machine.name!r}")
        limits = tuple((float(a[0]), float(a[-1])) for a in source.axes)
        field = grid.resample(source, grid.grid_lines(limits, pitch, points, region))
        provenance = {"map": dict(source.provenance)}
        name, model = machine.name, source.model
    else:
        source.check_machine(machine, "parameters")
        limits = grid.box(machine)
        lines = grid.grid_lines(limits, pitch, points, region)
        field = grid.from_parameters(machine, source, lines)
        provenance = {"parameters": dict(source.provenance)}
        name, model = machine.name, machine.model_name
    box = tuple((float(a[0]), float(a[-1])) for a in field.axes)
    positions = grid.check_positions(box, per_axis)
    r, u, before = grid.residual_grid(source, machine, field, positions)
    summary = {
        "points": int(positions.shape[0]),
        "per_axis": per_axis,
        "k": 2,
        "axes": ["X", "Y", "Z"],
        "readings": positions.tolist(),
        **_figures(r, u, before),
    }
    row = {
        "function": "volumetric",
        "points": int(np.prod(field.shape)),
        "unit": "µm",
        "max_correction": float(from_internal(np.abs(field.values).max(), "µm")),
        "max_u": None,
    }
    if field.factor is not None or field.node_u is not None:
        nodes = np.stack(np.meshgrid(*field.axes, indexing="ij"), axis=-1).reshape(-1, 3)
        row["max_u"] = float(from_internal(grid.node_uncertainty(field, nodes).max(), "µm"))
    row["slice"] = _grid_slice(field)
    at_points = None
    if at is not None:
        tool_points = machine.forward(np.asarray(at, float))  # nominal tool points
        at_points = _at_arrays(*grid.residual_grid(source, machine, field, tool_points))
    return ExportResult(
        "grid",
        name,
        model,
        grid.render(field, name),
        [row],
        [],
        summary,
        None,
        provenance,
        at_points,
        [
            "volumetric_grid.csv holds e = P_indicated - P_true at nominal tool-point "
            "positions (workpiece frame): the control commands P + e(P)"
        ],
    )


def export_compensation(
    machine: Machine,
    parameters: ParameterSet | VolumetricMap,
    fmt: str,
    *,
    pitch: float | None = None,
    points: int | None = None,
    axes: Sequence[str] | None = None,
    functions: Sequence[str] | None = None,
    check_per_axis: int = 5,
    bound_um: float | None = None,
    region: dict | None = None,
    at: np.ndarray | None = None,
    at_senses: np.ndarray | None = None,
    reference: dict | None = None,
    axis_names: dict | None = None,
) -> ExportResult:
    """Control tables of one format and the residual error after the control applies them.

    Parameters
    ----------
    machine : Machine
    parameters : ParameterSet, MeasuredTable or VolumetricMap
        Identified parameters with covariance, made for ``machine``; a measured pitch table
        (:class:`~mtmetrology.export.tabulated.MeasuredTable`, an ISO 230-2 run's x̄ per
        target and direction), tabulated point by point; for the ``grid`` format also a
        measured volumetric map (a map document or a vendor grid), which is resampled on
        the control's grid.
    fmt : {"linuxcnc", "fanuc", "siemens", "isg", "etalon", "grid"}
    pitch, points : float or int
        Table spacing (mm, or degrees on a rotary axis) or number of points (one of them).
    axes : sequence of str, optional
        Axes to tabulate.
    functions : sequence of str, optional
        Error functions to export (``E_XX`` …); every function the format can carry when
        omitted.  One the format cannot carry is refused.
    check_per_axis : int
        Grid points per axis of the residual check.
    bound_um : float, optional
        Interpolation-error bound of the pitch advisor, µm (axis-table formats).
    region : dict of axis to (low, high), optional
        Volumetric grid only: the box of nominal tool-point positions x, y, z (mm) it
        covers; the box the travel reaches (or the source map's grid) otherwise.  A box
        outside it is refused.
    at : ndarray, shape (n, n_axes), optional
        The user's readings (internal units): the residual r̂, its U (k = 2) and the
        uncompensated error e there as well (``at_points``).
    at_senses : ndarray, shape (n, n_axes), optional
        Sense of travel (+1 / −1) of each axis at the readings ``at`` (axis-table formats);
        positive travel when omitted.
    reference : dict of axis to float, optional
        Reference position per axis (mm or degrees), a point of the table: a Fanuc table
        is zero there (the control's reference return absorbs the error at that point).
    axis_names : dict of axis to str, optional
        Sinumerik: the control's machine-axis names (``{"X": "X1"}``, the default of K3's
        examples).

    Returns
    -------
    ExportResult

    Raises
    ------
    InputError
        Unknown format, a parameter set of another machine, a grid the control refuses.
    """
    if fmt not in (*FORMATS, "grid"):
        raise InputError(f"format: {fmt!r} is not one of {', '.join(FORMATS)}, grid")
    if pitch is None and points is None:
        raise InputError("give --pitch or --points")
    measured = isinstance(parameters, MeasuredTable)
    if bound_um is not None and not (np.isfinite(bound_um) and bound_um > 0):
        raise InputError(f"--bound: the interpolation-error bound must be > 0 µm, got {bound_um:g}")
    if fmt == "grid":
        if measured:
            raise InputError("format: grid takes a parameter set or a map, not a pitch table")
        return _export_grid(machine, parameters, pitch, points, region, check_per_axis, at)
    if isinstance(parameters, VolumetricMap):
        raise InputError(
            f"format: {fmt} tabulates error functions of a parameter set; a volumetric map is "
            "exported by the grid format only"
        )
    names = _axis_names(fmt, machine, axis_names)
    if measured:
        if bound_um is not None:
            raise InputError(
                "--bound: the pitch advisor tabulates a parameter set; for a measured table "
                "check.json states the interpolation bound at the pitch given"
            )
        model = tabulated_model(
            machine, parameters, pitch=pitch, points=points, axes=axes, reference=reference
        )
    else:
        check_table_limit(fmt, parameters.machine_for(machine), pitch, points, axes)
        model = compensation_model(
            machine, parameters, pitch=pitch, points=points, axes=axes, reference=reference
        )
    module, tables, _ = _build(fmt, model, functions)
    files = _render(fmt, module, tables, model, names)
    # the residual is what the control, emulated from its vendor's document, does with the
    # files: never the writer's own tables read back (a sign error shows as 2x the error)
    emulated = emulate(fmt, files, model.machine, reference=model.reference, axis_names=names)
    carried = {t.function for t in emulated.tables} | {n for n, _ in emulated.constants}
    not_carried = [t.function for t in model.tables if t.function not in carried]
    not_carried += [n for n, _ in model.constants if n not in carried]
    readings = check_readings(model.machine, check_per_axis)
    summary = _summary(model, emulated, readings, check_per_axis)
    at_points = None
    if at is not None:
        at = np.asarray(at, float)
        r_at, u_at = emulated_residual(model, emulated, at, at_senses)
        e_at = _uncompensated(model, at, at_senses)
        at_points = _at_arrays(r_at, u_at, e_at, at_senses)
    rows = []
    for t in tables:
        lin = t.axis in LINEAR_AXES
        src = model.table(t.function)
        u_t = src.u_forward
        scale = 1.0 if lin else np.pi / 180
        if u_t is not None:
            u_t = from_internal(np.interp(t.positions, src.positions, u_t), src.unit)
        rows.append(
            {
                "function": t.function,
                "points": int(t.positions.size),
                "pitch": round(float((t.positions[1] - t.positions[0]) / scale), 9),
                "pitch_unit": "mm" if lin else "deg",
                "unit": src.unit,
                "max_correction": float(from_internal(np.abs(t.forward).max(), src.unit)),
                "max_u": None if u_t is None else float(u_t.max()),
                "positions": (t.positions / scale).tolist(),
                "correction": from_internal(t.forward, src.unit).tolist(),
                "u": None if u_t is None else u_t.tolist(),
            }
        )
        if not np.array_equal(t.forward, t.reverse):  # per-direction tables
            rows[-1]["correction_reverse"] = from_internal(t.reverse, src.unit).tolist()
            u_r = src.u_reverse
            rows[-1]["u_reverse"] = (
                None
                if u_r is None
                else from_internal(np.interp(t.positions, src.positions, u_r), src.unit).tolist()
            )
    advisor = None
    if bound_um is not None:
        advisor = advise_pitch(fmt, model.machine, parameters, functions, bound_um, readings)
    sign = _sign(emulated)
    return ExportResult(
        fmt,
        model.machine.name,
        model.parameters.model or machine.model_name,
        files,
        rows,
        not_carried,
        summary,
        advisor,
        {"pitch_table" if measured else "parameters": dict(model.parameters.provenance)},
        at_points,
        ([] if sign["established"] else [sign["statement"]])
        + (fanuc.reference_notes(model, tables) if fmt == "fanuc" else [])
        + _reversal_notes(model, tables, fmt),
        sign,
    )
