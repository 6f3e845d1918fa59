"""VDI/VDE 2617-11 budget of on-machine feature measurements with a volumetric error map.

Mutilba et al. (seed 003, Section 3) replace the calibrated workpiece of ISO 15530-3 by
a volumetric error map taken just before the measurement.  For every feature measured in
one or more cycles (contact points, stylus centres, indicated positions P):

1. correct every point with the map: P_true = P − e(P) (:class:`VolumetricMap`, e the
   error of indication);
2. fit the feature to the original and to the corrected points (the fitting library's
   least-squares features) and take b = F(corrected) − F(original) per characteristic
   (diameter, roundness, X/Y position, flatness ...);
3. u_b = |b| (the systematic error is not corrected: ``uncorrected``, the paper's way), or
   the corrected result F(corrected) is reported and u_b is the uncertainty of the
   correction, from the map covariance (``corrected``; u_cal is then inside u_b);
4. u_p = the sample standard deviation of F over the cycles (Eq. 3; or the largest over
   series, ISO 15530-3 usage);
5. u_cal = the map uncertainty propagated to F: GUF u² = J Σ_e Jᵀ with J = ∂F/∂P at the
   corrected points and Σ_e the map covariance at the points, or a Monte Carlo of the map
   (draws of e from the same covariance, refit of every draw);
6. a probe systematic error enters in quadrature above 1 µm (small machine) or 3 µm
   (large machine);
7. u_MS = √(u_b² + u_p² + u_cal² + u_probe²), U_MS = k·u_MS (Eqs. 1–2 as Table 1
   computes them; :func:`mtmetrology.budgets.iso15530.combine`).

References
----------
VDI/VDE 2617-11:2011. *Accuracy of coordinate measuring machines — Characteristics and
their testing — Determination of the uncertainty of measurement for measurements on CMMs
using uncertainty budgets.*
Mutilba, U. et al. (seed 003), Section 3, Eqs. 1–5, Table 1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from mtmetrology._memory import require_memory
from mtmetrology.budgets.choices import FEATURE_KINDS
from mtmetrology.budgets.iso15530 import (
    Policy,
    RepeatabilityMethod,
    budget_output,
    combine,
    probe_contribution,
    repeatability,
)
from mtmetrology.errors import InputError
from mtmetrology.fitting import (
    BallCentre,
    CircleCentre,
    CircleDiameter,
    CylinderDiameter,
    Cylindricity,
    Flatness,
    GaugeLength,
    Roundness,
    SphereDiameter,
    Sphericity,
)
from mtmetrology.formatting import format_uncertainty
from mtmetrology.io.plausibility import check_within
from mtmetrology.kinematics.volumetric_map import VolumetricMap
from mtmetrology.rng import SeedLike, as_generator
from mtmetrology.uncertainty.conformity import Tolerance, decide
from mtmetrology.units import from_internal, to_internal

__all__ = [
    "CharacteristicBudget",
    "VolumetricMapBudget",
    "characteristics",
    "load_map",
    "map_for_points",
    "volumetric_map_budget",
]

BUDGET_KIND = "volumetric-map-budget"
_VERSION = 1
MODES = ("uncorrected", "corrected")


@dataclass(frozen=True)
class _MeanPoint:
    """Position of a probed point (the mean of its repeated contacts), x, y, z."""

    name: str = "position"
    unit: str = "mm"
    min_points: ClassVar[int] = 1

    @property
    def output_names(self) -> tuple[str, ...]:
        return ("position_x", "position_y", "position_z")

    def value(self, points) -> np.ndarray:
        return np.asarray(points, dtype=float).mean(axis=-2)

    def jacobian(self, points) -> np.ndarray:
        n = np.asarray(points).shape[0]
        return np.tile(np.eye(3), (1, n)) / n


def characteristics(kind: str, *, inner: bool = True, tip_diameter: float = 0.0) -> list:
    """The characteristics of a feature kind: ``[(name, feature, output index), ...]``.

    circle: diameter, roundness, X and Y position of the centre; plane: flatness;
    sphere: diameter, sphericity, X, Y, Z position; cylinder: diameter, cylindricity;
    length: the distance of two points less the tip diameter; position: X, Y, Z.
    """
    if kind == "circle":
        d = CircleDiameter(inner=inner, tip_diameter=tip_diameter)
        c = CircleCentre()
        return [("diameter", d, 0), ("roundness", Roundness(), 0), ("X position", c, 0),
                ("Y position", c, 1)]  # fmt: skip
    if kind == "plane":
        return [("flatness", Flatness(), 0)]
    if kind == "sphere":
        d = SphereDiameter(inner=inner, tip_diameter=tip_diameter)
        c = BallCentre()
        return [("diameter", d, 0), ("sphericity", Sphericity(), 0), ("X position", c, 0),
                ("Y position", c, 1), ("Z position", c, 2)]  # fmt: skip
    if kind == "cylinder":
        return [
            ("diameter", CylinderDiameter(inner=inner, tip_diameter=tip_diameter), 0),
            ("cylindricity", Cylindricity(), 0),
        ]
    if kind == "length":
        return [("length", GaugeLength(tip_diameter=tip_diameter), 0)]
    if kind == "position":
        p = _MeanPoint()
        return [("X position", p, 0), ("Y position", p, 1), ("Z position", p, 2)]
    raise InputError(f"--feature: one of {', '.join(FEATURE_KINDS)}, got {kind!r}")


def _values(chars, points: np.ndarray) -> np.ndarray:
    """Characteristics of point sets (..., n, 3) -> (..., k); each feature fitted once."""
    cache: dict[int, np.ndarray] = {}
    out = []
    for _, feature, index in chars:
        key = id(feature)
        if key not in cache:
            cache[key] = np.asarray(feature.value(points), dtype=float)
        v = cache[key]
        out.append(v if len(feature.output_names) == 1 else v[..., index])
    return np.stack(out, axis=-1)


def _jacobian(chars, points: np.ndarray) -> np.ndarray:
    """∂F/∂P (k, 3n) at one point set."""
    rows, cache = [], {}
    for _, feature, index in chars:
        key = id(feature)
        if key not in cache:
            cache[key] = np.atleast_2d(feature.jacobian(points))
        rows.append(cache[key][index])
    return np.array(rows)


@dataclass(frozen=True)
class CharacteristicBudget:
    """One row of the budget (lengths in mm), in the layout of Mutilba et al., Table 1.

    Attributes
    ----------
    name : str
    original, corrected : float
        F of the original and of the map-corrected points (mean over the cycles).
    b : float
        corrected − original.
    u_b, u_p, u_cal, u_probe : float
        Contributions; u_b = |b| (uncorrected) or the map uncertainty of the
        correction (corrected, then u_cal = 0: it is inside u_b).
    u, U : float
        u_MS and U_MS.
    result : float
        The reported value: original (uncorrected) or corrected.
    """

    name: str
    original: float
    corrected: float
    b: float
    u_b: float
    u_p: float
    u_cal: float
    u_probe: float
    u: float
    U: float
    result: float

    def to_dict(self) -> dict:
        um = {k: float(from_internal(getattr(self, k), "µm")) for k in
              ("b", "u_b", "u_p", "u_cal", "u_probe", "u", "U")}  # fmt: skip
        return {**{k: getattr(self, k) for k in self.__dataclass_fields__}, "um": um}

    @classmethod
    def from_dict(cls, doc: dict) -> CharacteristicBudget:
        return cls(**{k: doc[k] for k in cls.__dataclass_fields__})


@dataclass(frozen=True)
class VolumetricMapBudget:
    """A feature's VDI/VDE 2617-11 budget with a volumetric map (module notes).

    Attributes
    ----------
    feature : str
        Feature kind.
    rows : tuple of CharacteristicBudget
    mode : {"uncorrected", "corrected"}
    u_cal_method : {"guf", "mc"}
    trials : int
        Monte Carlo trials of the map (0 for the GUF).
    cycles : int
    n_points : int
        Points per cycle.
    repeatability_method : RepeatabilityMethod
    k : float
    machine : str
    largest_correction : float
        Largest |e| over the points, mm (for the plausibility of the map).
    provenance : dict
    """

    feature: str
    rows: tuple[CharacteristicBudget, ...]
    mode: str
    u_cal_method: str
    trials: int
    cycles: int
    n_points: int
    repeatability_method: RepeatabilityMethod
    k: float
    machine: str
    largest_correction: float
    provenance: dict = field(default_factory=dict)
    tolerances: dict = field(default_factory=dict)

    def decisions(self) -> dict:
        """ISO 14253-1 decision of each toleranced characteristic: result ± U_MS."""
        return {
            name: decide(self.row(name).result, self.row(name).U, tol, unit="mm")
            for name, tol in self.tolerances.items()
        }

    def row(self, name: str) -> CharacteristicBudget:
        """The row of characteristic ``name``."""
        for r in self.rows:
            if r.name == name:
                return r
        raise KeyError(name)

    def table(self) -> list[list[str]]:
        """Rows in the layout of Table 1 (µm, two significant digits, JCGM 100 7.2.6):
        characteristic, u_b, u_p, u_cal, u_MS, U_MS."""
        out = []
        for r in self.rows:
            d = r.to_dict()["um"]
            cells = (format_uncertainty(d[c]) for c in ("u_b", "u_p", "u_cal", "u", "U"))
            out.append([r.name, *cells])
        return out

    def to_dict(self) -> dict:
        return {
            "kind": BUDGET_KIND,
            "version": _VERSION,
            "feature": self.feature,
            "mode": self.mode,
            "u_cal_method": self.u_cal_method,
            "trials": self.trials,
            "cycles": self.cycles,
            "n_points": self.n_points,
            "repeatability_method": self.repeatability_method.value,
            "k": self.k,
            "machine": self.machine,
            "largest_correction_um": float(from_internal(self.largest_correction, "µm")),
            "unit": "mm",
            "rows": [r.to_dict() for r in self.rows],
            "outputs": [
                budget_output(r.name, r.result, r.u, r.U, self.k).to_dict() for r in self.rows
            ],
            "decisions": {n: d.to_dict() for n, d in self.decisions().items()},
            "provenance": dict(self.provenance),
        }

    @classmethod
    def from_dict(cls, doc: dict) -> VolumetricMapBudget:
        if doc.get("kind") != BUDGET_KIND or doc.get("version") != _VERSION:
            raise InputError(f"budget: expected kind {BUDGET_KIND!r} version {_VERSION}")
        return cls(
            doc["feature"],
            tuple(CharacteristicBudget.from_dict(r) for r in doc["rows"]),
            doc["mode"],
            doc["u_cal_method"],
            int(doc["trials"]),
            int(doc["cycles"]),
            int(doc["n_points"]),
            RepeatabilityMethod(doc["repeatability_method"]),
            float(doc["k"]),
            doc["machine"],
            float(to_internal(doc["largest_correction_um"], "µm")),
            dict(doc.get("provenance", {})),
            {
                name: Tolerance(
                    d["tolerance"]["nominal"],
                    d["tolerance"]["lower_deviation"],
                    d["tolerance"]["upper_deviation"],
                )
                for name, d in doc.get("decisions", {}).items()
            },
        )


def map_for_points(machine, params, points: np.ndarray, spacing: float = 10.0) -> VolumetricMap:
    """The map of an identified model on a grid covering ``points`` (1 mm margin).

    Nodes every ``spacing`` mm at most (10 mm: the trilinear interpolation error of the
    cubic error functions of a medium machine is far below 1 nm there).
    """
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    low, high = p.min(axis=0) - 1.0, p.max(axis=0) + 1.0
    counts = [max(2, math.ceil((hi - lo) / spacing) + 1) for lo, hi in zip(low, high, strict=True)]
    # each node holds its error and its sensitivities to every parameter (float64)
    require_memory(
        math.prod(counts) * 3 * (machine.n_params + 1) * 8,
        f"a map of {' x '.join(map(str, counts))} nodes over the points",
    )
    grid = tuple(np.linspace(lo, hi, n) for lo, hi, n in zip(low, high, counts, strict=True))
    return VolumetricMap.from_parameters(machine, params, grid)


#: Overrun of the points beyond an axis travel, as a share of the travel (a stylus, the
#: probing direction): beyond it the identified error functions would be extrapolated.
TRAVEL_MARGIN = 0.05


def check_in_travel(machine, points: np.ndarray, where) -> None:
    """Refuse points whose readings (nominal inverse kinematics, the machine's tool) leave
    a linear axis travel by more than :data:`TRAVEL_MARGIN` of it: the model's error
    functions are identified over the travel only.  ``where(i)`` names point i.

    Raises
    ------
    InputError
        The first point outside, its axis and the travel named.
    """
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    q = machine.inverse(p, np.zeros((len(p), machine.n_axes)), tool=machine.tool)
    for k, a in enumerate(machine.axis_names):
        travel = machine.axes[a].travel
        if travel is None or not machine.axes[a].linear:
            continue
        low, high = travel
        check_within(
            q[:, k],
            low,
            high,
            lambda i, a=a: f"{where(i)}: its reading {a}",
            margin=TRAVEL_MARGIN * (high - low),
            what=f"travel of {a} of {machine.name}",
        )


def _sqrt_psd(cov: np.ndarray) -> np.ndarray:
    w, v = np.linalg.eigh(cov)
    return v * np.sqrt(np.clip(w, 0.0, None))


def load_map(machine, path, points: np.ndarray, where=None) -> VolumetricMap:
    """The volumetric map of a file: a ``volumetric-map`` document as it is, or a parameter
    set (with its covariance) mapped on a grid covering ``points`` (:func:`map_for_points`).

    Parameters
    ----------
    machine : Machine
        The machine the parameter set belongs to.
    path : path
        The map or the parameter set (JSON/YAML).
    points : (N, 3) array
        Points the map must cover, mm.
    where : callable, optional
        ``where(i)`` names point i in a refusal (its file and line).

    Returns
    -------
    VolumetricMap

    Raises
    ------
    InputError
        A point outside the travel (a parameter set is not extrapolated).
    ResourceLimitError
        A map over the points larger than the memory holds.
    """
    from mtmetrology.io.documents import load_document
    from mtmetrology.kinematics.parameter_set import ParameterSet
    from mtmetrology.kinematics.volumetric_map import MAP_KIND

    doc = load_document(path, "map or parameter set")
    if isinstance(doc, dict) and doc.get("kind") == MAP_KIND:
        return VolumetricMap.from_dict(doc, str(path))
    pset = ParameterSet.from_document(doc, machine, str(path))
    check_in_travel(machine, points, where or (lambda i: f"points: point {i + 1}"))
    return map_for_points(machine, pset, points)


def volumetric_map_budget(
    points: np.ndarray,
    vmap: VolumetricMap,
    kind: str,
    *,
    cycles: np.ndarray | None = None,
    series: np.ndarray | None = None,
    machine: str | None = None,
    mode: str = "uncorrected",
    repeatability_method: RepeatabilityMethod | str = RepeatabilityMethod.SAMPLE,
    u_p: float | None = None,
    repeats: tuple | None = None,
    u_cal_method: str = "guf",
    trials: int = 2000,
    seed: SeedLike = None,
    probe_error: float = 0.0,
    machine_class: str = "small",
    k: float = 2.0,
    inner: bool = True,
    tip_diameter: float = 0.0,
    tolerances: dict | None = None,
    provenance: dict | None = None,
) -> VolumetricMapBudget:
    """Budget of one feature's characteristics with a volumetric map (module notes).

    Parameters
    ----------
    points : (N, 3) ndarray
        Indicated contact (stylus-centre) points, mm, all cycles.
    vmap : VolumetricMap
        The map of the machine, taken before the measurement.
    kind : str
        One of :data:`FEATURE_KINDS`.
    cycles : (N,) array, optional
        Cycle label of each point (every cycle the same number of points); one cycle
        without it.
    series : (N,) array, optional
        Series label of each point, for ``max-over-series`` (constant within a cycle).
    machine : str, optional
        Name of the machine measured: a map of another machine is refused.
    mode : {"uncorrected", "corrected"}
    repeatability_method : RepeatabilityMethod
    u_p : float, optional
        A repeatability given (mm) instead of the cycles' (needed with one cycle).
    repeats : (names, values, series or None), optional
        Repeated results of the characteristics from other cycles (e.g. the on-machine
        software's, over the temperature range of the scenario): u_p of each
        characteristic from its values, by ``repeatability_method``.
    u_cal_method : {"guf", "mc"}
    trials, seed
        Monte Carlo of the map (``mc``).
    probe_error, machine_class
        Probe systematic error (mm) and the machine class of its threshold.
    k : float
    inner, tip_diameter
        Sizes: bore (inner) or shaft, effective tip diameter (mm).
    tolerances : dict of str to Tolerance, optional
        Specifications of characteristics by name: the budget takes the ISO 14253-1
        decision of each (:meth:`VolumetricMapBudget.decisions`).

    Returns
    -------
    VolumetricMapBudget

    Raises
    ------
    InputError
        Too few points for the feature, a map of another machine, a point outside the
        map, unequal cycles, one cycle without ``u_p``, a negative uncertainty.
    """
    if machine is not None and vmap.machine and vmap.machine != machine:
        raise InputError(f"map: made for machine {vmap.machine!r}, not {machine!r}")
    if mode not in MODES:
        raise InputError(f"mode: one of {', '.join(MODES)}, got {mode!r}")
    if u_cal_method not in ("guf", "mc"):
        raise InputError(f"u_cal method: 'guf' or 'mc', got {u_cal_method!r}")
    if u_cal_method == "mc":
        # the draws of the map at every point of a cycle (3 coordinates) and the points
        # displaced by them, with the temporaries of the fit: about 4 such arrays
        n_points = np.asarray(points).size
        require_memory(
            4 * 8 * int(trials) * n_points,
            f"--trials {trials}: map draws at {n_points // 3} points",
        )
    if u_p is not None and not (math.isfinite(u_p) and u_p >= 0):
        raise InputError(f"u_p: must be >= 0, got {u_p}")
    chars = characteristics(kind, inner=inner, tip_diameter=tip_diameter)
    p = np.asarray(points, dtype=float)
    labels = np.zeros(len(p), dtype=int) if cycles is None else np.asarray(cycles)
    order = list(dict.fromkeys(labels.tolist()))
    sets = [p[labels == c] for c in order]
    n = len(sets[0])
    if any(len(s) != n for s in sets):
        raise InputError("points: every cycle must probe the same number of points")
    need = max(f.min_points for _, f, _ in chars)
    if kind == "length" and n != 2:
        raise InputError(f"feature length: 2 points per cycle, got {n}")
    if n < need:
        raise InputError(f"feature {kind}: {n} points per cycle, at least {need} needed")
    stack = np.stack(sets)  # (C, n, 3)
    corrected = vmap.correct(stack)
    try:
        original_f = _values(chars, stack)  # (C, k)
        corrected_f = _values(chars, corrected)
    except ValueError as err:  # the fitting library's refusal (collinear points ...)
        raise InputError(f"feature {kind}: {err}") from None
    if u_p is not None and repeats is not None:
        raise InputError("u_p: give a value or repeated results, not both")
    if u_p is not None:
        ups = np.full(len(chars), float(u_p))
    elif repeats is not None:
        names, values, rseries = (None if a is None else np.asarray(a) for a in repeats)
        ups = []
        for name, _, _ in chars:
            sel = names == name
            if not sel.any():
                raise InputError(
                    f"repeats: no values of characteristic {name!r} (the feature has "
                    f"{', '.join(c[0] for c in chars)})"
                )
            part = None if rseries is None else rseries[sel]
            ups.append(repeatability(values[sel], part, repeatability_method))
        ups = np.array(ups)
    else:
        if len(sets) < 2:
            raise InputError(
                "u_p: one measurement cycle; give repeated cycles (column 'cycle') or u_p"
            )
        series_per_cycle = None
        if series is not None:
            s = np.asarray(series)
            series_per_cycle = np.array([s[labels == c][0] for c in order])
        ups = np.array(
            [
                repeatability(original_f[:, j], series_per_cycle, repeatability_method)
                for j in range(len(chars))
            ]
        )
    # map uncertainty at the first cycle's points, propagated to the characteristics
    first = stack[0]
    cov_e = vmap.covariance(first)
    if u_cal_method == "guf":
        jac = _jacobian(chars, corrected[0])
        u_map = np.sqrt(np.clip(np.einsum("ki,ij,kj->k", jac, cov_e, jac), 0.0, None))
        used_trials = 0
    else:
        root = _sqrt_psd(cov_e)
        draws = as_generator(seed).standard_normal((trials, root.shape[1])) @ root.T
        trial_points = corrected[0][None] - draws.reshape(trials, n, 3)
        u_map = _values(chars, trial_points).std(axis=0, ddof=1)
        used_trials = trials
    u_probe = probe_contribution(probe_error, machine_class)
    rows = []
    for j, (name, _, _) in enumerate(chars):
        orig = float(original_f[:, j].mean())
        corr = float(corrected_f[:, j].mean())
        b = corr - orig
        if mode == "uncorrected":
            u_b, u_cal = abs(b), float(u_map[j])
            u, big = combine(Policy.PAPER_003, b=b, u_p=ups[j], u_cal=u_cal, u_probe=u_probe, k=k)
            result = orig
        else:
            u_b, u_cal = float(u_map[j]), 0.0
            u, big = combine(
                Policy.ISO_2011, b=b, u_p=ups[j], u_cal=0.0, u_b=u_b, u_probe=u_probe, k=k
            )
            result = corr
        rows.append(
            CharacteristicBudget(
                name, orig, corr, b, u_b, float(ups[j]), u_cal, u_probe, u, big, result
            )
        )
    tolerances = dict(tolerances or {})
    unknown = sorted(set(tolerances) - {c[0] for c in chars})
    if unknown:
        raise InputError(
            f"tolerance: {unknown[0]!r} is not a characteristic of a {kind} "
            f"({', '.join(c[0] for c in chars)})"
        )
    e = vmap.error(stack.reshape(-1, 3))
    return VolumetricMapBudget(
        kind,
        tuple(rows),
        mode,
        u_cal_method,
        used_trials,
        len(sets),
        n,
        RepeatabilityMethod(repeatability_method),
        float(k),
        vmap.machine,
        float(np.linalg.norm(e, axis=1).max()),
        dict(provenance or {}),
        tolerances,
    )
