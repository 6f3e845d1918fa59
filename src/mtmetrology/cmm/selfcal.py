"""Probes and plate as unknowns: the source's self-calibration design and its U1, U2, U3.

Unknowns (Salacheep 2016, §4.5, Appendix 2; digest §2.5–2.12): the error parameters θ of
the machine, the pose ``(ω_l, τ_l)`` of every plate location, every ball centre ``y_i``
(the plate is self-calibrated), every stylus offset ``p_k`` and the centre ``s₀`` of the
reference sphere.  Observations, each coordinate with standard uncertainty σ::

    ball i at location l, stylus k:   x*(q; θ, p_k) − [R_l y_i + ω_l × (R_l y_i) + τ_l]
    qualification, stylus k:          x*(q; θ, p_k) − s₀

``x*`` the stylus centre of the kinematic engine (eq. 4.9 for the source's stacking).  The
rows are linearised at the nominal (θ = 0, nominal readings ``q``), where ``∂x*/∂p_k = I``.
Without further information the problem has 10 free directions, fixed by the source's
constraints ``C Δ = 0``: the pose of the first location (6: the plate frame), one
calibrated length between two balls (1: the only scale) and ``Σ_k Δp_k = 0`` (3: the
stylus centroid).  With ``Q`` an orthonormal basis of the null space of C and
``J_r = J Q``::

    V = Q (J_rᵀ J_r)⁻¹ Qᵀ                         (full covariance, J weighted by 1/σ)
    V_K = Q V_K S_K⁻² V_Kᵀ Qᵀ                       (the source's truncated SVD, K terms)

The truncated form keeps the K largest singular values of ``J_r`` in the source's units
(m and rad; the ranking depends on the units): it is finite where the full covariance is
not, and smaller, because the dropped directions are simply left out.  U1 is the mean
standard uncertainty of the ball coordinates (per axis), U2 that of the CMM error
``e = x − x*(x)`` (stylus 1) at random points in the box of the plate locations used, U3
the same in [100, 900]³ mm (the source's whole volume, 200 points).

References
----------
Salacheep, P. (2016). *Error Compensation and Uncertainty Evaluation of CMMs Based on
Kinematic Error Models and Gaussian Processes*. MPhil thesis, Brunel University London,
§4.4–4.5, Tables 4.1–4.3, Appendix 2 (constraints, null space, truncated SVD K = 36).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import null_space

from mtmetrology.cmm.notebook import CMMNotebookRepr
from mtmetrology.cmm.problem import skew
from mtmetrology.errors import InputError
from mtmetrology.identification.diagnostics import analyse_identifiability
from mtmetrology.kinematics.machine import Machine
from mtmetrology.rng import as_generator
from mtmetrology.units import from_internal

__all__ = [
    "TABLE_4_3",
    "THESIS_PROBES",
    "THESIS_TABLES",
    "SelfCalibrationDesign",
    "selfcal_design",
    "thesis_locations",
    "thesis_plate",
]

KIND = "cmm-selfcal-design"
VERSION = 1
#: The source's six styli (Appendix 2), mm.
THESIS_PROBES = {
    "P1": (0.0, 0.0, 50.0),
    "P2": (0.0, 0.0, -50.0),
    "P3": (50.0, 0.0, 0.0),
    "P4": (-50.0, 0.0, 0.0),
    "P5": (0.0, 50.0, 0.0),
    "P6": (0.0, -50.0, 0.0),
}
#: Reference sphere of the probe qualification (Appendix 2), mm.
THESIS_SPHERE = (500.0, 500.0, 500.0)
#: Published average uncertainties, µm (Tables 4.1 and 4.2): {locations: {U: (x, y, z)}}.
THESIS_TABLES = {
    "L0": {"U1": (1.2122, 0.8468, 0.3935), "U2": (1.7268, 0.7908, 0.2510),
           "U3": (0.6631, 1.8794, 0.7217)},
    "L1": {"U1": (0.2135, 0.2567, 0.2730), "U2": (0.5563, 0.3223, 0.1123),
           "U3": (0.7564, 0.6223, 0.7122)},
    "L2": {"U1": (0.2152, 0.2593, 0.2673), "U2": (0.5349, 0.3039, 0.5072),
           "U3": (0.8028, 0.7693, 0.5721)},
    "L0+L1": {"U1": (0.1123, 0.2167, 0.2535), "U2": (0.3364, 0.2122, 0.0803),
              "U3": (0.3271, 0.4123, 0.3308)},
    "L0+L1+L2": {"U1": (0.1932, 0.1283, 0.1448), "U2": (0.1306, 0.0872, 0.1162),
                 "U3": (0.2133, 0.1202, 0.1003)},
}  # fmt: skip
#: Table 4.3, µm, location 1: ``{balls per side: {U: (x, y, z)}}``.  Its prose ("as the size
#: of the ball plate reduces, [U2, U3] generally increase, but [U1] become somewhat
#: smaller") contradicts its numbers, whose 5 × 5 column is larger on every row; the pitch
#: is not stated.  Implemented reading: the labels, an n × n plate at the simulation's
#: 100 mm pitch (the 5 × 5 a 400 mm plate), at L1 with the truncated SVD of Tables 4.1–4.2
#: (tests/cmm/test_selfcal_plate_sizes.py records what that gives).
TABLE_4_3 = {
    3: {"U1": (0.2868, 0.2597, 0.2436), "U2": (0.4268, 0.2023, 0.0685),
        "U3": (0.5467, 0.5113, 0.5938)},
    5: {"U1": (0.3138, 0.3233, 0.3642), "U2": (0.4664, 0.4223, 0.1184),
        "U3": (0.7112, 0.6013, 0.6693)},
}  # fmt: skip


def thesis_plate(balls_per_side: int = 3, pitch_mm: float = 100.0) -> np.ndarray:
    """The plate's ball centres, x fastest, in plate coordinates (mm), (n², 3): an n × n
    grid at ``pitch_mm`` centred on (500, 500) (the source's 3 × 3 at 100 mm by default)."""
    g = 500.0 + pitch_mm * (np.arange(balls_per_side) - 0.5 * (balls_per_side - 1))
    n = balls_per_side
    return np.column_stack([np.tile(g, n), np.repeat(g, n), np.zeros(n * n)])


def thesis_locations() -> dict:
    """The source's plate locations (Appendix 2): ``{id: (R, t, probes)}``, ``T(y) = R y + t``.

    L0 horizontal at z = 500 mm; L1, L2 vertical on the diagonals (1, −1, 0)/√2 and
    (1, 1, 0)/√2 through the centre: with u = y_x − 500, w = y_y − 500 the ball is at
    (500 + u/√2, 500 ∓ u/√2, 500 + w).  Styli: P1, P2 at L0, P3–P6 at L1 and L2 (the
    experiment's and the code's strategies).
    """
    c = np.array([500.0, 500.0, 500.0])
    h = 1.0 / np.sqrt(2.0)
    # columns: plate x → the diagonal, plate y → +Z, plate normal = their cross product
    r1 = np.column_stack([[h, -h, 0.0], [0.0, 0.0, 1.0], [-h, -h, 0.0]])
    r2 = np.column_stack([[h, h, 0.0], [0.0, 0.0, 1.0], [h, -h, 0.0]])
    centre = np.array([500.0, 500.0, 0.0])
    return {
        "L0": (np.eye(3), c - centre, ("P1", "P2")),
        "L1": (r1, c - r1 @ centre, ("P3", "P4", "P5", "P6")),
        "L2": (r2, c - r2 @ centre, ("P3", "P4", "P5", "P6")),
    }


def _is_angle(name: str) -> bool:
    last = name.split()[-1]
    return last in ("rx", "ry", "rz") or (name.startswith("E_") and name[2] in "ABC")


@dataclass(frozen=True)
class SelfCalibrationDesign(CMMNotebookRepr):
    """Result of :func:`selfcal_design`.

    Attributes
    ----------
    locations : tuple of str
    n_unknowns, n_constraints, rank : int
        Unknowns, constraints, and the rank of the reduced Jacobian (full: n − constraints).
    truncation : int
        K of the truncated covariance.
    U_full, U_truncated : dict
        ``{"U1" | "U2" | "U3": [x, y, z]}`` in µm (k = 1, the source's "uncertainties");
        ``U_full`` is None when the design leaves directions free.
    freedoms : dict
        What each choice of constraints leaves free (the identifiability message).
    provenance : dict
    """

    locations: tuple
    n_unknowns: int
    n_constraints: int
    rank: int
    truncation: int
    U_full: dict | None
    U_truncated: dict
    freedoms: dict
    provenance: dict

    @property
    def full_rank(self) -> bool:
        return self.rank == self.n_unknowns - self.n_constraints

    def to_dict(self) -> dict:
        """File form (version 1)."""
        return {
            "kind": KIND,
            "version": VERSION,
            "locations": list(self.locations),
            "n_unknowns": self.n_unknowns,
            "n_constraints": self.n_constraints,
            "rank": self.rank,
            "full_rank": self.full_rank,
            "truncation": self.truncation,
            "U_full_um": self.U_full,
            "U_truncated_um": self.U_truncated,
            "freedoms": self.freedoms,
            "provenance": self.provenance,
        }

    @classmethod
    def from_dict(cls, doc: dict) -> SelfCalibrationDesign:
        """Read :meth:`to_dict`'s form back."""
        if doc.get("kind") != KIND or doc.get("version") != VERSION:
            raise InputError(f"self-calibration design: expected kind {KIND!r} version {VERSION}")
        return cls(
            tuple(doc["locations"]),
            int(doc["n_unknowns"]),
            int(doc["n_constraints"]),
            int(doc["rank"]),
            int(doc["truncation"]),
            doc["U_full_um"],
            doc["U_truncated_um"],
            dict(doc["freedoms"]),
            dict(doc["provenance"]),
        )


def _design_jacobian(machine, plate, locations, probes, sphere, sigma):
    """Weighted Jacobian (rows, unknowns) at the nominal and the unknowns' names."""
    p, nl, nb, npr = machine.n_params, len(locations), len(plate), len(probes)
    pids = list(probes)
    offsets = np.array([probes[k] for k in pids])
    c_pose, c_ball = p, p + 6 * nl
    c_probe, c_sphere = c_ball + 3 * nb, c_ball + 3 * nb + 3 * npr
    n = c_sphere + 3
    blocks = []
    for li, (rot, trans, styli) in enumerate(locations):
        for k in styli:
            ki = pids.index(k)
            v = plate @ rot.T  # R y_i, (nb, 3)
            q = v + trans - offsets[ki]
            j = np.zeros((nb, 3, n))
            j[:, :, :p] = machine.jacobian(q, np.zeros(p), tool=offsets[ki])
            j[:, :, c_pose + 6 * li : c_pose + 6 * li + 3] = skew(v)
            j[:, :, c_pose + 6 * li + 3 : c_pose + 6 * li + 6] = -np.eye(3)
            for i in range(nb):
                j[i, :, c_ball + 3 * i : c_ball + 3 * i + 3] = -rot
            j[:, :, c_probe + 3 * ki : c_probe + 3 * ki + 3] = np.eye(3)
            blocks.append(j.reshape(3 * nb, n))
    q = np.asarray(sphere) - offsets  # qualification: every stylus on the sphere
    j = np.zeros((npr, 3, n))
    j[:, :, :p] = machine.jacobian(q, np.zeros(p), tool=offsets)
    for ki in range(npr):
        j[ki, :, c_probe + 3 * ki : c_probe + 3 * ki + 3] = np.eye(3)
    j[:, :, c_sphere:] = -np.eye(3)
    blocks.append(j.reshape(3 * npr, n))
    names = [
        *machine.parameter_names,
        *(f"pose {i} {c}" for i in range(nl) for c in ("rx", "ry", "rz", "x", "y", "z")),
        *(f"ball {i + 1} {c}" for i in range(nb) for c in "xyz"),
        *(f"probe {k} {c}" for k in pids for c in "xyz"),
        *(f"sphere {c}" for c in "xyz"),
    ]
    return np.vstack(blocks) / sigma, names, (c_pose, c_ball, c_probe)


def _constraints(n, plate, scale_balls, cols, n_probes):
    """Rows of C by group: pose datum (6), one length (1), stylus centroid (3)."""
    c_pose, c_ball, c_probe = cols
    pose = np.zeros((6, n))
    pose[:, c_pose : c_pose + 6] = np.eye(6)
    a, b = scale_balls
    g = plate[a] - plate[b]
    g /= np.linalg.norm(g)
    length = np.zeros((1, n))
    length[0, c_ball + 3 * a : c_ball + 3 * a + 3] = g
    length[0, c_ball + 3 * b : c_ball + 3 * b + 3] = -g
    centroid = np.zeros((3, n))
    for k in range(n_probes):
        centroid[:, c_probe + 3 * k : c_probe + 3 * k + 3] = np.eye(3)
    return {"plate frame": pose, "one length": length, "stylus centroid": centroid}


def _unscaled(v_z, q, scale):
    """Covariance of the unknowns (mm, rad) from that of the null-space coordinates."""
    return scale[:, None] * (q @ v_z @ q.T) * scale[None, :]


def _mean_u(cov_blocks) -> list:
    """Mean over points of sqrt(diag) per axis, µm, from (m, 3, 3) covariances (mm²)."""
    u = np.sqrt(np.clip(np.diagonal(cov_blocks, axis1=1, axis2=2), 0.0, None))
    return [float(v) for v in from_internal(u.mean(axis=0), "µm")]


def _summaries(v, machine, plate_cols, probe1, region, volume):
    """U1, U2, U3 (µm per axis) from the covariance V of all unknowns (mm, rad)."""
    p = machine.n_params
    c_ball, nb = plate_cols
    vb = v[c_ball : c_ball + 3 * nb, c_ball : c_ball + 3 * nb]
    u1 = _mean_u(np.stack([vb[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] for i in range(nb)]))
    cols = np.r_[np.arange(p), probe1]
    sub = v[np.ix_(cols, cols)]
    out = {"U1": u1}
    for key, pts in (("U2", region), ("U3", volume)):
        jac = machine.jacobian(pts, np.zeros(p), tool=np.asarray(THESIS_PROBES["P1"]))
        je = np.concatenate([jac, np.broadcast_to(np.eye(3), (len(pts), 3, 3))], axis=2)
        out[key] = _mean_u(np.einsum("nij,jk,nlk->nil", je, sub, je))
    return out


def selfcal_design(
    machine: Machine,
    locations,
    *,
    sigma: float,
    truncation: int = 36,
    scale_balls: tuple[int, int] | None = None,
    n_points: int = 200,
    seed=0,
    balls_per_side: int = 3,
    pitch_mm: float = 100.0,
) -> SelfCalibrationDesign:
    """U1, U2, U3 of the source's self-calibration for a set of plate locations.

    Parameters
    ----------
    machine : Machine
        The CMM with its error parameters (e.g. ``examples/cmm/cmm-salacheep-xyz.yaml``).
    locations : sequence of str
        Ids of :func:`thesis_locations` (``L0``, ``L1``, ``L2``).
    sigma : float
        Standard uncertainty of one indication coordinate, mm (the source: 0.5 µm).
    truncation : int
        K of the truncated covariance (the source: 36).
    scale_balls : (int, int), optional
        Indices of the two balls whose (calibrated) distance is the only scale; by
        default the first and last ball (the diagonal: balls 1 and 9 in the source).
    n_points : int
        Random points for U2 and U3.
    seed : int or Generator
    balls_per_side, pitch_mm : int, float
        The plate (:func:`thesis_plate`): 3 and 100 mm in Tables 4.1–4.2; Table 4.3
        compares 3 × 3 with 5 × 5 without stating the pitch (see ``TABLE_4_3``).

    Returns
    -------
    SelfCalibrationDesign

    Raises
    ------
    InputError
        Unknown location id, a plate of fewer than 2 × 2 balls or a pitch that is not
        positive, or a truncation beyond the free directions.
    """
    if balls_per_side < 2 or not pitch_mm > 0:
        raise InputError(
            f"plate {balls_per_side} x {balls_per_side} at {pitch_mm} mm: needs at least "
            "2 balls per side and a positive pitch"
        )
    known = thesis_locations()
    for loc in locations:
        if loc not in known:
            raise InputError(f"location {loc!r}: use {', '.join(known)}")
    plate = thesis_plate(balls_per_side, pitch_mm)
    if scale_balls is None:
        scale_balls = (0, len(plate) - 1)
    locs = [known[loc] for loc in locations]
    jac, names, cols = _design_jacobian(machine, plate, locs, THESIS_PROBES, THESIS_SPHERE, sigma)
    n = jac.shape[1]
    groups = _constraints(n, plate, scale_balls, cols, len(THESIS_PROBES))
    c = np.vstack(list(groups.values()))
    if not 0 < truncation <= n - len(c):
        raise InputError(f"truncation {truncation}: must be in 1..{n - len(c)}")
    # the source's units (m, rad) for the ranking of the truncated SVD
    scale = np.where([_is_angle(nm) for nm in names], 1e-3, 1.0)
    q = null_space(c * scale)
    _, s, vt = np.linalg.svd(jac * scale @ q, full_matrices=False)
    rank = int(np.sum(s > s[0] * 1e-10))
    rng = as_generator(seed)
    pts = np.vstack([plate @ r.T + t for r, t, _ in locs])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    region = lo + (hi - lo) * rng.uniform(size=(n_points, 3))
    volume = 100.0 + 800.0 * rng.uniform(size=(n_points, 3))
    probe1 = cols[2] + np.arange(3)
    args = (machine, (cols[1], len(plate)), probe1, region, volume)
    vk = (vt[:truncation].T / s[:truncation] ** 2) @ vt[:truncation]
    u_trunc = _summaries(_unscaled(vk, q, scale), *args)
    u_full = None
    if rank == q.shape[1]:
        u_full = _summaries(_unscaled((vt.T / s**2) @ vt, q, scale), *args)
    machine_names = machine.parameter_names
    freedoms = {}
    for label, rows in (("no constraints", None), *((f"without {g}", g) for g in groups),
                        ("all constraints", "")):  # fmt: skip
        kept = [groups[g] for g in groups if rows is not None and g != rows]
        a = np.vstack([jac, *[k * 1e3 for k in kept]]) if kept else jac
        rep = analyse_identifiability(a, names, report_names=machine_names)
        freedoms[label] = {"free": rep.n_unknowns - rep.rank, "message": rep.message}
    prov = {
        "source": "Salacheep 2016, §4.4–4.5, Appendix 2",
        "machine": machine.name,
        "sigma_um": float(from_internal(sigma, "µm")),
        "scale_balls": [int(scale_balls[0]) + 1, int(scale_balls[1]) + 1],
        "plate": {"balls_per_side": int(balls_per_side), "pitch_mm": float(pitch_mm)},
        "points": n_points,
        "seed": seed if isinstance(seed, int) else None,
    }
    return SelfCalibrationDesign(
        tuple(locations), n, len(c), rank, truncation, u_full, u_trunc, freedoms, prov
    )
