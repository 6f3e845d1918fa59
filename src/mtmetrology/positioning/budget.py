"""Uncertainty of the ISO 230-2 parameters from the laser measurement (ISO/TR 230-9 style).

Measurement model.  At a target a distance L from the laser datum, the corrected deviation
(:mod:`mtmetrology.positioning.environment`) errs by

    e(L) = L·δ_las + L·(n̂/n − 1) − L·[α (t_m − 20) − α̂ (t̂_m − 20)] + δ_cos(L) + δ_dead
           + δ_set + δ_EVE

with the inputs of the ISO/TR 230-9 list of contributors:

- ``delta_laser`` δ_las — laser calibration (relative wavelength error; certificate);
- ``t_air``, ``p_air``, ``rh`` — the air conditions the compensation used: their errors move
  the Edlén index n = n(t, p, RH) away from n̂ = n(t̂, p̂, RĤ) (the equation itself, not a
  linearisation: the Monte Carlo check sees its curvature);
- ``t_material``, ``alpha`` — material temperature and expansion coefficient of the NDE;
- ``cosine`` δ_cos — misalignment of beam and axis: the laser reads L cos θ, an error in
  [−L θ_max²/2, 0], rectangular (its size at L = L_max; scaled by L/L_max at the others);
- ``dead_path`` δ_dead = L_d·(∂n/∂t)·Δt — the dead path L_d between interferometer and
  datum, for an air-temperature change Δt during the test (rectangular ±Δt_max);
- ``setup`` δ_set = h·Δε — Abbe offset h times the change of the angular error motion
  (rectangular ±ε_max);
- ``eve`` δ_EVE — the environmental variation error: the drift of the reading of the
  laser with the axis at rest over the duration of the test (a drift check before the
  test), rectangular ±EVE/2 (0 unless measured).

The outputs are e(L) at every target (µm).  E, M and A are ranges of means whose
instrument error is at most the error over the measured length, so u(E) = u(M) = u(A) =
u(e(L_max)) (the largest over the targets).  B and R are differences at one target
(between directions, or runs), in which the length-proportional terms cancel: u(B) =
u(R) = sqrt(u²(δ_dead) + u²(δ_set) + u²(δ_EVE)).  U = k u with k = 2 (EA-4/02).

The GUF (JCGM 100) goes through :func:`mtmetrology.uncertainty.guf`, its Monte Carlo check
(JCGM 101) through :func:`mtmetrology.uncertainty.monte_carlo`.  No worked example of
ISO/TR 230-9 could be consulted for this implementation; the default input values are
stated in :data:`DEFAULTS` and each can be replaced.

References
----------
ISO/TR 230-9:2005, *Test code for machine tools — Part 9: Estimation of measurement
uncertainty for machine tool tests according to series ISO 230, basic equations*.
JCGM 100:2008, 5.1; JCGM 101:2008, 7.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.positioning import environment
from mtmetrology.uncertainty.distributions import Normal, Rectangular
from mtmetrology.uncertainty.inputs import InputQuantity, InputSet
from mtmetrology.units import from_internal, to_internal

__all__ = ["DEFAULTS", "Budget", "tr230_9_budget"]

#: Default input uncertainties (half-widths of rectangular inputs, standard uncertainties
#: of normal ones): a stabilised He-Ne laser with a weather station of typical sensors.
DEFAULTS = {
    "laser_half_width": 0.05e-6,  # relative wavelength accuracy, ±0.05 ppm
    "u_air_temperature_K": 0.2,
    "u_air_pressure_Pa": 100.0,
    "u_humidity_percent": 6.0,
    "u_material_temperature_K": 0.1,
    "alpha_half_width_per_K": 1.0e-6,
    "misalignment_rad": 2.0e-4,  # largest beam-to-axis angle
    "dead_path_mm": 50.0,
    "air_drift_K": 0.5,  # largest air-temperature change during the test
    "abbe_offset_mm": 50.0,
    "angular_change_rad": 5.0e-6,
    "eve_um": 0.0,  # environmental variation error from a drift check
    "k": 2.0,
}
_NAMES = (
    "delta_laser",
    "t_air",
    "p_air",
    "rh",
    "t_material",
    "alpha",
    "cosine",
    "dead_path",
    "setup",
    "eve",
)


class _ErrorModel:
    """e(L) at each target, vectorised over trials (the module's measurement model)."""

    def __init__(self, span: np.ndarray, nominal: np.ndarray, wavelength_nm: float):
        self.span = span
        self.l_max = float(span.max())
        self.nominal = nominal  # t_air, p_air, rh, t_material, alpha as estimated
        self.wavelength_nm = wavelength_nm
        self.n_hat = environment.refractive_index(*nominal[:3], wavelength_nm)
        self.output_names = tuple(f"e_{k + 1}" for k in range(span.size))
        self.output_units = ("mm",) * span.size

    def __call__(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        cols = [x[..., k] for k in range(len(_NAMES))]
        las, t, p, rh, tm, alpha, cos, dead, setup, eve = cols
        n = environment.refractive_index(t, np.clip(p, 1e4, 1.4e5), np.clip(rh, 0, 100))
        t_hat, alpha_hat = self.nominal[3], self.nominal[4]
        rel = las + (self.n_hat / n - 1.0) - (alpha * (tm - 20.0) - alpha_hat * (t_hat - 20.0))
        length = self.span
        e = rel[..., None] * length + (cos / self.l_max)[..., None] * length
        return e + (dead + setup + eve)[..., None]


@dataclass(frozen=True)
class Budget:
    """The ISO/TR 230-9 budget of one test.

    Attributes
    ----------
    span : ndarray, shape (m,)
        Distance of each target from the datum, mm.
    inputs : InputSet
    model : callable
        e(L) at the targets (module notes), mm.
    u_targets_um : ndarray, shape (m,)
        u(e(L)) at each target by the GUF, µm.
    u_local_um : float
        sqrt(u²(δ_dead) + u²(δ_set) + u²(δ_EVE)), µm.
    rows : list of dict
        The budget at the largest L: input, unit, estimate, u, sensitivity, contribution
        (µm), share.
    k : float
    """

    span: np.ndarray
    inputs: InputSet
    model: _ErrorModel
    u_targets_um: np.ndarray
    u_local_um: float
    rows: list
    k: float

    def u_at_um(self, span: np.ndarray) -> np.ndarray:
        """u(e(L)) at the given distances, µm (interpolated between the targets)."""
        return np.interp(span, self.span, self.u_targets_um)

    def parameter_u(self) -> dict:
        """Standard uncertainty of each axis parameter, µm (module notes)."""
        u_len = float(self.u_targets_um.max())
        out = {}
        for key in ("E_up", "E_down", "E", "M", "A_up", "A_down", "A", "Pa", "P"):
            out[key] = u_len
        for key in ("B", "B_mean", "R_up", "R_down", "R", "Ps", "U", "U_mean"):
            out[key] = self.u_local_um
        return out

    def monte_carlo(self, trials: int = 200_000, seed: int | None = 2302) -> np.ndarray:
        """The Monte Carlo check (JCGM 101): u(e(L)) at each target, µm."""
        from mtmetrology.uncertainty.mcm import monte_carlo

        res = monte_carlo(self.model, self.inputs, trials=trials, seed=seed)
        return from_internal(np.asarray(res.standard_uncertainty), "µm")

    def to_dict(self) -> dict:
        """JSON form: u and U (k stated) per parameter, per target, and the budget rows."""
        u = self.parameter_u()
        return {
            "method": "GUF (JCGM 100), ISO/TR 230-9 contributors",
            "k": self.k,
            "coverage_probability": 0.95,
            "u_um": u,
            "U_um": {key: self.k * v for key, v in u.items()},
            "u_targets_um": self.u_targets_um.tolist(),
            "budget_at_max_length": self.rows,
        }


def tr230_9_budget(
    targets: np.ndarray, conditions, *, n_runs: int = 5, datum_mm: float | None = None, **given
) -> Budget:
    """The ISO/TR 230-9 budget of a test (module notes for the model).

    Parameters
    ----------
    targets : ndarray, shape (m,)
        Target positions, mm.
    conditions : Conditions
        Estimates of the air and material conditions, the expansion coefficient and the
        wavelength.
    n_runs : int
        Runs per direction (stated; the repeatability is in the parameters themselves).
    datum_mm : float, optional
        The laser datum (the conditions' or the first target otherwise).
    **given
        Any key of :data:`DEFAULTS`.

    Returns
    -------
    Budget

    Raises
    ------
    InputError
        An unknown key, a negative or non-finite value.
    """
    from mtmetrology.uncertainty.guf import guf

    bad = sorted(set(given) - set(DEFAULTS))
    if bad:
        raise InputError(f"budget: {bad[0]}: not an input ({', '.join(DEFAULTS)})")
    v = DEFAULTS | given
    for key, value in v.items():
        number = isinstance(value, int | float) and not isinstance(value, bool)
        if not (number and np.isfinite(value) and value >= 0):
            raise InputError(f"budget: {key}: {value!r} must be a finite number ≥ 0")
    c = conditions
    datum = c.datum_mm if datum_mm is None else datum_mm
    datum = targets[0] if datum is None else datum
    span = np.abs(np.asarray(targets, dtype=float) - datum)
    if span.max() <= 0:
        raise InputError("targets: no target away from the laser datum")
    l_max = float(span.max())
    n = environment.refractive_index(c.air_temperature_C, c.air_pressure_Pa, c.humidity_percent)
    dn_dt = (
        environment.refractive_index(
            c.air_temperature_C + 0.5, c.air_pressure_Pa, c.humidity_percent
        )
        - environment.refractive_index(
            c.air_temperature_C - 0.5, c.air_pressure_Pa, c.humidity_percent
        )
    ) / n
    a = c.expansion_material_per_K
    half = {
        "cos": l_max * v["misalignment_rad"] ** 2 / 2.0,
        "dead": abs(v["dead_path_mm"] * dn_dt * v["air_drift_K"]),
        "setup": v["abbe_offset_mm"] * v["angular_change_rad"],
        "eve": to_internal(v["eve_um"], "µm") / 2.0,
    }

    def rect(name, centre, h, unit):
        return InputQuantity(
            name, Rectangular(centre - h, centre + h) if h > 0 else Normal(centre, 0.0), unit
        )

    inputs = InputSet(
        [
            rect("delta_laser", 0.0, v["laser_half_width"], ""),
            InputQuantity("t_air", Normal(c.air_temperature_C, v["u_air_temperature_K"]), "K"),
            InputQuantity("p_air", Normal(c.air_pressure_Pa, v["u_air_pressure_Pa"]), "Pa"),
            rect("rh", c.humidity_percent, v["u_humidity_percent"] * np.sqrt(3.0), "%"),
            InputQuantity("t_material", Normal(c.material_C, v["u_material_temperature_K"]), "K"),
            rect("alpha", a, v["alpha_half_width_per_K"], "1/K"),
            InputQuantity(
                "cosine",
                Rectangular(-half["cos"], 0.0) if half["cos"] > 0 else Normal(0.0, 0.0),
                "mm",
            ),
            rect("dead_path", 0.0, half["dead"], "mm"),
            rect("setup", 0.0, half["setup"], "mm"),
            rect("eve", 0.0, half["eve"], "mm"),
        ]
    )
    nominal = np.array(
        [c.air_temperature_C, c.air_pressure_Pa, c.humidity_percent, c.material_C, a]
    )
    model = _ErrorModel(span, nominal, c.wavelength_nm)
    res = guf(model, inputs)
    u_t = from_internal(np.asarray(res.standard_uncertainty), "µm")
    j = int(np.argmax(span))
    rows = [
        {
            "input": r.input,
            "unit": r.unit,
            "estimate": r.estimate,
            "u": r.u,
            "sensitivity": r.sensitivity,
            "contribution_um": from_internal(r.contribution, "µm"),
            "share": r.share,
        }
        for r in res.budget(j)
    ]
    local = np.sqrt(half["dead"] ** 2 + half["setup"] ** 2 + half["eve"] ** 2) / np.sqrt(3.0)
    u_local = from_internal(float(local), "µm")
    return Budget(span, inputs, model, u_t, u_local, rows, float(v["k"]))
