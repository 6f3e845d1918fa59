"""Independent length check of a calibrated machine with a gauge block (or any calibrated length).

The two end faces of a calibrated length L are probed at several (B, C) indexations;
each *pair* of readings puts the stylus centre against end a and end b.  With a machine
model (nominal: all errors zero; compensated: the identified parameters) the forward
kinematics gives the stylus centres p_a, p_b in the workpiece frame, and the measured
length is the centre distance less the tip diameter (the stylus touches both faces from
outside)::

    ℓ = ‖p_b − p_a‖ − 2 r_tip,        e = ℓ − L          (Alami Mchichi (2018) eq. 6.17)

The length errors of the nominal and compensated models, their mean, RMS, standard
deviation, range and largest magnitude show what the calibration does for a measurement
(Alami Mchichi (2018) §6.5.3, Figs 6.11–6.14; Sepahi Boroujeni (2021) Table 7-1).  The
distance is Euclidean (the projection on the gauge axis differs by second order in the
lateral errors).

Thermal correction of the gauge (Alami Mchichi (2018) §6.5.3: its main explanation of the
discrepancies): a gauge calibrated at 20 °C as L₂₀ is at temperature T during the check, so
the reference is ``L_T = L₂₀ (1 + α (T − 20 °C))`` with α its expansion coefficient
(hardened steel, 10.8 µm/(m·°C)). The measurement model of the reference gives
``u²(L_T) = (1 + αΔT)² u²(L₂₀) + (L₂₀ ΔT)² u²(α) + (L₂₀ α)² u²(T)``: the sensitivity to T
is L₂₀ α, 5.4 µm/°C on 500 mm (JCGM 100:2008, 5.1.2). The tip radius may come from a
calibration on a reference sphere (:func:`mtmetrology.fitting.effective_tip_diameter`),
whose u(d_tip) enters every length.

Measurement model of the compensated length error of pair i (JCGM 100:2008, 5.1.2 and
5.2.2): the readings q_a, q_b are compensated with the calibration's estimate θ̂, whose
covariance U_θ is the calibration's, so::

    e_i = ‖p(q_b,i; θ̂) − p(q_a,i; θ̂)‖ − d_tip − L_T
    u²(e_i) = u²(L_T) + u²(d_tip) + g_i U_θ g_iᵀ,
    g_i = ∂ℓ_i/∂θ = n_iᵀ (J(q_b,i; θ̂) − J(q_a,i; θ̂)),   n_i = (p_b − p_a)/‖p_b − p_a‖

with J = ∂p/∂θ the machine's parameter Jacobian. The gauge part ``u_g² = u²(L_T) + u²(d_tip)``
is the same for every pair; the calibration part differs by pair (the indexation). The
errors of two pairs share both, ``cov(e_i, e_j) = u_g² + g_i U_θ g_jᵀ``, so their mean and
RMS are not averages of independent values. The check's own probing repeatability is not
part of u(e): the scatter of e over the pairs shows it.

READINGS CSV: ``pair,end,X,Y,Z,B,C[,S]`` (mm, degrees), ``end`` ``a`` or ``b``, one row
per end and pair.

References
----------
Alami Mchichi, N. (2018). *Étalonnage des machines-outils à cinq axes ...*. PhD thesis,
École Polytechnique de Montréal, §6.5.3, eq. 6.17.
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, Table 7-1.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mtmetrology.io.files import InputFileError
from mtmetrology.io.plausibility import (
    check_positive,
    check_scale,
    check_temperatures,
    check_uncertainty,
    checked_number,
)
from mtmetrology.io.tables import read_csv_table, write_csv_table
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.readings_table import readings_from_table
from mtmetrology.rng import SeedLike, as_generator
from mtmetrology.samba.notebook import SambaNotebookRepr
from mtmetrology.samba.records import check_travel
from mtmetrology.units import from_internal

__all__ = [
    "LengthCheck",
    "LengthReadings",
    "error_statistics",
    "length_sensitivities",
    "read_length_readings",
    "simulate_length_check",
    "simulate_length_readings",
    "thermal_reference",
    "verify_length",
]

#: Expansion coefficient of a hardened steel gauge block, 1/°C (Alami Mchichi (2018) §6.5.3).
STEEL_CTE = 10.8e-6
REFERENCE_TEMPERATURE_C = 20.0


@dataclass(frozen=True)
class ThermalReference:
    """The gauge's length at the check's temperature and its standard uncertainty (mm).

    ``sensitivities`` are ∂L_T/∂L₂₀ (1), ∂L_T/∂α (mm·°C), ∂L_T/∂T (mm/°C); ``contributions``
    the products with each input's u (mm).
    """

    length: float
    u: float
    sensitivities: dict
    contributions: dict

    def to_dict(self) -> dict:
        return {
            "length_mm": self.length,
            "u_mm": self.u,
            "sensitivities": self.sensitivities,
            "contributions_mm": self.contributions,
        }


def thermal_reference(
    length20: float,
    u_length20: float,
    temperature_c: float,
    u_temperature_c: float,
    cte: float = STEEL_CTE,
    u_cte: float = 0.0,
) -> ThermalReference:
    """Reference length of a gauge at temperature T (module notes).

    Parameters
    ----------
    length20, u_length20 : float
        Calibrated length at 20 °C and its standard uncertainty, mm.
    temperature_c, u_temperature_c : float
        Gauge temperature during the check and its standard uncertainty, °C.
    cte, u_cte : float
        Expansion coefficient and its standard uncertainty, 1/°C; a positive α lengthens
        the gauge above 20 °C.

    Returns
    -------
    ThermalReference
        ``L_T = L₂₀ (1 + α (T − 20))`` and ``u(L_T)`` by the law of propagation.

    Raises
    ------
    InputError
        A length not > 0, a temperature outside −50 to 100 °C, a negative uncertainty or
        a non-finite input (each named by its option).

    References
    ----------
    Alami Mchichi (2018), §6.5.3; JCGM 100:2008, 5.1.2.

    Examples
    --------
    >>> r = thermal_reference(500.0, 0.00025, 21.0, 1.0)
    >>> round(r.length, 6), round(r.sensitivities["temperature"] * 1e3, 3)
    (500.0054, 5.4)
    """
    check_positive(length20, "--length")
    check_uncertainty(u_length20, "--u-length", "mm")
    check_temperatures(temperature_c, "--temperature-c")
    check_uncertainty(u_temperature_c, "--u-temperature-c", "°C")
    checked_number(cte, "--cte")
    check_uncertainty(u_cte, "--u-cte")
    dt = temperature_c - REFERENCE_TEMPERATURE_C
    sens = {"length20": 1.0 + cte * dt, "cte": length20 * dt, "temperature": length20 * cte}
    contrib = {
        "length20": sens["length20"] * u_length20,
        "cte": sens["cte"] * u_cte,
        "temperature": sens["temperature"] * u_temperature_c,
    }
    u = float(np.sqrt(sum(c**2 for c in contrib.values())))
    return ThermalReference(length20 * (1.0 + cte * dt), u, sens, contrib)


@dataclass(frozen=True, eq=False)
class LengthReadings:
    """Pairs of readings on the two ends of a calibrated length (internal units)."""

    pairs: tuple[str, ...]
    end_a: np.ndarray = field(repr=False)  # (n, n_axes)
    end_b: np.ndarray = field(repr=False)  # (n, n_axes)

    def __len__(self) -> int:
        return len(self.pairs)


def read_length_readings(path: str | Path, machine: Machine) -> LengthReadings:
    """Read ``pair,end,X,Y,Z,B,C[,S]``; every pair needs exactly one ``a`` and one ``b`` row.

    Raises
    ------
    InputFileError
        A missing column, NaN, an end other than a/b, a pair without both ends, a
        reading outside the travel.
    """
    table = read_csv_table(path, required=["pair", "end"])
    q = readings_from_table(machine, table)
    ends = table.strings("end")
    pairs = table.strings("pair")
    index: dict[str, dict[str, int]] = {}
    for i, (p, e) in enumerate(zip(pairs, ends, strict=True)):
        if e not in ("a", "b"):
            raise InputFileError(
                f"{table.path}, line {table.lines[i]}: end must be 'a' or 'b', got {e!r}"
            )
        if e in index.setdefault(p, {}):
            raise InputFileError(
                f"{table.path}, line {table.lines[i]}: pair {p!r} has end {e} twice"
            )
        index[p][e] = i
    for p, e in index.items():
        if set(e) != {"a", "b"}:
            missing = "b" if "a" in e else "a"
            line = table.lines[next(iter(e.values()))]
            raise InputFileError(f"{table.path}, line {line}: pair {p!r} has no end {missing}")
    names = tuple(index)
    return LengthReadings(
        names,
        q[[index[p]["a"] for p in names]],
        q[[index[p]["b"] for p in names]],
    )


def error_statistics(errors: np.ndarray) -> dict:
    """Mean, RMS, standard deviation, range and largest magnitude of length errors (µm)."""
    e = from_internal(np.asarray(errors, dtype=float), "µm")
    return {
        "mean": float(e.mean()),
        "rms": float(np.sqrt(np.mean(e**2))),
        "std": float(e.std(ddof=1)) if e.size > 1 else 0.0,
        "range": float(e.max() - e.min()),
        "max_abs": float(np.abs(e).max()),
    }


@dataclass(frozen=True, eq=False)
class LengthCheck(SambaNotebookRepr):
    """Result of :func:`verify_length` (internal units: mm).

    Attributes
    ----------
    pairs : tuple of str
    length, u_length, tip_radius : float
        Calibrated length, its standard uncertainty (or None) and the tip radius, mm.
    nominal, compensated : (n,) ndarray
        Measured lengths with the nominal and the compensated model, mm.
    thermal : ThermalReference or None
    u_tip_diameter : float or None
    u_calibration : (n,) ndarray or None
        ``sqrt(g_i U_θ g_iᵀ)`` of each pair's compensated length (module notes), mm; None
        without the calibration's covariance.
    machine : str or None
        The machine's name: the document then says what it is (``machine``, ``category``
        "verification") for the calibration history.
    """

    pairs: tuple[str, ...]
    length: float
    u_length: float | None
    tip_radius: float
    nominal: np.ndarray = field(repr=False)
    compensated: np.ndarray = field(repr=False)
    thermal: ThermalReference | None = None
    u_tip_diameter: float | None = None
    u_calibration: np.ndarray | None = field(default=None, repr=False)
    machine: str | None = None

    @property
    def reference_length(self) -> float:
        """L_T of the thermal correction, else the calibrated length, mm."""
        return self.length if self.thermal is None else self.thermal.length

    @property
    def u_gauge(self) -> float | None:
        """The gauge's part of u(e), the same for every pair: ``sqrt(u²(L_T) + u²(d_tip))``,
        mm; None when neither is stated."""
        parts = [self.u_length if self.thermal is None else self.thermal.u, self.u_tip_diameter]
        known = [p for p in parts if p is not None]
        return float(np.sqrt(sum(p**2 for p in known))) if known else None

    @property
    def u_error(self) -> np.ndarray | None:
        """u(e_i) of each compensated length error, ``sqrt(u_g² + g_i U_θ g_iᵀ)`` (module
        notes), mm, shape (n,); None when neither the gauge's u nor U_θ is known."""
        if self.u_gauge is None and self.u_calibration is None:
            return None
        gauge = 0.0 if self.u_gauge is None else self.u_gauge
        calibration = 0.0 if self.u_calibration is None else self.u_calibration
        return np.sqrt(gauge**2 + calibration**2) * np.ones(len(self.pairs))

    @property
    def errors_nominal(self) -> np.ndarray:
        return self.nominal - self.reference_length

    @property
    def errors_compensated(self) -> np.ndarray:
        return self.compensated - self.reference_length

    def to_dict(self) -> dict:
        """The ``length-check`` document: per pair and summary statistics, µm.

        ``u_gauge_um`` is the gauge's part of u(e); each pair's ``u_calibration_um`` and
        ``u_error_um`` (None when unknown) and ``u_error_max_um``, the largest, include the
        calibration's U_θ when ``calibration_in_u`` is true.
        """
        en = from_internal(self.errors_nominal, "µm")
        ec = from_internal(self.errors_compensated, "µm")

        def um(values, i):
            return None if values is None else float(from_internal(values[i], "µm"))

        u_error = self.u_error
        said = {} if self.machine is None else {"machine": self.machine, "category": "verification"}
        return {
            "kind": "length-check",
            "version": 1,
            **said,
            "length_mm": self.length,
            "u_length_mm": self.u_length,
            "tip_radius_mm": self.tip_radius,
            "u_tip_diameter_mm": self.u_tip_diameter,
            "thermal": None if self.thermal is None else self.thermal.to_dict(),
            "reference_length_mm": self.reference_length,
            "u_gauge_um": None
            if self.u_gauge is None
            else float(from_internal(self.u_gauge, "µm")),
            "calibration_in_u": self.u_calibration is not None,
            "u_error_max_um": None
            if u_error is None
            else float(from_internal(u_error.max(), "µm")),
            "pairs": [
                {
                    "pair": p,
                    "length_nominal_mm": float(self.nominal[i]),
                    "length_compensated_mm": float(self.compensated[i]),
                    "error_nominal_um": float(en[i]),
                    "error_compensated_um": float(ec[i]),
                    "u_calibration_um": um(self.u_calibration, i),
                    "u_error_um": um(u_error, i),
                }
                for i, p in enumerate(self.pairs)
            ],
            "nominal": error_statistics(self.errors_nominal),
            "compensated": error_statistics(self.errors_compensated),
        }


def verify_length(
    machine: Machine,
    params: np.ndarray | None,
    readings: LengthReadings,
    length: float,
    *,
    tip_radius: float,
    u_length: float | None = None,
    thermal: ThermalReference | None = None,
    u_tip_diameter: float | None = None,
    parameter_covariance: np.ndarray | None = None,
) -> LengthCheck:
    """Length errors of the nominal and the compensated machine model, with u(e).

    Measurement model (module notes): ``e_i = ℓ_i(θ̂) − L_T`` and
    ``u²(e_i) = u²(L_T) + u²(d_tip) + g_i U_θ g_iᵀ`` with ``g_i = ∂ℓ_i/∂θ`` at θ̂ from the
    machine's parameter Jacobian (JCGM 100:2008, 5.1.2; Alami Mchichi (2018) eq. 6.17).

    Parameters
    ----------
    machine : Machine
        With the error model of ``params`` active.
    params : (n_params,) ndarray or None
        Identified errors (internal units); None: only the nominal model (both equal).
    readings : LengthReadings
    length : float
        Calibrated length L, mm.
    tip_radius : float
        Effective stylus tip radius, mm.
    u_length : float, optional
        Standard uncertainty of L, mm (reported).
    thermal : ThermalReference, optional
        The gauge's length at the check's temperature (:func:`thermal_reference`): the
        errors are taken against it and its u replaces ``u_length``.
    u_tip_diameter : float, optional
        Standard uncertainty of the effective tip diameter (from a reference-sphere
        calibration), mm.
    parameter_covariance : (n_params, n_params) ndarray, optional
        U_θ of ``params`` (internal units, ``machine.parameter_names`` order): the
        calibration that compensated the readings. None: u(e) holds the gauge alone and
        the document says so (``calibration_in_u`` false).

    Returns
    -------
    LengthCheck

    Raises
    ------
    InputFileError
        A length that is not positive, a negative tip radius, a covariance without
        ``params`` or of the wrong shape.

    Examples
    --------
    >>> m = Machine.load("five-axis-wcbxfzyst", "13")
    >>> q = m.readings_from_customary(
    ...     {"X": [[0.0, 100.0]], "Y": [[0.0, 0.0]], "Z": [[0.0, 0.0]], "B": 0.0, "C": 0.0})
    >>> r = LengthReadings(("1",), q[:, 0], q[:, 1])
    >>> chk = verify_length(m, None, r, 94.0, tip_radius=3.0)
    >>> float(chk.errors_nominal[0])
    0.0
    """
    if not (length > 0 and np.isfinite(length)):
        raise InputFileError(f"--length: the calibrated length must be > 0 mm, got {length}")
    if not (tip_radius >= 0 and np.isfinite(tip_radius)):
        raise InputFileError(f"the tip radius must be >= 0, got {tip_radius}")

    def lengths(theta):
        pa = machine.forward(readings.end_a, theta)
        pb = machine.forward(readings.end_b, theta)
        return np.linalg.norm(pb - pa, axis=-1) - 2.0 * tip_radius

    nominal = lengths(None)
    # a length in m or µm is 10³ off what the machine reads between the ends
    check_scale(length, float(np.mean(np.abs(nominal))), "--length",
                against="the mean nominal length the readings show")  # fmt: skip
    compensated = nominal if params is None else lengths(params)
    u_calibration = None
    if parameter_covariance is not None:
        if params is None:
            raise InputFileError("a parameter covariance needs the parameters it belongs to")
        u_theta = np.asarray(parameter_covariance, dtype=float)
        if u_theta.shape != (machine.n_params, machine.n_params):
            raise InputFileError(
                f"the parameter covariance must be {machine.n_params}x{machine.n_params} "
                f"(the machine's parameters), got {u_theta.shape}"
            )
        g = length_sensitivities(machine, params, readings)
        u_calibration = np.sqrt(np.maximum(np.einsum("ip,pq,iq->i", g, u_theta, g), 0.0))
    return LengthCheck(
        readings.pairs,
        float(length),
        u_length,
        float(tip_radius),
        nominal,
        compensated,
        thermal,
        u_tip_diameter,
        u_calibration,
        machine=machine.name,
    )


def length_sensitivities(
    machine: Machine, params: np.ndarray, readings: LengthReadings
) -> np.ndarray:
    """G: ∂ℓ_i/∂θ of each pair's compensated length, shape (n_pairs, n_params).

    ``g_i = n_iᵀ (J(q_b,i; θ) − J(q_a,i; θ))`` with ``n_i`` the unit vector from the
    stylus centre at end a to the one at end b and J = ∂p/∂θ (:meth:`Machine.jacobian`);
    the tip diameter does not depend on θ. mm per internal parameter unit.
    """
    pa = machine.evaluate(readings.end_a, params, d_params=True)
    pb = machine.evaluate(readings.end_b, params, d_params=True)
    d = pb.position - pa.position
    n = d / np.linalg.norm(d, axis=-1, keepdims=True)
    return np.einsum("ik,ikp->ip", n, pb.d_params - pa.d_params)


def simulate_length_readings(
    machine: Machine,
    truth: np.ndarray | None,
    end_a,
    end_b,
    pairs_deg,
    *,
    tip_radius: float,
    noise: float = 0.0,
    seed: SeedLike = None,
) -> tuple[tuple[str, ...], np.ndarray]:
    """Readings of a virtual length check: header and rows ``pair,end,X,Y,Z,B,C[,S]``.

    Parameters
    ----------
    machine : Machine
    truth : (n_params,) ndarray or None
        True errors (internal units).
    end_a, end_b : (3,) array_like
        Centres of the two end faces in the workpiece frame, mm.
    pairs_deg : sequence of (B, C)
        Indexations, degrees.
    tip_radius : float
        Stylus tip radius, mm: the stylus centre stands off each face by it.
    noise : float
        Standard deviation of each linear reading, mm.
    seed : int, SeedSequence or Generator

    Returns
    -------
    header : tuple of str
    rows : (2·n_pairs, n_axes) ndarray
        Customary readings (mm, degrees) in the order pair 1 a, pair 1 b, ...
    """
    a, b = np.asarray(end_a, dtype=float), np.asarray(end_b, dtype=float)
    e = (b - a) / np.linalg.norm(b - a)
    targets = np.array([a - tip_radius * e, b + tip_radius * e])  # stylus centres
    bc = np.asarray(pairs_deg, dtype=float)
    values = {"B": np.repeat(bc[:, 0], 2), "C": np.repeat(bc[:, 1], 2)}
    values.update({ax: np.zeros(2 * len(bc)) for ax in machine.linear_axes})
    start = machine.readings_from_customary(values)
    q = machine.inverse(np.tile(targets, (len(bc), 1)), start, truth)
    linear = [i for i, ax in enumerate(machine.axis_names) if ax in machine.linear_axes]
    q[:, linear] += noise * as_generator(seed).standard_normal((q.shape[0], len(linear)))
    check_travel(machine, q, lambda i: f"pair {i // 2 + 1}")
    return ("pair", "end", *machine.axis_names), machine.readings_to_customary(q)


@dataclass(frozen=True, eq=False)
class SimulatedLengthCheck:
    """Customary readings of a virtual length check (:func:`simulate_length_check`).

    Attributes
    ----------
    header : tuple of str
        ``pair, end`` and the axis names.
    rows : (2·n_pairs, n_axes) ndarray
        Readings (mm, degrees): pair 1 end a, pair 1 end b, ...
    """

    header: tuple[str, ...]
    rows: np.ndarray

    @property
    def pairs(self) -> int:
        return len(self.rows) // 2

    def lines(self) -> list[list[str]]:
        """The CSV rows ``pair,end,<readings to 6 decimals>`` that ``mtm length verify``
        reads."""
        return [
            [str(k // 2 + 1), "ab"[k % 2], *(f"{v:.6f}" for v in row)]
            for k, row in enumerate(self.rows)
        ]

    def write(self, path: str | Path) -> None:
        """Write READINGS.csv (atomically)."""
        write_csv_table(path, self.header, self.lines())

    def to_dict(self) -> dict:
        """The readings as a document (the CSV's header and rows)."""
        return {
            "kind": "length-check-readings",
            "version": 1,
            "header": list(self.header),
            "rows": [[float(v) for v in row] for row in self.rows],
        }


def simulate_length_check(
    machine: Machine,
    truth: np.ndarray | None,
    end_a,
    end_b,
    *,
    pairs: int = 20,
    b_max_deg: float = 45.0,
    noise: float = 0.0,
    seed: SeedLike = None,
) -> SimulatedLengthCheck:
    """A gauge-block length check on a virtual machine at random indexations.

    ``pairs`` indexations B ~ U(−b_max, b_max), C ~ U(0, 360) degrees are drawn from
    ``seed``; the same generator then draws the reading noise
    (:func:`simulate_length_readings`, the stylus tip radius the machine's).

    Parameters
    ----------
    machine : Machine
    truth : (n_params,) ndarray or None
        True errors (internal units).
    end_a, end_b : (3,) array_like
        End-face centres in the workpiece frame, mm.
    pairs : int
        Number of (B, C) indexations, at least 1.
    b_max_deg : float
        Largest |B|, degrees.
    noise : float
        Standard deviation of each linear reading, mm.
    seed : int, SeedSequence or Generator

    Returns
    -------
    SimulatedLengthCheck
    """
    if pairs < 1:
        raise InputFileError(f"--pairs must be at least 1, got {pairs}")
    rng = as_generator(seed)
    bc = np.column_stack([rng.uniform(-b_max_deg, b_max_deg, pairs), rng.uniform(0, 360, pairs)])
    header, rows = simulate_length_readings(
        machine, truth, end_a, end_b, bc, tip_radius=machine.tip_radius, noise=noise, seed=rng
    )
    return SimulatedLengthCheck(header, rows)
