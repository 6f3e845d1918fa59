"""A sphere by least squares and by minimum zone (sphericity).

25 points on the upper half of a sphere of 25.4 mm diameter (12.7 mm radius), radial
deviations of 2 µm standard deviation (seeded): the least-squares sphericity (peak to
valley) and the minimum zone, which a form tolerance is checked against. What
``mtm fit sphere --method minimum-zone`` computes (its command is printed). Run it on its own::

    python examples/sphere_fitting.py [OUT]

References
----------
ISO 1101:2017 (minimum zone); ISO 10360-6:2001 (least-squares elements).
"""

from __future__ import annotations

import numpy as np

from mtmetrology.fitting.documents import fit_document
from mtmetrology.fitting.least_squares import fit_sphere
from mtmetrology.fitting.minimum_zone import sphericity
from mtmetrology.io.tables import write_csv_table
from mtmetrology.report.demo import DemoContext
from mtmetrology.report.results import add_fit_document
from mtmetrology.units import from_internal, to_internal

#: The sphere's radius, mm: a one-inch (25.4 mm) reference sphere.
RADIUS_MM = 12.7


def _rng(ctx: DemoContext, stream: int) -> np.random.Generator:
    """An independent stream per section, from the root seed."""
    return np.random.default_rng(np.random.SeedSequence(ctx.seed).spawn(stream + 1)[stream])


def main(ctx: DemoContext) -> None:
    ctx.rule("Geometric elements")
    rng = _rng(ctx, 2)
    d = rng.standard_normal((25, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d[:, 2] = np.abs(d[:, 2])  # the upper hemisphere, as probed on a mounted sphere
    form = float(to_internal(2.0, "µm"))
    radii = RADIUS_MM + form * rng.standard_normal(25)
    points = np.array([10.0, -20.0, 5.0]) + radii[:, None] * d
    write_csv_table(
        ctx.path("fitting", "sphere.csv"),
        ["x", "y", "z"],
        ([f"{v:.6f}" for v in p] for p in points),
    )
    ls = fit_sphere(points)
    zone = sphericity(points)
    source = ctx.shown("fitting", "sphere.csv")
    document = fit_document(
        "sphere",
        "minimum-zone",
        source,
        zone.element,
        zone.residuals,
        zone.form_error,
        {"message": zone.message},
    )
    ctx.write_json(document, "fitting", "sphere-result.json")
    ctx.report.section(
        "A sphere: least squares and minimum zone",
        f"25 points on the upper half of a sphere of {2 * RADIUS_MM:g} mm diameter, radial "
        "deviations of 2 µm standard deviation. The "
        f"least-squares sphericity (peak to valley) is "
        f"{float(from_internal(ls.form_error, 'µm')):.2f} µm; the minimum zone, which a form "
        f"tolerance is checked against, {float(from_internal(zone.form_error, 'µm')):.2f} µm.",
    )
    add_fit_document(ctx.report, document, zone.residuals, points)
    ctx.command("the minimum-zone sphere", "fit", "sphere", source, "--method", "minimum-zone")
    ctx.summary.append(
        f"sphere: radius {zone.element.radius:.4f} mm, sphericity "
        f"{float(from_internal(zone.form_error, 'µm')):.2f} µm (least squares "
        f"{float(from_internal(ls.form_error, 'µm')):.2f} µm)"
    )


if __name__ == "__main__":
    from mtmetrology.report.demo import run_example

    run_example(main, "sphere_fitting")
