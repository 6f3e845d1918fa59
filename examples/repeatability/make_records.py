"""Write the synthetic probing records of the repeatability tutorial (deterministic).

- ``sphere-records.csv``: 45 target poses on a sphere probed in 16 cycles ("ordered"
  strategy: every cycle visits all targets), readings = nominal point + a thermal drift
  common to all targets (a cubic in time, a few µm over the 3 h) + white noise
  σ = 0.5 µm along the approach and 0.2 µm across it.
- ``ring-hysteresis.csv``: probing hysteresis test of a ring gauge (r = 28.782 mm),
  12 indexations ψ = 0°, 30°, …, 330°, 24 cycles, one reading without hysteresis
  (``direct``) and one with it (``hysteresis``, radius 0.11 µm smaller on average),
  scatter 0.6 µm (Sepahi Boroujeni (2021), §4, is the model of both tests).

Run from the repository root::

    python examples/repeatability/make_records.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mtmetrology.omm.repeatability import sphere_normal
from mtmetrology.units import from_internal, to_internal

HERE = Path(__file__).parent
UM = to_internal(1.0, "µm")


def sphere_records(rng: np.random.Generator) -> list[str]:
    n_targets, cycles, dt = 45, 16, 15.0  # s between touches
    phi = rng.uniform(0.0, 90.0, n_targets)
    theta = rng.uniform(0.0, 360.0, n_targets)
    b = rng.uniform(-90.0, 90.0, n_targets)
    c = rng.uniform(-180.0, 180.0, n_targets)
    pos = rng.uniform([-200, -150, -100], [200, 150, 200], (n_targets, 3))
    n = sphere_normal(to_internal(phi, "deg"), to_internal(theta, "deg"))
    span = cycles * n_targets * dt
    # Coefficients of z, z², z³ (z = time / span) of the X, Y, Z drift, µm.
    drift = np.array([[16.0, -12.0, 8.0], [-24.0, 8.0, -4.0], [12.0, 6.0, 2.0]]) * UM
    rows = ["target,phi,theta,B,C,X_T,Y_T,Z_T,i,j,k,X,Y,Z,time"]
    for cycle in range(cycles):
        for t in range(n_targets):
            time = (cycle * n_targets + t) * dt
            z = time / span
            thermal = drift[0] * z + drift[1] * z**2 + drift[2] * z**3
            along, across = rng.normal(0.0, 0.5 * UM), rng.normal(0.0, 0.2 * UM, 3)
            p = pos[t] + thermal + along * n[t] + across - np.dot(across, n[t]) * n[t]
            rows.append(
                f"T{t:02d},{phi[t]:.3f},{theta[t]:.3f},{b[t]:.3f},{c[t]:.3f},"
                f"{pos[t, 0]:.4f},{pos[t, 1]:.4f},{pos[t, 2]:.4f},"
                f"{-n[t, 0]:.6f},{-n[t, 1]:.6f},{-n[t, 2]:.6f},"
                f"{p[0]:.5f},{p[1]:.5f},{p[2]:.5f},{time:.0f}"
            )
    return rows


def ring_records(rng: np.random.Generator) -> list[str]:
    rows = ["psi,condition,X,Y"]
    for _cycle in range(24):
        for psi in range(0, 360, 30):
            a = to_internal(float(psi), "deg")
            for condition, offset in (("direct", 0.0), ("hysteresis", -0.11 * UM)):
                r = 28.782 + offset + rng.normal(0.0, 0.6 * UM)
                rows.append(f"{psi},{condition},{r * np.cos(a):.6f},{r * np.sin(a):.6f}")
    return rows


def main() -> None:
    rng = np.random.default_rng(2021)
    for name, rows in (
        ("sphere-records.csv", sphere_records(rng)),
        ("ring-hysteresis.csv", ring_records(rng)),
    ):
        (HERE / name).write_text("\n".join(rows) + "\n", encoding="utf-8")
        print(f"{name}: {len(rows) - 1} rows")
    print(f"noise along the approach: {from_internal(0.5 * UM, 'µm'):g} µm")


if __name__ == "__main__":
    main()
