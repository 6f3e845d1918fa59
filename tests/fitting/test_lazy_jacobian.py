"""The parameter Jacobian of a fit is computed on first access, with the same bits.

A fit keeps what its sensitivities need and computes ``parameter_jacobian`` (and the
pieces of ``residual_jacobian``) only when asked.  The value must not depend on when it is
asked: accessed at once (as the eager fit computed it) or after the caller's points were
overwritten and other fits ran in between, the arrays are bit-for-bit equal.
"""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.fitting import axial, least_squares, odr
from mtmetrology.fitting.axial import fit_cylinder
from mtmetrology.fitting.least_squares import fit_circle, fit_plane, fit_sphere

N_POINTS = 60  # enough for every element; small keeps the (n, n, 3) residual Jacobian tiny


def _points(name: str, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = rng.uniform(0.0, 2.0 * np.pi, N_POINTS)
    noise = rng.normal(scale=2e-3, size=(N_POINTS, 3))
    if name == "sphere":
        u = rng.normal(size=(N_POINTS, 3))
        return 12.5 * u / np.linalg.norm(u, axis=1, keepdims=True) + (1.0, -2.0, 3.0) + noise
    if name == "circle":  # 3-D: the plane is fitted too (the two-stage Jacobian)
        return np.column_stack([5 * np.cos(t), 5 * np.sin(t), 0.3 * np.cos(t)]) + noise
    if name == "plane":
        return np.column_stack([rng.uniform(-5, 5, (N_POINTS, 2)), 0.1 * t]) + noise
    return np.column_stack([4 * np.cos(t), 4 * np.sin(t), rng.uniform(0, 10, N_POINTS)]) + noise


FITS = {"sphere": fit_sphere, "circle": fit_circle, "plane": fit_plane, "cylinder": fit_cylinder}


def _same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("name", sorted(FITS))
def test_late_jacobian_has_the_bits_of_the_immediate_one(name):
    fit = FITS[name]
    points = _points(name, 11)
    eager = fit(points.copy())
    eager_jacobian = eager.parameter_jacobian.copy()
    eager_residual = eager.residual_jacobian()

    mine = points.copy()
    lazy = fit(mine)
    mine[:] = np.random.default_rng(12).normal(size=mine.shape)  # the caller reuses it
    for other in FITS:  # other fits allocate and free arrays in between
        FITS[other](_points(other, 13)).parameter_jacobian  # noqa: B018

    assert _same_bits(lazy.parameter_jacobian, eager_jacobian)
    assert _same_bits(lazy.residual_jacobian(), eager_residual)
    assert lazy.parameter_jacobian.shape == (len(lazy.parameters), N_POINTS, 3)


@pytest.mark.parametrize("name", sorted(FITS))
def test_fit_defers_the_jacobian_until_asked_and_computes_it_once(name, monkeypatch):
    calls = []

    def counted(j, g):  # dβ/dP = −J⁺ ∂d/∂P: the costly step of every sensitivity
        calls.append(j.shape)
        return odr.local_to_points(j, g)

    monkeypatch.setattr(least_squares, "local_to_points", counted)
    monkeypatch.setattr(axial, "local_to_points", counted)
    fit = FITS[name](_points(name, 21))
    assert calls == []  # the element, residuals and form error need no Jacobian
    first = fit.parameter_jacobian
    after_first = len(calls)
    fit.residual_jacobian()
    assert fit.parameter_jacobian is first
    assert after_first >= 1 and len(calls) == after_first
