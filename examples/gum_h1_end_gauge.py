"""GUM annex H.1, end-gauge calibration, printed like a calibration certificate.

Reproduces JCGM 100:2008 H.1.6 (first order): l = 50.000 838 mm, u_c(l) = 32 nm,
ν_eff = 16, k = t_99(16) = 2.92, U_99 = 93 nm; then states what the second-order
terms of H.1.7 give (34 nm) and, with Monte Carlo (JCGM 101), the distribution of l
with the same normal inputs.

Run from the repository root::

    python examples/gum_h1_end_gauge.py
"""

from __future__ import annotations

import math
from pathlib import Path

from mtmetrology.uncertainty.guf import guf
from mtmetrology.uncertainty.mcm import monte_carlo
from mtmetrology.uncertainty.modelfile import load_model
from mtmetrology.units import convert

MODEL = Path(__file__).with_name("gum-h1-end-gauge.yaml")
P = 0.99


def main() -> None:
    loaded = load_model(MODEL)
    result = guf(loaded.model, loaded.inputs, p=P)

    print(f"{loaded.name}  ({MODEL.name})\n")
    print(
        f"{'input':8} {'estimate':>14} {'u(x_i)':>10} {'unit':5} {'c_i':>11} "
        f"{'u_i(l) / nm':>11} {'dof':>5}"
    )
    for row in result.budget("l"):
        dof = "inf" if math.isinf(row.dof) else f"{row.dof:g}"
        print(
            f"{row.input:8} {row.estimate:14.10g} {row.u:10.3g} {row.unit:5} "
            f"{row.sensitivity + 0.0:11.4g} {row.contribution:11.1f} {dof:>5}"
        )

    l_mm = convert(result.estimate[0], "nm", "mm")
    u_nm = result.standard_uncertainty[0]
    nu = result.dof_effective[0]
    k = result.coverage_factor[0]
    U_nm = result.expanded_uncertainty[0]
    print("\nCertificate (JCGM 100:2008, H.1.6)")
    print(f"  length at 20 °C        l   = {l_mm:.7f} mm")
    print(f"  standard uncertainty   u_c = {u_nm:.0f} nm ({u_nm:.1f} nm unrounded)")
    print(f"  effective dof          ν   = {math.floor(nu)} ({nu:.1f}, Welch–Satterthwaite)")
    print(f"  coverage factor        k   = {k:.2f} (t distribution, p = {P})")
    print(f"  expanded uncertainty   U   = {U_nm:.0f} nm")
    print(f"  l = ({l_mm:.7f} ± {convert(U_nm, 'nm', 'mm'):.7f}) mm, p = {P}")

    # H.1.7: the products δα·θ and α_s·δθ have zero expectation but non-zero variance.
    ls = loaded.inputs.estimate[0]
    u = dict(zip(loaded.inputs.names, loaded.inputs.standard_uncertainty, strict=True))
    second = (ls * u["dalpha"] * u["theta"], ls * u["alpha_s"] * u["dtheta"])
    u2 = math.sqrt(u_nm**2 + sum(s**2 for s in second))
    print("\nSecond-order terms (JCGM 100:2008, H.1.7)")
    print(f"  l_s·u(δα)·u(θ) = {second[0]:.1f} nm, l_s·u(α_s)·u(δθ) = {second[1]:.1f} nm")
    print(f"  u_c(l) with second-order terms = {u2:.0f} nm ({u2:.1f} nm)")

    mc = monte_carlo(loaded.model, loaded.inputs, trials=1_000_000, p=P, seed=20080101)
    low, high = mc.interval_shortest[0]
    print("\nMonte Carlo, normal inputs (JCGM 101:2008), 10^6 trials")
    print(
        f"  u(l) = {mc.standard_uncertainty[0]:.1f} nm, shortest {P:.0%} interval "
        f"[{low - result.estimate[0]:+.0f}, {high - result.estimate[0]:+.0f}] nm about l"
    )


if __name__ == "__main__":
    main()
