"""Volumetric grid: tool-point corrections on a grid over the linear axes, with u.

For controls that take a 3-D table: at each node ``(X_i, Y_j, Z_k)`` of a rectilinear grid
of linear-axis readings (rotary axes at zero) the correction vector ``c = −e(q)`` (the
kinematic chain's tool-point error, mm) and its standard uncertainty per component
``sqrt(diag(J U Jᵀ))``; between nodes the control interpolates trilinearly per cell.

The writer takes anything with the small :class:`VectorField` interface (grid lines,
vectors, u), so a measured volumetric map plugs in as well as a parameter set.

File (``volumetric_grid.csv``, :doc:`file-formats`): ``//`` comment lines, then a header
``X,Y,Z,cx,cy,cz,ux,uy,uz`` and one row per node, X varying slowest; positions in mm,
corrections and uncertainties in µm.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.export.control import residual
from mtmetrology.export.model import CompensationModel
from mtmetrology.units import from_internal, to_internal

__all__ = [
    "VectorField",
    "VolumetricGrid",
    "grid_from_model",
    "grid_lines",
    "parse",
    "render",
    "residual_grid",
    "trilinear",
]

NAME = "grid"
_AXES = ("X", "Y", "Z")
_HEADER = "X,Y,Z,cx,cy,cz,ux,uy,uz"


class VectorField(Protocol):
    """What the grid writer needs: grid lines (mm), vectors and u (mm), (nx, ny, nz, 3)."""

    lines: tuple[np.ndarray, np.ndarray, np.ndarray]
    vectors: np.ndarray
    u: np.ndarray | None


@dataclass(frozen=True)
class VolumetricGrid:
    """Correction vectors on a rectilinear grid (implements :class:`VectorField`)."""

    lines: tuple[np.ndarray, np.ndarray, np.ndarray]
    vectors: np.ndarray
    u: np.ndarray | None = None


def grid_from_model(
    model: CompensationModel, lines: tuple[np.ndarray, np.ndarray, np.ndarray]
) -> VolumetricGrid:
    """Corrections of the model's machine at the grid nodes (rotary axes at zero).

    Parameters
    ----------
    model : CompensationModel
    lines : three ndarrays
        Grid lines of X, Y, Z readings, mm, ascending, within the travel.

    Raises
    ------
    InputError
        The machine lacks a linear axis, or a grid line leaves the travel.
    """
    m = model.machine
    missing = [a for a in _AXES if a not in m.axis_names]
    if missing:
        raise InputError(
            f"grid: {m.name} has no {missing[0]} axis; a volumetric grid needs X, Y, Z"
        )
    for a, line in zip(_AXES, lines, strict=True):
        lo, hi = m.axes[a].travel
        line = np.asarray(line, dtype=float)
        if line.size < 2 or np.any(np.diff(line) <= 0):
            raise InputError(f"grid: {a} lines must be ascending, two at least")
        if line[0] < lo - 1e-9 or line[-1] > hi + 1e-9:
            raise InputError(
                f"grid: {a} from {line[0]:g} to {line[-1]:g} mm is outside the travel of {a} "
                f"[{lo:g}, {hi:g}] mm"
            )
    mesh = np.meshgrid(*lines, indexing="ij")
    q = np.zeros((mesh[0].size, m.n_axes))
    for a, g in zip(_AXES, mesh, strict=True):
        q[:, m.axis_names.index(a)] = g.ravel()
    p = model.parameters
    cov = None
    if p.covariance is not None:
        order = [p.names.index(n) for n in m.parameter_names]
        cov = p.covariance[np.ix_(order, order)]
    e, u = residual(m, model.theta, cov, [], q)
    shape = (*mesh[0].shape, 3)
    return VolumetricGrid(
        tuple(np.asarray(x, dtype=float) for x in lines),
        -e.reshape(shape),
        None if u is None else u.reshape(shape),
    )


def grid_lines(model: CompensationModel, pitch=None, points=None, region=None) -> tuple:
    """Grid lines of X, Y, Z: equally spaced from the region's start (travel by default) at
    ``pitch`` mm, the region's end added; or ``points`` per axis."""
    out = []
    for a in _AXES:
        if a not in model.machine.axis_names:
            raise InputError(f"grid: {model.machine.name} has no {a} axis; a grid needs X, Y, Z")
        lo, hi = (region or {}).get(a, model.machine.axes[a].travel)
        if not hi > lo:
            raise InputError(f"region: {a} from {lo:g} to {hi:g} mm is empty")
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


def residual_grid(model: CompensationModel, field: VectorField, readings: np.ndarray):
    """Tool-point error left after the control shifts X, Y, Z by the trilinear correction:
    ``r = e(q) + ∂p/∂(x, y, z) · c(q)``, and its u (identification), mm."""
    m = model.machine
    p = model.parameters
    cov = None
    if p.covariance is not None:
        order = [p.names.index(n) for n in m.parameter_names]
        cov = p.covariance[np.ix_(order, order)]
    e, u = residual(m, model.theta, cov, [], readings)
    cols = [m.axis_names.index(a) for a in _AXES]
    shift = m.axis_jacobian(readings)[:, :, cols]
    c = trilinear(field, readings[:, cols])
    return e + np.einsum("nij,nj->ni", shift, c), u


def trilinear(field: VectorField, points: np.ndarray) -> np.ndarray:
    """Trilinear interpolation of the field's vectors at ``points`` (N, 3) mm; the end
    cells are extended (values held) beyond the grid."""
    points = np.asarray(points, dtype=float)
    idx, w = [], []
    for k, line in enumerate(field.lines):
        i = np.clip(np.searchsorted(line, points[:, k], side="right") - 1, 0, line.size - 2)
        t = np.clip((points[:, k] - line[i]) / (line[i + 1] - line[i]), 0.0, 1.0)
        idx.append(i)
        w.append(t)
    out = np.zeros((points.shape[0], 3))
    for dx in (0, 1):
        for dy in (0, 1):
            for dz in (0, 1):
                weight = (
                    (w[0] if dx else 1 - w[0])
                    * (w[1] if dy else 1 - w[1])
                    * (w[2] if dz else 1 - w[2])
                )
                out += weight[:, None] * field.vectors[idx[0] + dx, idx[1] + dy, idx[2] + dz]
    return out


def render(field: VectorField, title: str = "") -> dict:
    """File name -> text of ``volumetric_grid.csv``."""
    mesh = np.meshgrid(*field.lines, indexing="ij")
    xyz = np.stack([g.ravel() for g in mesh], axis=-1)
    c = from_internal(field.vectors.reshape(-1, 3), "µm")
    u = np.full_like(c, np.nan) if field.u is None else from_internal(field.u.reshape(-1, 3), "µm")
    rows = [
        f"// mtmetrology volumetric grid {title}: X, Y, Z mm; corrections c and u in µm",
        _HEADER,
    ]
    rows += [
        ",".join([*(f"{v:.4f}" for v in p), *(f"{v:.4f}" for v in cc), *(f"{v:.4f}" for v in uu)])
        for p, cc, uu in zip(xyz, c, u, strict=True)
    ]
    return {"volumetric_grid.csv": "\n".join(rows) + "\n"}


def parse(files: dict) -> VolumetricGrid:
    """Read ``volumetric_grid.csv`` back (inverse of :func:`render`)."""
    lines = [s for s in files["volumetric_grid.csv"].splitlines() if not s.startswith("//")]
    if not lines or lines[0].strip() != _HEADER:
        raise InputError(f"volumetric_grid.csv: header must be {_HEADER}")
    try:
        a = np.array([[float(v) for v in s.split(",")] for s in lines[1:]])
    except ValueError:
        raise InputError("volumetric_grid.csv: a value is not a number") from None
    grid_lines = tuple(np.unique(a[:, k]) for k in range(3))
    shape = tuple(g.size for g in grid_lines)
    if int(np.prod(shape)) != a.shape[0]:
        raise InputError("volumetric_grid.csv: the nodes do not form a full rectilinear grid")
    vectors = to_internal(a[:, 3:6], "µm").reshape(*shape, 3)
    u = to_internal(a[:, 6:9], "µm").reshape(*shape, 3)
    return VolumetricGrid(grid_lines, vectors, None if np.isnan(u).all() else u)
