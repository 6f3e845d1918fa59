"""Where to put the tracker: a Monte Carlo placement study (Aguado et al. (2019), Study 1).

Each trial draws a candidate tracker position uniformly in the allowed region, levels the
tracker (α = β = 0) and turns it towards the mesh centre (δ; the azimuth does not change
the point uncertainty), draws the angular noise levels u_θ, u_φ from N(20, 3) µrad
(independently, as the paper does), and evaluates at every mesh point:

- the first-order point uncertainty ``u_p`` (eq. 24, the trace of the full covariance);
- one draw of the error the tracker introduces, ``|e_i|`` (eq. 1 with the machine
  perfect).

The criterion of a candidate is the maximum (or the mean) of ``u_p`` over the mesh, at the
effective level ``√(20² + 3²)`` µrad (a property of the geometry: with the drawn levels the
minimum over candidates would pick the luckiest draw); the best pose minimises it.
Candidates inside the workspace, or seeing a mesh point beyond the range or elevation
limits, are refused and counted.

Direction of the study.  ``"x"`` places the tracker on the −X side of the workspace in the
region given (the paper's D −2000…−500, L ±2000, H 350…2000 mm); ``"y"`` places it on the
−Y side with the same stand-offs from the workspace faces (the region turned by 90° about
the vertical through the workspace centre).  The point uncertainty depends on the range and
the elevation only, so the ratio of the two studies follows from the extent of the mesh
along and across the line of sight; for the paper's mesh (400 × 400 mm in X and Y) the two
directions give the same best criterion: the paper's 30 % lower maximum along X depends on
the machine body and region it does not publish.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mtmetrology._memory import require_memory
from mtmetrology.errors import InputError, ResourceLimitError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.tracker import (
    TrackerLimits,
    TrackerNoise,
    TrackerPose,
    euler_matrix,
    spherical,
)
from mtmetrology.rng import SeedLike, as_generator
from mtmetrology.tracker.setup import measurement_points, workspace_box
from mtmetrology.units import from_internal

__all__ = ["PAPER_REGION", "PlacementStudy", "plan_placement"]

#: Allowed tracker region of the paper, (D, L, H) bounds in mm (Section 3).
PAPER_REGION = ((-2000.0, -500.0), (-2000.0, 2000.0), (350.0, 2000.0))
_CHUNK = 10_000
#: Most candidate poses one study draws: 10⁷, about 25 µs each (4 minutes); the best of 10⁴
#: (the default) is already within the criterion's noise of the optimum.
MAX_TRIALS = 10_000_000
#: Bytes kept per accepted candidate: position and yaw, criterion, largest error (float64).
_BYTES_PER_TRIAL = 6 * 8


@dataclass(frozen=True, eq=False)
class PlacementStudy:
    """Result of :func:`plan_placement` (mm).

    Attributes
    ----------
    candidates : (N, 3) ndarray
        Accepted candidate positions.
    criterion : (N,) ndarray
        Max (or mean) u_p over the mesh of each candidate.
    max_error : (N,) ndarray
        One draw of the largest tracker-introduced error over the mesh.
    best : TrackerPose
    criterion_name : str
    direction : str
    refused : int
        Candidates refused (inside the workspace or beyond the tracker's limits).
    provenance : dict
    """

    candidates: np.ndarray = field(repr=False)
    criterion: np.ndarray = field(repr=False)
    max_error: np.ndarray = field(repr=False)
    best: TrackerPose
    criterion_name: str
    direction: str
    refused: int
    provenance: dict = field(default_factory=dict)

    @property
    def best_value(self) -> float:
        return float(self.criterion.min())

    def summary(self) -> str:
        um = from_internal(1.0, "µm")
        b = self.best.to_dict()
        low = np.quantile(self.max_error, 0.05) * um
        return "\n".join(
            [
                f"tracker placement along {self.direction.upper()}: {len(self.criterion)} "
                f"candidates accepted, {self.refused} refused",
                f"  best pose D, L, H = {b['D_mm']:.0f}, {b['L_mm']:.0f}, {b['H_mm']:.0f} mm, "
                f"δ = {b['delta_deg']:.2f}°: {self.criterion_name} u_p "
                f"{self.best_value * um:.1f} µm",
                f"  largest tracker-introduced error: 5 % quantile {low:.1f} µm, median "
                f"{np.median(self.max_error) * um:.1f} µm over the candidates",
            ]
        )

    def to_dict(self) -> dict:
        um = from_internal(1.0, "µm")
        return {
            "kind": "tracker-placement",
            "version": 1,
            "direction": self.direction,
            "criterion": self.criterion_name,
            "best_pose": self.best.to_dict(),
            "best_value_um": self.best_value * um,
            "refused": self.refused,
            "candidates_mm": self.candidates.tolist(),
            "criterion_um": (self.criterion * um).tolist(),
            "max_error_um": (self.max_error * um).tolist(),
            "provenance": self.provenance,
        }

    @classmethod
    def from_dict(cls, doc: dict) -> PlacementStudy:
        mm = 1.0 / from_internal(1.0, "µm")
        return cls(
            np.asarray(doc["candidates_mm"], float),
            np.asarray(doc["criterion_um"], float) * mm,
            np.asarray(doc["max_error_um"], float) * mm,
            TrackerPose.from_dict(doc["best_pose"]),
            doc["criterion"],
            doc["direction"],
            int(doc["refused"]),
            dict(doc["provenance"]),
        )


def _positions(rng, region, direction: str, box: np.ndarray, size: int) -> np.ndarray:
    lo = np.array([r[0] for r in region])
    hi = np.array([r[1] for r in region])
    p = lo + (hi - lo) * rng.random((size, 3))
    if direction == "y":
        # same stand-off from the −Y face as from the −X face; across: about the centre
        centre = box.mean(axis=0)
        stand_off = box[0, 0] - p[:, 0]
        across = p[:, 1] - centre[1]
        p = np.column_stack([centre[0] + across, box[0, 1] - stand_off, p[:, 2]])
    return p


def plan_placement(
    machine: Machine,
    mesh: np.ndarray,
    tools: np.ndarray,
    *,
    region=PAPER_REGION,
    direction: str = "x",
    criterion: str = "max",
    trials: int = 10_000,
    noise: TrackerNoise | None = None,
    limits: TrackerLimits | None = None,
    seed: SeedLike = None,
) -> PlacementStudy:
    """Monte Carlo placement study (module notes).

    Parameters
    ----------
    machine : Machine
    mesh, tools : ndarray
        Commanded mesh (n, 3) and tool offsets (n_t, 3), mm.
    region : ((D0, D1), (L0, L1), (H0, H1))
        Allowed tracker positions, mm.
    direction : {"x", "y"}
    criterion : {"max", "mean"}
        Aggregate of u_p over the mesh.
    trials : int
        Candidate poses drawn.
    noise, limits
        Tracker noise and limits (the paper's by default).
    seed : int, optional

    Returns
    -------
    PlacementStudy

    Raises
    ------
    InputError
        Bad options, or no candidate satisfies the limits.
    ResourceLimitError
        More than :data:`MAX_TRIALS` trials or than the memory holds (before any work).
    """
    if direction not in ("x", "y"):
        raise InputError(f"--direction must be x or y, got {direction!r}")
    if criterion not in ("max", "mean"):
        raise InputError(f"--criterion must be max or mean, got {criterion!r}")
    if not isinstance(trials, int | np.integer) or trials < 1:
        raise InputError(f"--trials must be a positive integer, got {trials}")
    if trials > MAX_TRIALS:
        raise ResourceLimitError(
            f"--trials {trials}: at most {MAX_TRIALS} candidate poses (about 25 µs each: "
            f"{trials} would take about {trials * 25e-6 / 60:.3g} min)"
        )
    require_memory(
        trials * _BYTES_PER_TRIAL, f"--trials {trials}: {_BYTES_PER_TRIAL} bytes per candidate"
    )
    reg = np.asarray(region, dtype=float)
    if reg.shape != (3, 2) or not np.all(np.isfinite(reg)) or np.any(reg[:, 1] < reg[:, 0]):
        raise InputError("--region needs finite D0:D1,L0:L1,H0:H1 with lower <= upper")
    noise = noise or TrackerNoise()
    limits = limits or TrackerLimits()
    q, t = measurement_points(mesh, tools)
    points = machine.forward(q, tool=t)  # (n, 3)
    centre = points.mean(axis=0)
    box = workspace_box(machine)
    rng = as_generator(seed)
    kept_p, kept_c, kept_e = [], [], []
    refused = 0
    done = 0
    while done < trials:
        k = min(_CHUNK, trials - done)
        done += k
        pos = _positions(rng, reg, direction, box, k)
        delta = np.arctan2(centre[1] - pos[:, 1], centre[0] - pos[:, 0])
        rot = euler_matrix(np.zeros(k), np.zeros(k), delta)  # (k, 3, 3)
        p_lt = np.einsum("kni,kij->knj", points - pos[:, None, :], rot)
        s = spherical(p_lt)  # (k, n, 3)
        inside = np.all((pos >= box[0]) & (pos <= box[1]), axis=1)
        ok = np.all(limits.within(s), axis=1) & ~inside
        refused += int((~ok).sum())
        if not ok.any():
            continue
        s, pos, delta = s[ok], pos[ok], delta[ok]
        m = len(pos)
        u_el = np.maximum(rng.normal(noise.u_angle, noise.u_angle_spread, (m, 1)), 0.0)
        u_az = np.maximum(rng.normal(noise.u_angle, noise.u_angle_spread, (m, 1)), 0.0)
        # the columns of ∂(x, y, z)/∂(r, a, e) are orthogonal with norms 1, r·cos e, r:
        # u_p² = u_r² + (r cos e·u_a)² + (r·u_e)² + 3 u_SMR² (eq. 24), and one draw of the
        # introduced error has |e|² = Σ (norm_k·u_k·z_k)² plus the SMR term
        r, el = s[..., 0], s[..., 2]
        u_eff = noise.u_angle_effective
        norms = np.stack([np.ones_like(r), r * np.cos(el), r], axis=-1)
        u_p = np.sqrt(
            noise.u_range(r) ** 2 + (norms[..., 1] ** 2 + r**2) * u_eff**2 + 3 * noise.u_smr**2
        )
        ur = noise.u_range(r)
        sd = norms * np.stack(np.broadcast_arrays(ur, u_az, u_el), axis=-1)
        draw = sd * rng.standard_normal(sd.shape)
        err2 = np.einsum("mnk,mnk->mn", draw, draw)
        if noise.u_smr > 0:
            err2 = err2 + noise.u_smr**2 * rng.chisquare(3, err2.shape)
        agg = u_p.max(axis=1) if criterion == "max" else u_p.mean(axis=1)
        kept_p.append(np.column_stack([pos, delta]))
        kept_c.append(agg)
        kept_e.append(np.sqrt(err2.max(axis=1)))
    if not kept_p:
        raise InputError(
            f"no candidate pose of the {trials} drawn satisfies the tracker limits outside "
            "the workspace; check --region"
        )
    cand = np.concatenate(kept_p)
    crit = np.concatenate(kept_c)
    i = int(np.argmin(crit))
    best = TrackerPose(cand[i, :3], np.array([0.0, 0.0, cand[i, 3]]))
    return PlacementStudy(
        candidates=cand[:, :3],
        criterion=crit,
        max_error=np.concatenate(kept_e),
        best=best,
        criterion_name=criterion,
        direction=direction,
        refused=refused,
        provenance={
            "machine": machine.name,
            "region_mm": reg.tolist(),
            "trials": int(trials),
            "noise": noise.to_dict(),
            "seed": seed if isinstance(seed, int) else None,
        },
    )
