"""Volumetric grid: the control's 3-D table of tool-point corrections, with u.

For controls that take a 3-D table.  The table is a
:class:`~mtmetrology.kinematics.volumetric_map.VolumetricMap` on a rectilinear grid of
nominal tool-point positions P (workpiece frame, mm) — the one map implementation of the
project, made from a parameter set by :meth:`VolumetricMap.from_parameters` or resampled
from a measured map (a map document or a vendor grid CSV).  Between nodes the control
interpolates trilinearly per cell (:meth:`VolumetricMap.weights`).

Sign
----
The file holds the map's **error of indication** (JCGM 200:2012, 2.16)
``e(P) = P_indicated − P_true = −δ(q)``, δ the ISO 230-1 deviation of the tool point.  This
is what the control adds to its commanded position: commanding ``P + e(P)`` puts the tool at
``P + e(P) + δ ≈ P``.  A single positioning error ``E_XX(x) = a·x`` therefore gives
``e_x = −a·x`` in the file (a tool point that lags is commanded further).

Residual
--------
At a check point P (readings q = nominal inverse of P) the control leaves

    r(P) = δ(q; θ) + e_ctrl(P),

``e_ctrl`` the trilinear interpolation of the written grid.  From a parameter set, δ comes
from the kinematic chain and ``u(r)² = diag(J U Jᵀ)`` (J = ∂p/∂θ at q: the written numbers
are fixed, the machine's θ is uncertain).  From a measured map, the map is the best
knowledge of the machine, ``δ = −e_src(P)``, and ``u(r)`` is the map's own standard
uncertainty at P (:meth:`VolumetricMap.standard_uncertainty`).

File (``volumetric_grid.csv``, :doc:`file-formats`): ``#`` comment lines, then the header
``x,y,z,ex,ey,ez[,ux,uy,uz]`` and one row per node, x varying slowest; positions in mm,
errors and uncertainties in µm — the vendor grid form :meth:`VolumetricMap.from_table`
reads (``sign = "error"``), so a written grid is itself a map source.

References
----------
ISO/TR 16907:2015, *Machine tools — Numerical compensation of geometric errors*.
JCGM 200:2012 (VIM), 2.16 (measurement error).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.export.control import residual
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.kinematics.volumetric_map import VolumetricMap
from mtmetrology.units import from_internal

__all__ = [
    "FILE",
    "box",
    "check_positions",
    "from_parameters",
    "grid_lines",
    "node_uncertainty",
    "parse",
    "render",
    "resample",
    "residual_grid",
]

NAME = "grid"
FILE = "volumetric_grid.csv"
_AXES = "xyz"


def _linear_readings(machine: Machine, points: np.ndarray) -> np.ndarray:
    """Nominal readings of tool-point positions (rotary axes at zero)."""
    zeros = np.zeros((len(points), machine.n_axes))
    return machine.inverse(points, zeros, tool=machine.tool)


def box(machine: Machine) -> tuple[tuple[float, float], ...]:
    """The box of nominal tool-point positions the travel of X, Y, Z reaches (mm)."""
    missing = [a for a in "XYZ" if a not in machine.axis_names]
    if missing:
        raise InputError(f"grid: {machine.name} has no {missing[0]} axis; a grid needs X, Y, Z")
    corners = np.array(
        np.meshgrid(*(machine.axes[a].travel for a in "XYZ"), indexing="ij")
    ).reshape(3, -1)
    q = np.zeros((corners.shape[1], machine.n_axes))
    for k, a in enumerate("XYZ"):
        q[:, machine.axis_names.index(a)] = corners[k]
    p = machine.forward(q)
    return tuple((float(p[:, k].min()), float(p[:, k].max())) for k in range(3))


def _check_in_travel(machine: Machine, region: tuple) -> None:
    """Refuse a box whose corners need readings outside the travel."""
    corners = np.array(np.meshgrid(*region, indexing="ij")).reshape(3, -1).T
    q = _linear_readings(machine, corners)
    for a in "XYZ":
        lo, hi = machine.axes[a].travel
        col = q[:, machine.axis_names.index(a)]
        if col.min() < lo - 1e-6 or col.max() > hi + 1e-6:
            k = "XYZ".index(a)
            raise InputError(
                f"grid: {_AXES[k]} from {region[k][0]:g} to {region[k][1]:g} mm is outside the "
                f"travel of {a} [{lo:g}, {hi:g}] mm"
            )


def grid_lines(
    limits: tuple, pitch: float | None = None, points: int | None = None, region=None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Grid lines of x, y, z: equally spaced from the region's start (``limits`` by default)
    at ``pitch`` mm, the region's end added; or ``points`` per axis.

    Parameters
    ----------
    limits : three (low, high)
        The box the grid must stay in (mm): the travel's box or a source map's grid.
    region : dict of "X"/"Y"/"Z" (or lower case) to (low, high), optional
        A sub-box (mm); refused when it leaves ``limits``.
    """
    region = {k.lower(): v for k, v in (region or {}).items()}
    bad = [k for k in region if k not in _AXES]
    if bad:
        raise InputError(f"region: {bad[0]} is not x, y or z")
    out = []
    for k, a in enumerate(_AXES):
        lo, hi = region.get(a, limits[k])
        if not hi > lo:
            raise InputError(f"region: {a} from {lo:g} to {hi:g} mm is empty")
        if lo < limits[k][0] - 1e-9 or hi > limits[k][1] + 1e-9:
            raise InputError(
                f"grid: {a} from {lo:g} to {hi:g} mm is outside "
                f"[{limits[k][0]:g}, {limits[k][1]:g}] mm"
            )
        if points is not None:
            if points < 2:
                raise InputError(f"points: {points} < 2")
            out.append(np.linspace(lo, hi, points))
            continue
        if not (pitch > 0 and pitch <= hi - lo):
            raise InputError(f"pitch: {pitch:g} mm must be positive and at most the {a} range")
        line = lo + pitch * np.arange(int(np.floor((hi - lo) / pitch + 1e-9)) + 1)
        out.append(line if np.isclose(line[-1], hi) else np.append(line, hi))
    return tuple(out)


def from_parameters(machine: Machine, parameters: ParameterSet, lines: tuple) -> VolumetricMap:
    """The control's grid from a parameter set: :meth:`VolumetricMap.from_parameters` at the
    nodes (sign ``error``), after refusing nodes outside the travel."""
    _check_in_travel(machine, tuple((float(x[0]), float(x[-1])) for x in lines))
    return VolumetricMap.from_parameters(machine, parameters, lines, sign="error")


def resample(source: VolumetricMap, lines: tuple) -> VolumetricMap:
    """A measured map on the control's grid: e and its covariance at the new nodes.

    The values are the source's trilinear interpolation; a covariance factor is carried
    exactly (``F_new = W F``); independent node uncertainties give each new node its
    standard uncertainty (the correlation the interpolation introduces between new nodes
    is not kept; the residual check uses the source itself).
    """
    nodes = np.stack(np.meshgrid(*lines, indexing="ij"), axis=-1).reshape(-1, 3)
    shape = (*tuple(x.size for x in lines), 3)
    factor = node_u = None
    if source.factor is not None:
        idx, w = source.weights(nodes)
        factor = np.einsum("mk,mkcr->mcr", w, source.factor[idx])
    elif source.node_u is not None:
        node_u = node_uncertainty(source, nodes).reshape(shape)
    return VolumetricMap(
        lines,
        source.error(nodes).reshape(shape),
        sign="error",
        machine=source.machine,
        model=source.model,
        tool=source.tool,
        reference=source.reference,
        factor=factor,
        node_u=node_u,
        provenance={"resampled from": dict(source.provenance)},
    )


def node_uncertainty(field: VolumetricMap, points: np.ndarray) -> np.ndarray | None:
    """Standard uncertainty of e per component at ``points`` (m, 3), mm — the diagonal of
    :meth:`VolumetricMap.covariance` without forming the (3m, 3m) matrix; None without a
    covariance."""
    if field.factor is None and field.node_u is None:
        return None
    idx, w = field.weights(points)
    if field.factor is not None:
        f = np.einsum("mk,mkcr->mcr", w, field.factor[idx])
        return np.sqrt(np.einsum("mcr,mcr->mc", f, f))
    var = field.node_u.reshape(-1, 3)[idx] ** 2  # (m, 8, 3)
    return np.sqrt(np.einsum("mk,mkc->mc", w**2, var))


def check_positions(limits: tuple, per_axis: int) -> np.ndarray:
    """Full-factorial check points in the box, off the nodes: ``lo + (k + 0.382)(hi − lo)/n``
    on each axis (the golden-section offset of the axis-table check)."""
    k = (np.arange(per_axis) + (3 - 5**0.5) / 2) / per_axis
    cols = [lo + (hi - lo) * k for lo, hi in limits]
    return np.stack(np.meshgrid(*cols, indexing="ij"), axis=-1).reshape(-1, 3)


def residual_grid(
    source: ParameterSet | VolumetricMap,
    machine: Machine,
    field: VolumetricMap,
    points: np.ndarray,
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """Tool-point error left after the control applies ``field`` at tool-point positions
    ``points`` (m, 3) mm (module notes).

    Returns
    -------
    r : ndarray, shape (m, 3)
        Estimated residual, mm.
    u : ndarray, shape (m, 3) or None
        Its standard uncertainty, mm.
    before : ndarray, shape (m, 3)
        The deviation δ without compensation, mm.
    """
    points = np.asarray(points, dtype=float)
    if isinstance(source, VolumetricMap):
        before = -source.error(points)
        u = node_uncertainty(source, points)
    else:
        m = source.machine_for(machine)
        cov = source.covariance
        if cov is not None:
            order = [source.names.index(n) for n in m.parameter_names]
            cov = cov[np.ix_(order, order)]
        q = _linear_readings(m, points)
        before, u = residual(m, source.vector_for(m), cov, [], q)
    return before + field.error(points), u, before


def render(field: VolumetricMap, title: str = "") -> dict:
    """File name -> text of ``volumetric_grid.csv`` (the form of
    :meth:`VolumetricMap.from_table`, sign ``error``)."""
    nodes = np.stack(np.meshgrid(*field.axes, indexing="ij"), axis=-1).reshape(-1, 3)
    e = from_internal(field.error(nodes), "µm")
    u = node_uncertainty(field, nodes)
    rows = [
        f"# mtmetrology volumetric grid {title}: x, y, z mm (nominal tool point, workpiece "
        "frame); e = P_indicated - P_true in µm: the control commands P + e(P); u in µm",
        "x,y,z,ex,ey,ez" + ("" if u is None else ",ux,uy,uz"),
    ]
    cols = [nodes, e] if u is None else [nodes, e, from_internal(u, "µm")]
    rows += [",".join(f"{v:.4f}" for v in row) for row in np.hstack(cols)]
    return {FILE: "\n".join(rows) + "\n"}


def parse(files: dict, machine: str = "") -> VolumetricMap:
    """Read ``volumetric_grid.csv`` back through :meth:`VolumetricMap.from_table` (the one
    reader of vendor grids)."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / FILE
        path.write_text(files[FILE], encoding="utf-8")
        return VolumetricMap.from_table(path, machine=machine, sign="error")
