"""Tests for mtmetrology.kinematics.compensation: the chunked compensation of a record
(issue 20), the covariance G U_θ Gᵀ of the compensated points and the corrections."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.kinematics.compensation import (
    Compensation,
    compensate,
    compensated_points,
    compensation_covariance,
    correction_statistics,
)
from mtmetrology.kinematics.machine import Machine

MACHINE = Machine.load("five-axis-wcbxfzyst")


def _record(n=7, seed=0):
    rng = np.random.default_rng(seed)
    customary = {
        "X": rng.uniform(-100, 100, n),
        "Y": rng.uniform(-100, 100, n),
        "Z": rng.uniform(50, 200, n),
        "B": rng.uniform(-45, 45, n),
        "C": rng.uniform(0, 360, n),
    }
    q = MACHINE.readings_from_customary(customary)
    theta = rng.normal(size=MACHINE.n_params) * MACHINE.parameter_scales
    a = MACHINE.parameter_scales[:, None] * rng.normal(size=(MACHINE.n_params,) * 2)
    return q, theta, a @ a.T


def test_chunks_do_not_change_the_result():
    """One row per chunk, three rows per chunk and one chunk give the same points and u:
    each row is compensated on its own."""
    q, theta, cov = _record()
    whole = compensate(MACHINE, q, theta, cov, with_u=True)
    for rows in (1, 3):
        part = compensate(MACHINE, q, theta, cov, with_u=True, chunk_rows=rows)
        np.testing.assert_array_equal(part.points, whole.points)
        np.testing.assert_array_equal(part.u, whole.u)


def test_points_and_u_are_those_of_the_kinematic_engine():
    q, theta, cov = _record()
    points, u = compensated_points(MACHINE, q, theta, cov)
    result = compensate(MACHINE, q, theta, cov, with_u=True)
    np.testing.assert_array_equal(result.points, points)
    np.testing.assert_array_equal(result.u, u)
    np.testing.assert_array_equal(
        compensate(MACHINE, q, theta).points, MACHINE.forward(q, theta, tool=MACHINE.tool)
    )


def test_document_round_trip():
    q, theta, cov = _record()
    result = compensate(MACHINE, q, theta, cov, with_u=True)
    back = Compensation.from_dict(result.to_dict())
    np.testing.assert_array_equal(back.points, result.points)
    np.testing.assert_array_equal(back.u, result.u)
    assert Compensation.from_dict(compensate(MACHINE, q, theta).to_dict()).u is None


def test_a_non_finite_position_names_the_file_line():
    q, theta, _ = _record()
    q[4, 0] = np.nan
    with pytest.raises(InputError) as err:
        compensate(MACHINE, q, theta, source="r.csv", lines=list(range(10, 17)))
    assert str(err.value).startswith("r.csv, line 14: the compensated position is not finite")


def test_u_without_a_covariance_is_refused():
    q, theta, _ = _record()
    with pytest.raises(InputError, match="needs a parameter covariance"):
        compensate(MACHINE, q, theta, with_u=True)


def test_covariance_is_the_parameter_jacobian_propagation():
    """One parameter of variance σ²: U_q = σ² g gᵀ with g = ∂f/∂δ_k by central differences."""
    q, theta, _ = _record(n=3, seed=2)
    k = 7
    sigma = 2.0 * MACHINE.parameter_scales[k]
    cov = np.zeros((MACHINE.n_params,) * 2)
    cov[k, k] = sigma**2
    points, u_q = compensation_covariance(MACHINE, q, theta, cov)
    h = 1e-3 * MACHINE.parameter_scales[k]
    step = np.zeros(MACHINE.n_params)
    step[k] = h
    tool = MACHINE.tool
    g = (
        MACHINE.forward(q, theta + step, tool=tool) - MACHINE.forward(q, theta - step, tool=tool)
    ) / (2 * h)
    assert np.abs(g).max() > 1e-3  # the parameter moves the point: the check is not 0 = 0
    np.testing.assert_allclose(points, MACHINE.forward(q, theta, tool=tool), atol=1e-12)
    expected = sigma**2 * np.einsum("si,sj->sij", g, g)
    np.testing.assert_allclose(u_q, expected, rtol=1e-6, atol=1e-15)


def test_u_is_the_root_of_the_covariance_diagonal_and_scales_with_the_covariance():
    q, theta, cov = _record(seed=3)
    _, full = compensation_covariance(MACHINE, q, theta, cov)
    assert np.all(np.linalg.eigvalsh(full) >= -1e-18)
    np.testing.assert_allclose(full, np.swapaxes(full, 1, 2), atol=1e-18)
    _, u = compensated_points(MACHINE, q, theta, cov)
    np.testing.assert_allclose(u, np.sqrt(np.diagonal(full, axis1=1, axis2=2)), rtol=1e-12)
    _, u4 = compensated_points(MACHINE, q, theta, 16.0 * cov)
    np.testing.assert_allclose(u4, 4.0 * u, rtol=1e-12)


def test_correction_statistics_of_known_corrections():
    """Corrections (3, 4, 0) µm and (0, 0, 12) µm: norms 5 and 12 µm, rms √84.5 µm."""
    nominal = np.array([[10.0, 20.0, 30.0], [-5.0, 0.0, 40.0]])
    points = nominal + np.array([[3e-3, 4e-3, 0.0], [0.0, 0.0, 12e-3]])
    correction, largest, rms = correction_statistics(points, nominal)
    np.testing.assert_allclose(correction, [[3.0, 4.0, 0.0], [0.0, 0.0, 12.0]], atol=1e-9)
    assert largest == pytest.approx(12.0, abs=1e-9)
    assert rms == pytest.approx(np.sqrt(84.5), abs=1e-9)


def _report_rows(html: str) -> dict[str, str]:
    """quantity -> value of the Compensation section's table."""
    import re

    return dict(re.findall(r"<tr><td>([^<]*)</td><td[^>]*>([^<]*)</td><td>[^<]*</td></tr>", html))


def test_compensation_report_gives_the_corrections_and_the_notebook_its_points():
    from mtmetrology.report import Report
    from mtmetrology.report.results import add_result

    # exact: corrections (3, 4, 0) µm and (0, 0, 12) µm have norms 5 and 12 µm,
    # largest 12 µm, rms √((25 + 144)/2) = 9.192 µm
    nominal = np.array([[10.0, 20.0, 30.0], [-5.0, 0.0, 40.0]])
    points = nominal + np.array([[3e-3, 4e-3, 0.0], [0.0, 0.0, 12e-3]])
    comp = Compensation(points, u=np.full((2, 3), 0.7e-3))
    rep = add_result(Report("c"), comp, nominal=nominal, machine=MACHINE)
    rows = _report_rows(rep.html())
    assert (rows["points"], float(rows["largest correction"])) == ("2", 12.0)
    assert float(rows["rms correction"]) == pytest.approx(np.sqrt((25 + 144) / 2), abs=1e-3)
    # without the nominal positions the notebook shows the points and the largest u
    rows = _report_rows(comp._repr_html_())
    assert rows == {"points": "2", "largest u of a coordinate": "0.70"}
