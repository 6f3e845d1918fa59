"""A volumetric error map: a gridded field of error vectors with its covariance.

A map is made from an identified error model of a machine (:meth:`VolumetricMap.from_parameters`)
or read from a vendor's grid (:meth:`VolumetricMap.from_table`).  It is evaluated anywhere
inside its grid by trilinear interpolation, so that a controller table and a point
correction use the same field.

Sign convention
---------------
The map holds, at every nominal (indicated) tool-point position P of the workpiece frame,
the **error of indication** (JCGM 200:2012, 2.16: measured value minus reference value)

    e(P) = P_indicated − P_true = −δ(q),     δ(q) = p(q; θ) − p(q; 0),

where δ is the ISO 230-1 deviation of the tool point (actual minus nominal position,
error motions of the tool relative to the workpiece) at the readings q that indicate P.
A point probed on the machine is corrected by

    P_true = P_meas − e(P_meas).

The values may be stored as the correction c(P) = −e(P) = δ(q) instead (``sign =
"correction"``, the quantity a controller adds to its command in the opposite sense);
:meth:`VolumetricMap.error` and :meth:`VolumetricMap.correction` always return e and c.

Covariance
----------
The grid values' covariance is kept either as a factor F (node, component, r) with
cov(e_i, e_j) = F_i F_jᵀ (a map from an identified model: F = −(∂p/∂θ)·L with
Σ_θ = L Lᵀ) or as independent standard uncertainties per node and component (a vendor
grid).  Interpolation is linear in the node values, so the covariance at any points is
exact under the interpolation: cov(e(P_a), e(P_b)) = Σ w_a,i w_b,j cov(e_i, e_j).

References
----------
ISO 230-1:2012, 3.1 (error motions) and Annex (volumetric errors).
ISO/TR 16907:2015, *Machine tools — Numerical compensation of geometric errors*.
JCGM 200:2012, *International vocabulary of metrology*, 2.16 (measurement error).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.io import read_csv_table
from mtmetrology.units import from_internal, to_internal

__all__ = ["MAP_KIND", "VolumetricMap"]

MAP_KIND = "volumetric-map"
_VERSION = 1
_SIGNS = ("error", "correction")


def _axis(values, name: str) -> np.ndarray:
    a = np.asarray(values, dtype=float).ravel()
    if a.size < 2 or not np.all(np.isfinite(a)) or np.any(np.diff(a) <= 0):
        raise InputError(f"grid {name}: needs at least 2 strictly increasing finite nodes")
    return a


@dataclass(frozen=True, eq=False)
class VolumetricMap:
    """Error vectors on a rectilinear grid of nominal tool-point positions (mm).

    Attributes
    ----------
    axes : tuple of three (n_k,) ndarray
        Grid nodes along x, y, z of the workpiece frame (mm), strictly increasing.
    values : (nx, ny, nz, 3) ndarray
        Stored vectors (mm): the error of indication e, or the correction −e (``sign``).
    sign : {"error", "correction"}
        What ``values`` holds (module notes).
    machine : str
        Name of the machine the map belongs to.
    model : str or None
        Error model it was computed with.
    tool : (3,) ndarray
        Tool vector (mm) the map holds for (angular errors make e depend on it).
    reference : (3,) ndarray or None
        Nominal position at which the map is referred to zero error (None: the model's
        own reference, the axis reference points).
    factor : (nx·ny·nz, 3, r) ndarray or None
        Covariance factor of the node errors e (mm).
    node_u : (nx, ny, nz, 3) ndarray or None
        Independent standard uncertainties of the node values (mm), when no factor.
    provenance : dict
    """

    axes: tuple[np.ndarray, np.ndarray, np.ndarray]
    values: np.ndarray
    sign: str = "error"
    machine: str = ""
    model: str | None = None
    tool: np.ndarray = field(default_factory=lambda: np.zeros(3))
    reference: np.ndarray | None = None
    factor: np.ndarray | None = None
    node_u: np.ndarray | None = None
    provenance: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        axes = tuple(_axis(a, n) for a, n in zip(self.axes, "xyz", strict=True))
        object.__setattr__(self, "axes", axes)
        shape = (*tuple(a.size for a in axes), 3)
        values = np.asarray(self.values, dtype=float)
        if values.shape != shape:
            raise InputError(f"map values: shape {values.shape}, the grid needs {shape}")
        object.__setattr__(self, "values", values)
        if self.sign not in _SIGNS:
            raise InputError(f"map sign: 'error' or 'correction', got {self.sign!r}")
        object.__setattr__(self, "tool", np.asarray(self.tool, dtype=float))
        if self.factor is not None and self.node_u is not None:
            raise InputError("map covariance: give a factor or node uncertainties, not both")
        if self.node_u is not None and np.any(np.asarray(self.node_u) < 0):
            raise InputError("map node uncertainties: must be >= 0")

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_parameters(
        cls,
        machine,
        params,
        grid: tuple,
        *,
        tool=None,
        reference=None,
        sign: str = "error",
    ) -> VolumetricMap:
        """The map of an identified error model on a grid of nominal positions.

        Parameters
        ----------
        machine : Machine
            A machine whose axes are all linear (the nominal chain is affine).
        params : ParameterSet
            Identified errors (and their covariance, if any) of ``machine``.
        grid : tuple of three array_like
            Nodes along x, y, z of the workpiece frame (mm).
        tool : (3,) array_like, optional
            Tool vector (mm); the machine's nominal tool by default.
        reference : (3,) array_like, optional
            Nominal position whose error is subtracted from every node (and whose
            covariance is propagated with it).
        sign : {"error", "correction"}
            What the stored values hold.

        Returns
        -------
        VolumetricMap
            e(P) = p(q; 0) − p(q; θ) at q = the nominal inverse of P, with factor
            F = −(∂p/∂θ)·L, Σ_θ = L Lᵀ (eigen-factor, positive semi-definite).
        """
        linear = all(machine.axes[a].linear for a in machine.axis_names)
        if not linear:
            raise InputError(
                f"volumetric map: machine {machine.name} has rotary axes; a map over the "
                "volume needs a machine with linear axes only"
            )
        params.check_machine(machine, "parameters")
        m = params.machine_for(machine)
        theta = params.vector_for(m)
        axes = tuple(_axis(a, n) for a, n in zip(grid, "xyz", strict=True))
        nodes = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        if reference is not None:
            nodes = np.vstack([nodes, np.asarray(reference, dtype=float)[None, :]])
        t = m.tool if tool is None else np.asarray(tool, dtype=float)
        q = m.inverse(nodes, np.zeros((len(nodes), m.n_axes)), tool=t)
        ev = m.evaluate(q, theta, tool=t, d_params=True)
        error = m.forward(q, tool=t) - ev.position  # e = nominal − actual
        sens = -ev.d_params  # ∂e/∂θ
        if reference is not None:
            error = error[:-1] - error[-1]
            sens = sens[:-1] - sens[-1]
        factor = None
        if params.covariance is not None:
            w, v = np.linalg.eigh(params.covariance)
            root = v * np.sqrt(np.clip(w, 0.0, None))
            factor = sens @ root
        shape = (*tuple(a.size for a in axes), 3)
        values = error.reshape(shape)
        return cls(
            axes,
            values if sign == "error" else -values,
            sign=sign,
            machine=machine.name,
            model=params.model,
            tool=t,
            reference=None if reference is None else np.asarray(reference, dtype=float),
            factor=factor,
            provenance={"from": "parameters", **dict(params.provenance or {})},
        )

    @classmethod
    def from_table(
        cls, path, *, machine: str, sign: str = "error", tool=(0.0, 0.0, 0.0)
    ) -> VolumetricMap:
        """A vendor grid: CSV ``x,y,z`` (mm), ``ex,ey,ez`` (µm)[, ``ux,uy,uz`` (µm)].

        Every node of a rectilinear grid must be present once (any row order).  ``sign``
        says whether ``ex, ey, ez`` are errors of indication or corrections.

        Raises
        ------
        InputFileError
            Missing column, non-number; InputError: incomplete or repeated nodes,
            negative uncertainty.
        """
        table = read_csv_table(path, required=["x", "y", "z", "ex", "ey", "ez"], min_rows=8)
        xyz = np.column_stack([table.floats(c) for c in "xyz"])
        vec = to_internal(np.column_stack([table.floats(f"e{c}") for c in "xyz"]), "µm")
        axes = tuple(np.unique(xyz[:, k]) for k in range(3))
        shape = tuple(a.size for a in axes)
        if int(np.prod(shape)) != len(table):
            raise InputError(
                f"{path}: {len(table)} rows do not form a full {shape[0]}x{shape[1]}x"
                f"{shape[2]} grid (one row per node)"
            )
        idx = [np.searchsorted(axes[k], xyz[:, k]) for k in range(3)]
        flat = np.ravel_multi_index(idx, shape)
        if np.unique(flat).size != flat.size:
            raise InputError(f"{path}: a grid node is listed twice")
        values = np.empty((int(np.prod(shape)), 3))
        values[flat] = vec
        node_u = None
        if all(table.has(f"u{c}") for c in "xyz"):
            u = np.column_stack([table.floats(f"u{c}") for c in "xyz"])
            bad = np.flatnonzero((u < 0).any(axis=1))
            if bad.size:
                raise InputError(f"{path}, line {table.lines[bad[0]]}: uncertainty must be >= 0")
            node_u = np.empty_like(values)
            node_u[flat] = to_internal(u, "µm")
            node_u = node_u.reshape((*shape, 3))
        return cls(
            axes,
            values.reshape((*shape, 3)),
            sign=sign,
            machine=machine,
            tool=np.asarray(tool, dtype=float),
            node_u=node_u,
            provenance={"from": str(path)},
        )

    # ------------------------------------------------------------------ evaluation
    @property
    def shape(self) -> tuple[int, int, int]:
        return tuple(a.size for a in self.axes)

    def weights(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Trilinear interpolation: node indices (m, 8) and weights (m, 8) of each point.

        Raises
        ------
        InputError
            A point outside the grid (the map does not extrapolate).
        """
        p = np.asarray(points, dtype=float).reshape(-1, 3)
        cells, fracs = [], []
        for k, a in enumerate(self.axes):
            slack = 1e-9 * max(1.0, abs(a[0]), abs(a[-1]))
            outside = (p[:, k] < a[0] - slack) | (p[:, k] > a[-1] + slack)
            if outside.any():
                i = int(np.flatnonzero(outside)[0])
                raise InputError(
                    f"point {i} ({', '.join(f'{v:g}' for v in p[i])}) mm is outside the map's "
                    f"grid along {'xyz'[k]} [{a[0]:g}, {a[-1]:g}] mm"
                )
            c = np.clip(np.searchsorted(a, p[:, k], side="right") - 1, 0, a.size - 2)
            cells.append(c)
            fracs.append(np.clip((p[:, k] - a[c]) / (a[c + 1] - a[c]), 0.0, 1.0))
        corners = np.array(np.meshgrid([0, 1], [0, 1], [0, 1], indexing="ij")).reshape(3, 8)
        idx = np.ravel_multi_index(
            tuple(cells[k][:, None] + corners[k][None, :] for k in range(3)), self.shape
        )
        w = np.ones((len(p), 8))
        for k in range(3):
            w *= np.where(corners[k][None, :] == 1, fracs[k][:, None], 1.0 - fracs[k][:, None])
        return idx, w

    def _stored(self, points) -> np.ndarray:
        idx, w = self.weights(points)
        flat = self.values.reshape(-1, 3)
        out = np.einsum("mk,mkc->mc", w, flat[idx])
        return out.reshape(np.shape(points))

    def error(self, points) -> np.ndarray:
        """e(P) = P_indicated − P_true at nominal positions ``points`` (..., 3), mm."""
        v = self._stored(points)
        return v if self.sign == "error" else -v

    def evaluate(self, points) -> np.ndarray:
        """Alias of :meth:`error` (the map's error of indication at ``points``)."""
        return self.error(points)

    def correction(self, points) -> np.ndarray:
        """c(P) = −e(P): what is added to an indicated position to get the true one."""
        return -self.error(points)

    def correct(self, points) -> np.ndarray:
        """P_true = P_meas − e(P_meas) for measured points (..., 3), mm."""
        p = np.asarray(points, dtype=float)
        return p - self.error(p)

    def covariance(self, points) -> np.ndarray:
        """Covariance (3m, 3m) of e at ``points`` (m, 3), ordered point by point (mm²).

        Zero when the map has no covariance.
        """
        idx, w = self.weights(points)
        m = len(idx)
        if self.factor is not None:
            f = np.einsum("mk,mkcr->mcr", w, self.factor[idx]).reshape(3 * m, -1)
            return f @ f.T
        if self.node_u is None:
            return np.zeros((3 * m, 3 * m))
        var = self.node_u.reshape(-1, 3) ** 2
        # Same nodes shared by two points: Σ_k w_a,k w_b,k u_k² per component.
        n = var.shape[0]
        dense = np.zeros((m, n))
        np.add.at(dense, (np.repeat(np.arange(m), 8), idx.ravel()), w.ravel())
        out = np.zeros((3 * m, 3 * m))
        for c in range(3):
            out[c::3, c::3] = (dense * var[:, c]) @ dense.T
        return out

    def standard_uncertainty(self, points) -> np.ndarray:
        """u of each component of e at ``points`` (m, 3), mm."""
        return np.sqrt(np.clip(np.diag(self.covariance(points)), 0, None)).reshape(-1, 3)

    # ------------------------------------------------------------------ files
    def to_dict(self) -> dict:
        """JSON form: nodes in mm, vectors and uncertainties in µm (C order x, y, z)."""
        um = lambda a: from_internal(np.asarray(a), "µm").tolist()  # noqa: E731
        doc = {
            "kind": MAP_KIND,
            "version": _VERSION,
            "machine": self.machine,
            "model": self.model,
            "sign": self.sign,
            "convention": "e = P_indicated - P_true; P_true = P_meas - e(P_meas)",
            "unit": "µm",
            "tool_mm": self.tool.tolist(),
            "reference_mm": None if self.reference is None else self.reference.tolist(),
            "grid_mm": {c: a.tolist() for c, a in zip("xyz", self.axes, strict=True)},
            "values": um(self.values.reshape(-1, 3)),
            "covariance_factor": None if self.factor is None else um(self.factor),
            "node_u": None if self.node_u is None else um(self.node_u.reshape(-1, 3)),
            "provenance": dict(self.provenance),
        }
        return doc

    @classmethod
    def from_dict(cls, doc: dict, source: str = "map") -> VolumetricMap:
        """Read :meth:`to_dict`'s form back.

        Raises
        ------
        InputError
            Not a map document, or an unsupported version (message names ``source``).
        """
        if not isinstance(doc, dict) or doc.get("kind") != MAP_KIND:
            raise InputError(f"{source}: kind must be {MAP_KIND!r}")
        if doc.get("version") != _VERSION:
            raise InputError(f"{source}: version {doc.get('version')!r} is not {_VERSION}")
        axes = tuple(np.asarray(doc["grid_mm"][c], dtype=float) for c in "xyz")
        shape = tuple(a.size for a in axes)
        mm = lambda a: to_internal(np.asarray(a, dtype=float), "µm")  # noqa: E731
        factor = doc.get("covariance_factor")
        node_u = doc.get("node_u")
        ref = doc.get("reference_mm")
        return cls(
            axes,
            mm(doc["values"]).reshape((*shape, 3)),
            sign=doc["sign"],
            machine=doc["machine"],
            model=doc.get("model"),
            tool=np.asarray(doc["tool_mm"], dtype=float),
            reference=None if ref is None else np.asarray(ref, dtype=float),
            factor=None if factor is None else mm(factor),
            node_u=None if node_u is None else mm(node_u).reshape((*shape, 3)),
            provenance=dict(doc.get("provenance", {})),
        )
