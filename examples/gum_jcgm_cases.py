"""The worked examples of the GUM and its Supplement 1, run through mtmetrology.uncertainty.

Each ``case_*`` function returns a :class:`Case` (model, inputs, output names and units);
``main`` evaluates every case by the GUF and by Monte Carlo and prints our figures beside
the published ones.  The tests in ``tests/uncertainty/test_published_cases.py`` run the
same cases and assert the published numbers.

- JCGM 100:2008, H.2: simultaneous resistance and reactance from five sets of V, I, φ
  (correlated Type A inputs with ν = 4: one ensemble, Willink 2007).
- JCGM 100:2008, H.3: calibration of a thermometer by a least-squares line (correlated
  slope and intercept with ν = 9: one ensemble); correction at 30 °C.
- JCGM 101:2008, 9.2: additive model Y = X₁ + X₂ + X₃ + X₄ (normal, rectangular,
  rectangular of different widths).
- JCGM 101:2008, 9.3: mass calibration (conventional mass, air buoyancy).
- JCGM 101:2008, 9.4: comparison loss in microwave power meter calibration,
  δY = X₁² + X₂² (x₁ = 0, 0.010, 0.050; x₂ = 0; u = 0.005; r = 0 or 0.9).

References
----------
JCGM 100:2008, *Evaluation of measurement data — Guide to the expression of uncertainty in
measurement*, annex H.

JCGM 101:2008, *Evaluation of measurement data — Supplement 1 to the GUM — Propagation of
distributions using a Monte Carlo method*, clause 9.

Willink, R. (2007). A generalization of the Welch–Satterthwaite formula for use with
correlated uncertainty components. *Metrologia* 44(5), 340–349.

Run from the repository root::

    python examples/gum_jcgm_cases.py
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from mtmetrology.optimize import least_squares
from mtmetrology.uncertainty import (
    InputQuantity,
    InputSet,
    Normal,
    Rectangular,
    guf,
    monte_carlo,
    validate_results,
)

# JCGM 100:2008, Table H.2: five sets of simultaneous observations of V (V), I (mA), φ (rad).
H2_OBSERVATIONS = np.array(
    [
        [5.007, 19.663, 1.0456],
        [4.994, 19.639, 1.0438],
        [5.005, 19.640, 1.0468],
        [4.990, 19.685, 1.0428],
        [4.999, 19.678, 1.0433],
    ]
)
# JCGM 100:2008, Table H.6: thermometer readings t_k and corrections b_k (°C).
H3_READINGS = np.array(
    [21.521, 22.012, 22.512, 23.003, 23.507, 23.999, 24.513, 25.002, 25.503, 26.010, 26.511]
)
H3_CORRECTIONS = np.array(
    [-0.171, -0.169, -0.166, -0.159, -0.164, -0.165, -0.156, -0.157, -0.159, -0.161, -0.160]
)
H3_REFERENCE_TEMPERATURE = 20.0  # t₀ (°C), H.3.1


@dataclass(frozen=True)
class Case:
    """A published example: ``model(X (..., N)) -> (..., m)`` and its inputs."""

    title: str
    model: Callable[[np.ndarray], np.ndarray]
    inputs: InputSet
    names: tuple[str, ...]
    units: tuple[str, ...]

    def guf(self, p: float = 0.95):
        return guf(self.model, self.inputs, p=p, output_names=self.names, output_units=self.units)

    def monte_carlo(self, trials: int = 10**6, seed: int = 1, p: float = 0.95, **options):
        return monte_carlo(
            self.model,
            self.inputs,
            trials=trials,
            seed=seed,
            p=p,
            output_names=self.names,
            output_units=self.units,
            **options,
        )


def _impedance(x):
    """(R, X, Z) = (V/I cos φ, V/I sin φ, V/I) in Ω for V in V and I in mA (JCGM 100, H.2.1)."""
    z = 1e3 * x[..., 0] / x[..., 1]
    return np.stack([z * np.cos(x[..., 2]), z * np.sin(x[..., 2]), z], axis=-1)


def case_gum_h2() -> Case:
    """JCGM 100:2008, H.2, approach 1: the means of V, I, φ with their covariances (ν = 4)."""
    inputs = InputSet.from_observations(["V", "I", "phi"], H2_OBSERVATIONS, ["", "", "rad"])
    return Case("GUM H.2 resistance and reactance", _impedance, inputs, ("R", "X", "Z"), ("",) * 3)


def gum_h3_fit():
    """Least-squares line b(t) = y₁ + y₂ (t − t₀) through Table H.6 (JCGM 100:2008, H.3.2).

    Returns
    -------
    (estimate (2,), covariance (2, 2), residual standard deviation s, dof ν = n − 2)
    """
    design = np.column_stack(
        [np.ones_like(H3_READINGS), H3_READINGS - H3_REFERENCE_TEMPERATURE]
    )  # (n, 2)
    fit = least_squares(lambda y: (design @ y - H3_CORRECTIONS, design), np.zeros(2))
    dof = H3_READINGS.size - 2
    s = math.sqrt(2.0 * fit.cost / dof)  # H.3.3: s² = Σ r_k² / (n − 2)
    covariance = s**2 * np.linalg.inv(design.T @ design)  # (H.13)–(H.16)
    return fit.x, covariance, s, dof


def case_gum_h3(temperature: float = 30.0) -> Case:
    """JCGM 100:2008, H.3.4: the correction b(t) = y₁ + y₂ (t − t₀) at ``temperature`` °C.

    y₁ and y₂ come from one fit of n = 11 points: correlated (r = −0.930) with ν = 9 each,
    an ensemble.
    """
    estimate, covariance, _, dof = gum_h3_fit()
    inputs = InputSet.from_covariance(
        ["y1", "y2"], estimate, covariance, ["°C", "1"], dof=[dof, dof], ensembles=[["y1", "y2"]]
    )
    lever = temperature - H3_REFERENCE_TEMPERATURE

    def correction(x):
        return x[..., 0] + x[..., 1] * lever

    return Case(f"GUM H.3 thermometer correction at {temperature:g} °C", correction, inputs,
                ("b",), ("°C",))  # fmt: skip


def _additive(x):
    return x.sum(axis=-1)


def case_jcgm101_9_2(kind: str) -> Case:
    """JCGM 101:2008, 9.2: Y = X₁ + X₂ + X₃ + X₄, inputs of expectation 0.

    ``kind``: "normal" (9.2.2, u = 1 each), "rectangular" (9.2.3, u = 1 each) or
    "rectangular-wide" (9.2.4, X₁…X₃ as in 9.2.3, X₄ rectangular with u = 10).
    """
    half_widths = {
        "rectangular": [math.sqrt(3.0)] * 4,
        "rectangular-wide": [math.sqrt(3.0)] * 3 + [10.0 * math.sqrt(3.0)],
    }
    if kind == "normal":
        quantities = [InputQuantity(f"X{i}", Normal(0.0, 1.0)) for i in range(1, 5)]
    elif kind in half_widths:
        quantities = [
            InputQuantity(f"X{i}", Rectangular(-a, a))
            for i, a in enumerate(half_widths[kind], start=1)
        ]
    else:
        raise ValueError(f"kind must be normal, rectangular or rectangular-wide, got {kind!r}")
    return Case(f"JCGM 101 9.2 additive model ({kind})", _additive, InputSet(quantities),
                ("Y",), ("",))  # fmt: skip


AIR_DENSITY_REFERENCE = 1.2  # ρ_a0 (kg/m³), JCGM 101:2008, 9.3.1
NOMINAL_MASS = 100_000.0  # m_nom (mg)


def _mass_deviation(x):
    """δm = (m_R,c + δm_R,c)[1 + (ρ_a − ρ_a0)(1/ρ_W − 1/ρ_R)] − m_nom (JCGM 101, 9.3.1)."""
    m_ref, dm_ref, rho_a, rho_w, rho_r = np.moveaxis(x, -1, 0)
    buoyancy = (rho_a - AIR_DENSITY_REFERENCE) * (1.0 / rho_w - 1.0 / rho_r)
    return (m_ref + dm_ref) * (1.0 + buoyancy) - NOMINAL_MASS


def case_jcgm101_9_3() -> Case:
    """JCGM 101:2008, 9.3, Table 5: mass calibration of a 100 g weight (mg, kg/m³)."""
    inputs = InputSet(
        [
            InputQuantity("m_Rc", Normal(100_000.000, 0.050)),
            InputQuantity("dm_Rc", Normal(1.234, 0.020)),
            InputQuantity("rho_a", Rectangular(1.10, 1.30)),
            InputQuantity("rho_W", Rectangular(7000.0, 9000.0)),
            InputQuantity("rho_R", Rectangular(7950.0, 8050.0)),
        ]
    )
    return Case("JCGM 101 9.3 mass calibration", _mass_deviation, inputs, ("dm",), ("",))


def _comparison_loss(x):
    """δY = X₁² + X₂² (JCGM 101:2008, 9.4.1)."""
    return x[..., 0] ** 2 + x[..., 1] ** 2


def case_jcgm101_9_4(x1: float, correlation: float = 0.0, u: float = 0.005) -> Case:
    """JCGM 101:2008, 9.4: X₁, X₂ bivariate normal, x₂ = 0, u(x₁) = u(x₂) = u."""
    covariance = u**2 * np.array([[1.0, correlation], [correlation, 1.0]])
    inputs = InputSet.from_covariance(["X1", "X2"], [x1, 0.0], covariance)
    return Case(f"JCGM 101 9.4 comparison loss (x1 = {x1:g}, r = {correlation:g})",
                _comparison_loss, inputs, ("dY",), ("",))  # fmt: skip


def _show(case: Case, trials: int = 10**6) -> None:
    g = case.guf()
    r = case.monte_carlo(trials)
    report = validate_results(g, r)
    print(f"\n{case.title}  (GUF validated by Monte Carlo: {report.passed})")
    for og, om, short in zip(g.outputs, r.outputs, r.interval_shortest, strict=True):
        print(
            f"  {og.name:3} GUF {og.value:.6g} u {og.u:.4g} [{og.interval[0]:.6g}, "
            f"{og.interval[1]:.6g}]  MCM {om.value:.6g} u {om.u:.4g} shortest "
            f"[{short[0]:.6g}, {short[1]:.6g}]"
        )


def main() -> None:
    h2 = case_gum_h2().guf()
    print("GUM H.2 (Table H.4: R 127.732 Ω u 0.071, X 219.847 Ω u 0.295, Z 254.260 Ω u 0.236;")
    print("         r(R,X) -0.588, r(R,Z) -0.485, r(X,Z) 0.993)")
    for o, nu in zip(h2.outputs, h2.dof_effective, strict=True):
        print(f"  {o.name} = {o.value:.3f} Ω, u = {o.u:.4f} Ω, ν_eff = {nu:.1f}")
    print(
        f"  r = {h2.correlation[0, 1]:.3f}, {h2.correlation[0, 2]:.3f}, {h2.correlation[1, 2]:.3f}"
    )
    estimate, covariance, s, dof = gum_h3_fit()
    h3 = case_gum_h3().guf()
    print("\nGUM H.3 (y1 -0.1712 °C, y2 0.00218, s 0.0035 °C, r -0.930; b(30 °C) -0.1494 u 0.0041)")
    print(
        f"  y1 = {estimate[0]:.4f} °C, y2 = {estimate[1]:.5f}, s = {s:.4f} °C, "
        f"r = {covariance[0, 1] / math.sqrt(covariance[0, 0] * covariance[1, 1]):.3f}, ν = {dof}"
    )
    print(
        f"  b(30 °C) = {h3.output().value:.4f} °C, u = {h3.output().u:.4f} °C, "
        f"ν_eff = {h3.dof_effective[0]:.1f}"
    )
    for kind in ("normal", "rectangular", "rectangular-wide"):
        _show(case_jcgm101_9_2(kind))
    _show(case_jcgm101_9_3())
    for x1 in (0.0, 0.010, 0.050):
        for correlation in (0.0, 0.9):
            _show(case_jcgm101_9_4(x1, correlation))


if __name__ == "__main__":
    main()
