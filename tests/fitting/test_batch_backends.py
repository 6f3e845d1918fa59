"""The compiled and the numpy backends of the batched circle/sphere fits agree.

The compiled backend forms each set's moment matrix in one pass of scalar sums
(:mod:`mtmetrology.fitting._kernels`); the numpy backend by stacked matrix products.  The
two differ only in the order of the additions, so the fitted elements agree to rounding:
1e-12 relative to the size of the sets, on spheres (free and known radius) and on 2-D and
3-D circles, in several chunks and with sets that need damping.
"""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.fitting import batch

pytest.importorskip("numba")


def _sets(rng, k, n, kind, arc, radius=None):
    """(k, n, d) points on spherical caps ("sphere") or circular arcs ("circle2",
    "circle3": in a random plane) of radius 10–40 mm (or ``radius``), polar half-angle
    or arc ``arc``, offsets up to 500 mm, 1 µm noise."""
    r = rng.uniform(10.0, 40.0, (k, 1, 1)) if radius is None else radius
    angle = rng.uniform(0.0, arc, (k, n))
    if kind == "sphere":
        azimuth = rng.uniform(0.0, 2 * np.pi, (k, n))
        unit = np.stack(
            [np.sin(angle) * np.cos(azimuth), np.sin(angle) * np.sin(azimuth), np.cos(angle)],
            axis=2,
        )
    else:
        unit = np.stack([np.cos(angle), np.sin(angle), np.zeros((k, n))], axis=2)
        if kind == "circle2":
            unit = unit[..., :2]
        else:
            unit = unit @ np.linalg.qr(rng.standard_normal((3, 3)))[0]
    offset = rng.uniform(-500.0, 500.0, (k, 1, unit.shape[2]))
    return offset + r * unit + 1e-3 * rng.standard_normal(unit.shape)


def _both(monkeypatch, fit, points, **kwargs):
    monkeypatch.setattr(batch, "BACKEND", "numba")
    assert batch._compiled_kernels(len(points)) is not None
    compiled = fit(points, **kwargs)
    monkeypatch.setattr(batch, "BACKEND", "numpy")
    assert batch._compiled_kernels(len(points)) is None
    return compiled, fit(points, **kwargs)


@pytest.mark.parametrize(
    ("fit", "kind", "arc", "kwargs"),
    [
        (batch.fit_spheres, "sphere", np.pi / 2, {}),
        (batch.fit_spheres, "sphere", 0.3, {}),  # shallow caps: more iterations
        (batch.fit_spheres, "sphere", np.pi / 2, {"radius": 25.0}),
        (batch.fit_circles, "circle2", np.pi / 2, {}),
        (batch.fit_circles, "circle3", np.pi / 2, {}),
    ],
)
def test_backends_agree(fit, kind, arc, kwargs, monkeypatch):
    rng = np.random.default_rng(12)
    points = _sets(rng, 300, 12, kind, arc, kwargs.get("radius"))
    monkeypatch.setattr(batch, "_COMPILED_CHUNK", 128)  # several chunks on both paths
    monkeypatch.setattr(batch, "_CHUNK", 128)
    compiled, reference = _both(monkeypatch, fit, points, **kwargs)
    # the stop reason at rounding level (step or cost) may differ; success may not
    assert compiled.success.all() and reference.success.all()
    scale = np.abs(points).max()
    np.testing.assert_allclose(compiled.centres, reference.centres, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(compiled.radii, reference.radii, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(compiled.residuals, reference.residuals, rtol=0, atol=1e-12 * scale)
