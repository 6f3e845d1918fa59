"""Sequential multilateration workflows: simulate lengths, identify the machine, check by MC.

:func:`calibrate_multilateration` solves :class:`~mtmetrology.multilateration.problem.
LengthProblem` with the identification engine (:func:`mtmetrology.identification.
levenberg_marquardt`: one least-squares core, rank diagnostics naming what the set-up cannot
see) and returns a :class:`MultilaterationResult`: the machine's error parameters with
their covariance (the GUF of the weighted least squares, (JᵀJ)⁻¹ with the weights
1/u(ℓ) of the instrument specification), the stations and dead paths, the residuals.

:func:`map_monte_carlo` checks the map uncertainty by re-solving the identification for
simulated length noise (JCGM 101:2008): every trial draws ε_ij ~ N(0, u_ij²), and is
re-solved by chord Gauss–Newton steps (:func:`mtmetrology.optimize.chord_batch`) on the
exact length geometry ‖p − S‖, with the tool point of each trial taken on the kinematic
engine's first-order expansion about the estimate p(q; θ) ≈ p(q; θ̂) + ∂p/∂θ·(θ − θ̂)
(the remainder is a product of two error motions, below 1e-9 mm for the µm-level spread
of the trials).  The map errors at the asked points follow as e = −∂p/∂θ·θ.

References
----------
JCGM 101:2008, *Evaluation of measurement data — Supplement 1 to the GUM — Propagation of
distributions using a Monte Carlo method*, 7.
Schwenke, H. et al. (2005), *CIRP Annals* 54(1), 475–478 (sequential multilateration).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from mtmetrology._memory import require_memory
from mtmetrology.errors import InputError
from mtmetrology.identification import levenberg_marquardt
from mtmetrology.identification.adequacy import ModelAdequacy, residual_patterns
from mtmetrology.identification.datum import SetupTerms, exposed_terms
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.multilateration.problem import LASERTRACER_SPEC, LengthProblem
from mtmetrology.optimize import chord_batch
from mtmetrology.rng import SeedLike, as_generator, chunk_generators
from mtmetrology.units import from_internal, to_internal

__all__ = [
    "MIN_LENGTHS_PER_STATION",
    "LengthRecord",
    "MapMonteCarlo",
    "MultilaterationResult",
    "Station",
    "calibrate_multilateration",
    "map_monte_carlo",
    "simulate_lengths",
]

#: Fewest lengths a station must see: its four unknowns and a redundancy of as many.
MIN_LENGTHS_PER_STATION = 8
#: Peak bytes a simulated length holds: its pose, reflector, station centre and dead path
#: rows (float64), the kinematic chain's temporaries on them and the written row; an upper
#: estimate (about 64 float64), for the memory check before a simulation starts.
BYTES_PER_LENGTH = 512


@dataclass(frozen=True)
class Station:
    """A tracking-interferometer station: centre (mm, workpiece frame) and dead path (mm)."""

    name: str
    position: tuple[float, float, float]
    dead_path: float = 0.0


@dataclass(frozen=True, eq=False)
class LengthRecord:
    """Lengths of a sequential multilateration (the content of LENGTHS.csv).

    Attributes
    ----------
    readings : (n, n_axes) ndarray
        Axis readings (mm, rad).
    tools : (n, 3) ndarray
        Reflector (tool) vector of each length, mm.
    stations : tuple of str
        Station id of each length.
    lengths : (n,) ndarray
        Interferometer lengths, mm.
    """

    readings: np.ndarray
    tools: np.ndarray
    stations: tuple[str, ...]
    lengths: np.ndarray


def simulate_lengths(
    machine: Machine,
    theta: np.ndarray | None,
    stations: Sequence[Station],
    readings: np.ndarray,
    tools: np.ndarray,
    *,
    spec: tuple[float, float] = LASERTRACER_SPEC,
    seed: SeedLike = None,
) -> LengthRecord:
    """Lengths every station reads at every pose and tool: ℓ = ‖p − S‖ − ℓ0 + ε.

    Parameters
    ----------
    machine : Machine
    theta : (n_params,) ndarray or None
        True errors (internal units); None for an error-free machine.
    stations : sequence of Station
    readings : (n, n_axes) ndarray
        Poses, visited by every station with every tool.
    tools : (k, 3) ndarray
        Reflector vectors (mm); each pose is measured with each.
    spec : (a, b)
        ε ~ N(0, (a + b·L)²), L the distance to the station.
    seed
        Random seed.

    Returns
    -------
    LengthRecord
        Ordered station by station, tool by tool, pose by pose.

    Raises
    ------
    ResourceLimitError
        More lengths than the memory holds (:data:`BYTES_PER_LENGTH` each), before any work.
    """
    rng = as_generator(seed)
    q = np.asarray(readings, dtype=float)
    tools = np.atleast_2d(np.asarray(tools, dtype=float))
    n_lengths = len(q) * len(tools) * len(stations)
    require_memory(
        n_lengths * BYTES_PER_LENGTH,
        f"{len(q)} poses x {len(tools)} reflectors x {len(stations)} stations: "
        f"{n_lengths} lengths x {BYTES_PER_LENGTH} bytes",
    )
    rows_q, rows_t, ids, centre, dead = [], [], [], [], []
    for s in stations:
        for t in tools:
            rows_q.append(q)
            rows_t.append(np.broadcast_to(t, (*q.shape[:1], 3)))
            ids += [s.name] * len(q)
            centre.append(np.broadcast_to(np.asarray(s.position, float), (len(q), 3)))
            dead.append(np.full(len(q), float(s.dead_path)))
    big_q, big_t = np.vstack(rows_q), np.vstack(rows_t)
    pos = machine.forward(big_q, theta, tool=big_t)
    dist = np.linalg.norm(pos - np.vstack(centre), axis=1)
    a, b = spec
    noise = rng.standard_normal(dist.size) * (a + b * dist)
    return LengthRecord(big_q, big_t, tuple(ids), dist - np.concatenate(dead) + noise)


@dataclass(frozen=True, eq=False)
class MultilaterationResult:
    """An identified machine from multilateration lengths.

    Attributes
    ----------
    parameters : ParameterSet
        Error parameters with covariance (internal units; the GUF of the least squares,
        scaled by s² when the residuals contradict the spec: :attr:`adequacy`).
    stations : tuple of Station
        Estimated station centres and dead paths.
    station_u : (n_stations, 4) ndarray
        Standard uncertainties of x, y, z, ℓ0 of each station, mm.
    spec : (a, b)
        Length uncertainty used as the weights.
    n_lengths : int
    residual_rms : float
        RMS of the unweighted length residuals, mm.
    variance_factor : float or None
        ‖r‖²/(m − n) of the weighted residuals (≈ 1 when the spec describes the noise).
    diagnostics : dict
        The identifiability report (:meth:`IdentifiabilityReport.to_dict`).
    message : str
    map_check : MapMonteCarlo or None
        The Monte Carlo check of the map uncertainty, when one was run (its document is
        ``provenance.map_monte_carlo``).
    adequacy : ModelAdequacy or None
        The engine's chi-squared test of the residuals and the covariance factor applied
        (:mod:`mtmetrology.identification.adequacy`).
    residual_patterns : dict
        RMS of the length residuals by station and by tool
        (:func:`~mtmetrology.identification.adequacy.residual_patterns`).
    setup_terms : SetupTerms
        The constants the model leaves out that the set-up exposes (added to
        ``parameters``) and those it absorbs (``provenance.setup_terms``).
    """

    parameters: ParameterSet
    stations: tuple[Station, ...]
    station_u: np.ndarray
    spec: tuple[float, float]
    n_lengths: int
    residual_rms: float
    variance_factor: float | None
    diagnostics: dict = field(repr=False)
    message: str = ""
    map_check: MapMonteCarlo | None = None
    adequacy: ModelAdequacy | None = None
    residual_patterns: dict = field(default_factory=dict, repr=False)

    @property
    def covariance_factor(self) -> float:
        """Factor the a-priori covariance was scaled by (1 when it was not)."""
        return 1.0 if self.adequacy is None else self.adequacy.factor

    setup_terms: SetupTerms = field(default_factory=SetupTerms)

    def to_dict(self) -> dict:
        """The MAP.json form: a parameter-set document whose provenance holds the set-up."""
        doc = self.parameters.to_document()
        doc["provenance"] = {
            "method": "sequential multilateration",
            "spec": {
                "a_um": float(from_internal(self.spec[0], "µm")),
                "b_um_per_m": float(from_internal(self.spec[1], "µm/m")),
                "meaning": "u(l) = a + b*L (standard uncertainty)",
            },
            "n_lengths": self.n_lengths,
            "residual_rms_um": float(from_internal(self.residual_rms, "µm")),
            "variance_factor": self.variance_factor,
            "stations": [
                {
                    "name": s.name,
                    "position_mm": list(s.position),
                    "dead_path_mm": s.dead_path,
                    "u_mm": u.tolist(),
                }
                for s, u in zip(self.stations, self.station_u, strict=True)
            ],
            "diagnostics": self.diagnostics,
            "message": self.message,
            "residual_patterns": self.residual_patterns,
            "setup_terms": self.setup_terms.to_dict(),
        }
        if self.adequacy is not None:
            doc["provenance"]["adequacy"] = self.adequacy.to_dict()
        if self.map_check is not None:
            doc["provenance"]["map_monte_carlo"] = self.map_check.to_dict()
        return doc

    @classmethod
    def from_dict(cls, doc: dict, machine: Machine, source: str = "map") -> MultilaterationResult:
        """Read :meth:`to_dict`'s form (the parameter set is validated against ``machine``)."""
        pset = ParameterSet.from_document(doc, machine, source)
        prov = pset.provenance
        if prov.get("method") != "sequential multilateration":
            raise InputError(f"{source}: not a multilateration result (provenance.method)")
        stations = tuple(
            Station(s["name"], tuple(s["position_mm"]), float(s["dead_path_mm"]))
            for s in prov["stations"]
        )
        spec = (
            float(to_internal(prov["spec"]["a_um"], "µm")),
            float(to_internal(prov["spec"]["b_um_per_m"], "µm/m")),
        )
        return cls(
            pset,
            stations,
            np.array([s["u_mm"] for s in prov["stations"]], dtype=float),
            spec,
            int(prov["n_lengths"]),
            float(to_internal(prov["residual_rms_um"], "µm")),
            prov["variance_factor"],
            prov["diagnostics"],
            prov.get("message", ""),
            adequacy=None if "adequacy" not in prov else ModelAdequacy.from_dict(prov["adequacy"]),
            residual_patterns=dict(prov.get("residual_patterns", {})),
            setup_terms=(
                SetupTerms.from_dict(prov["setup_terms"]) if "setup_terms" in prov else SetupTerms()
            ),
        )


def _check_record(machine: Machine, record: LengthRecord, spec) -> None:
    n = len(record.lengths)
    if n == 0:
        raise InputError("lengths: none given")
    ids, counts = np.unique(np.asarray(record.stations), return_counts=True)
    few = [(str(i), int(c)) for i, c in zip(ids, counts, strict=True)]
    few = [(i, c) for i, c in few if c < MIN_LENGTHS_PER_STATION]
    if few:
        name, count = few[0]
        raise InputError(
            f"station {name} sees {count} points; at least {MIN_LENGTHS_PER_STATION} are "
            "needed (its centre and dead path are 4 unknowns)"
        )
    if n < machine.n_params + 4 * ids.size + 1:
        raise InputError(
            f"{n} lengths for {machine.n_params + 4 * ids.size} unknowns "
            f"({machine.n_params} parameters, {ids.size} stations × 4): measure more points"
        )
    a, b = spec
    if not (np.isfinite(a) and np.isfinite(b) and a >= 0 and b >= 0 and a + b > 0):
        raise InputError(f"length uncertainty: a and b must be >= 0 (not both 0), got {spec}")


def calibrate_multilateration(
    machine: Machine,
    record: LengthRecord,
    *,
    spec: tuple[float, float] = LASERTRACER_SPEC,
    provenance: dict | None = None,
    adequacy: str = "scale",
) -> MultilaterationResult:
    """Identify the machine's active error parameters, the stations and dead paths.

    Parameters
    ----------
    machine : Machine
        Machine with the error model to identify (e.g. ``three-axis-xfyz``, 51
        coefficients of the 21 error functions).
    record : LengthRecord
    spec : (a, b)
        Standard uncertainty of a length u = a + b·L (mm, dimensionless); default the
        LaserTRACER NG U(k = 2) = 0.2 µm + 0.3 µm/m.
    provenance : dict, optional
        Recorded with the parameter set.
    adequacy : {"scale", "a-priori"}
        The engine's model-adequacy rule: when the residuals contradict the spec (chi-squared
        p < 0.01) the covariance is scaled by s² (``"scale"``) or kept (``"a-priori"``);
        :meth:`~mtmetrology.identification.IdentificationResult.with_adequacy`.

    Returns
    -------
    MultilaterationResult
        The parameters are the machine's and the constants the set-up exposes: a
        constant rotation of the tool-side axes moves each reflector t by ε × t, one shift
        of every point (absorbed by the station centres) with one reflector, a different
        one per reflector with several laterally offset reflectors; those the rank check
        (:func:`~mtmetrology.identification.datum.exposed_terms`) finds outside the span
        of the model's and the stations' columns are added and named
        (:attr:`MultilaterationResult.setup_terms`).

    Raises
    ------
    InputError
        Too few lengths, a station that sees too few points, a bad spec.
    RankDeficientError
        The set-up cannot see some parameters: the message names each unobservable
        combination (e.g. ``E_CZ1 (not observable)`` — the yaw of Z with the reflector on
        the spindle axis only; a second, laterally offset tool recovers it).
    """
    _check_record(machine, record, spec)

    def problem_of(m: Machine) -> LengthProblem:
        r = record
        return LengthProblem(m, r.readings, r.tools, r.stations, r.lengths, spec)

    def jacobian_of(m: Machine) -> np.ndarray:
        p = problem_of(m)
        return p.evaluate(p.initial())[1]

    stations_names = problem_of(machine).names[machine.n_params :]
    terms = exposed_terms(jacobian_of, machine, stations_names)
    if terms.added:
        machine = machine.with_parameters([*machine.parameter_names, *terms.added])
    problem = problem_of(machine)
    solved = levenberg_marquardt(problem, report_names=machine.parameter_names)
    if not solved.success:
        raise InputError(f"multilateration: the identification did not converge ({solved.message})")
    solved = solved.with_adequacy(adequacy)
    pset = solved.parameter_set(machine, provenance)
    _, centres, dead = problem.split(solved.estimate)
    u = solved.standard_uncertainty[machine.n_params :].reshape(-1, 4)
    stations = tuple(
        Station(name, tuple(float(v) for v in c), float(d))
        for name, c, d in zip(problem.station_ids, centres, dead, strict=True)
    )
    raw = solved.residuals * problem.sigma()
    tool_ids = [",".join(f"{v:g}" for v in t) for t in record.tools]
    patterns = residual_patterns(
        raw, {"station": record.stations, "tool": tool_ids}, weighted=solved.residuals
    )
    return MultilaterationResult(
        pset,
        stations,
        u,
        (float(spec[0]), float(spec[1])),
        int(raw.size),
        float(np.sqrt(np.mean(raw**2))),
        solved.variance_factor,
        solved.diagnostics.to_dict(),
        solved.message,
        adequacy=solved.adequacy,
        residual_patterns=patterns,
        setup_terms=terms,
    )


@dataclass(frozen=True, eq=False)
class MapMonteCarlo:
    """Monte Carlo check of the map uncertainty at some points.

    Attributes
    ----------
    points : (m, 3) ndarray
        Nominal positions, mm.
    u_guf : (m, 3) ndarray
        Standard uncertainty of e from the parameter covariance (GUF), mm.
    u_mcm : (m, 3) ndarray
        Standard deviation of e over the trials, mm.
    trials : int
        Trials that converged.
    failed : int
    """

    points: np.ndarray
    u_guf: np.ndarray
    u_mcm: np.ndarray
    trials: int
    failed: int

    @property
    def largest_ratio_deviation(self) -> float:
        """max |u_mcm/u_guf − 1| over the points and components."""
        return float(np.max(np.abs(self.u_mcm / self.u_guf - 1.0)))

    def to_dict(self) -> dict:
        return {
            "kind": "multilateration-map-monte-carlo",
            "version": 1,
            "points_mm": self.points.tolist(),
            "u_guf_um": from_internal(self.u_guf, "µm").tolist(),
            "u_mcm_um": from_internal(self.u_mcm, "µm").tolist(),
            "trials": self.trials,
            "failed": self.failed,
        }


def map_monte_carlo(
    machine: Machine,
    record: LengthRecord,
    result: MultilaterationResult,
    points: np.ndarray,
    *,
    trials: int = 10_000,
    seed: SeedLike = None,
    tool=None,
    block: int = 500,
    progress=None,
) -> MapMonteCarlo:
    """Re-solve the identification for simulated length noise; u of the map at ``points``.

    Parameters
    ----------
    machine : Machine
        The machine the result belongs to.
    record : LengthRecord
        The lengths identified (their positions and tools; the noise is drawn about the
        fitted lengths).
    result : MultilaterationResult
        When its covariance was scaled by the adequacy rule, the noise is drawn with the
        spec's u times s, the noise that covariance stands for.
    points : (m, 3) ndarray
        Nominal positions (mm) where the map's uncertainty is checked.
    trials : int
    seed
    tool : (3,) array_like, optional
        Tool of the map (the machine's nominal tool by default).
    block : int
        Trials re-solved at once (memory: block × lengths × 3 doubles).
    progress : callable, optional
        ``progress(done, trials)`` after each block, for a progress display; the result
        does not depend on it.

    Returns
    -------
    MapMonteCarlo
    """
    spec = result.spec
    m = result.parameters.machine_for(machine)
    problem = LengthProblem(m, record.readings, record.tools, record.stations, record.lengths, spec)
    theta = result.parameters.vector_for(m)
    x_hat = np.concatenate(
        [
            theta,
            np.column_stack(
                [
                    np.array([s.position for s in result.stations]),
                    [s.dead_path for s in result.stations],
                ]
            ).ravel(),
        ]
    )
    r_hat, jac = problem.evaluate(x_hat)
    fitted = record.lengths + r_hat * problem.sigma()  # lengths the estimate predicts
    # the noise the covariance stands for: the spec, times s when the adequacy rule scaled
    # the covariance by s² (the weights, hence the Jacobian, follow)
    scale = np.sqrt(result.covariance_factor)
    u, jac = problem.sigma() * scale, jac / scale
    ev = m.evaluate(record.readings, theta, tool=record.tools, d_params=True)
    pos0, g_rows = ev.position, ev.d_params.reshape(-1, m.n_params)  # (n, 3), (3n, p)
    p = m.n_params
    st = problem.station_index
    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    t = m.tool if tool is None else np.asarray(tool, dtype=float)
    qp = m.inverse(pts, np.zeros((len(pts), m.n_axes)), tool=t)
    gp = -m.evaluate(qp, theta, tool=t, d_params=True).d_params  # ∂e/∂θ (m, 3, p)
    cov = result.parameters.covariance
    u_guf = np.sqrt(np.einsum("mcp,pq,mcq->mc", gp, cov, gp))
    # One linear map from the change of the unknowns to (p − S_j, ℓ0_j) of every length:
    # the kinematic part on the engine's Jacobian, the station part exact (it is linear).
    n = len(st)
    lift = np.zeros((n, 4, x_hat.size))
    lift[:, :3, :p] = g_rows.reshape(n, 3, p)
    cols = p + 4 * st
    for c in range(3):
        lift[np.arange(n), c, cols + c] = -1.0
    lift[np.arange(n), 3, cols + 3] = 1.0
    lift = lift.reshape(4 * n, -1).T.copy()  # (n_unknowns, 4n)
    base = np.column_stack(
        [pos0 - x_hat[p:].reshape(-1, 4)[st, :3], x_hat[p:].reshape(-1, 4)[st, 3]]
    )
    base = base.ravel()
    samples, failed = [], 0
    gens = chunk_generators(seed, -(-trials // block))
    for k, start in enumerate(range(0, trials, block)):
        size = min(block, trials - start)
        lengths = fitted + gens[k].standard_normal((size, fitted.size)) * u

        def residuals(x, index, lengths=lengths):
            y = (base + (x - x_hat) @ lift).reshape(len(x), n, 4)
            dist = np.sqrt(np.einsum("knc,knc->kn", y[..., :3], y[..., :3]))
            return (dist - y[..., 3] - lengths[index]) / u

        # The step that meets xtol (1e-2 of the length uncertainties) is applied: what
        # remains is the chord's contraction rate (≈1e-3 here) times it.
        solved = chord_batch(
            residuals, np.tile(x_hat, (size, 1)), jac, xtol=1e-2, apply_final_step=True
        )
        ok = solved.status > 0
        failed += int((~ok).sum())
        samples.append((solved.x[ok, :p] @ gp.reshape(-1, p).T).reshape(-1, len(pts), 3))
        if progress is not None:
            progress(start + size, trials)
    e = np.concatenate(samples)
    return MapMonteCarlo(pts, u_guf, e.std(axis=0, ddof=1), int(e.shape[0]), failed)
