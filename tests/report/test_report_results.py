"""Result objects render their report in Jupyter (``_repr_html_``) and in reports."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from mtmetrology.fitting.least_squares import fit_sphere
from mtmetrology.fitting.minimum_zone import sphericity
from mtmetrology.identification import BallCentreProblem, ScaleBar, levenberg_marquardt
from mtmetrology.kinematics import Machine
from mtmetrology.report import Report
from mtmetrology.report.results import add_result, renders, result_report
from mtmetrology.samba import SambaSetup, probing_sequence
from mtmetrology.uncertainty.guf import guf
from mtmetrology.uncertainty.mcm import monte_carlo
from mtmetrology.uncertainty.modelfile import load_model
from mtmetrology.uncertainty.validation import validate_guf

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "gum-h1-end-gauge.yaml"
TWO_OUTPUTS = """
kind: measurement-model
name: two lengths
inputs:
  - {name: a, value: 10.0, u: 0.3, unit: µm}
  - {name: b, value: 5.0, u: 0.4, unit: µm}
outputs:
  - {name: s, expression: "a + b", unit: µm}
  - {name: d, expression: "a - b", unit: µm}
"""


def _figures(html: str) -> int:
    return len(re.findall(r'<figure class="mtm-figure"', html))


@pytest.fixture(scope="module")
def two_outputs(tmp_path_factory):
    path = tmp_path_factory.mktemp("model") / "two.yaml"
    path.write_text(TWO_OUTPUTS, encoding="utf-8")
    loaded = load_model(path)
    g = guf(loaded.model, loaded.inputs)
    r = monte_carlo(loaded.model, loaded.inputs, trials=20_000, seed=5, keep_samples=True)
    return loaded, g, r


def test_guf_result_shows_budget_and_gum_h1_uncertainty():
    """GUM H.1.6: u_c(l) = 32 nm, ν_eff = 16.7 (JCGM 100:2008, H.1.6)."""
    loaded = load_model(EXAMPLE)
    g = guf(loaded.model, loaded.inputs, p=0.99)
    html = g._repr_html_()
    assert html.startswith('<div class="mtm-report">') and _figures(html) == 1
    row = re.search(r"<tbody>\s*<tr><td>l</td>(.*?)</tr>", html, re.S).group(1)
    cells = re.findall(r"<td[^>]*>(.*?)</td>", row)
    assert cells[1] == "32" and cells[5] == "16.7"  # u and ν_eff columns


def test_two_output_guf_adds_correlation_and_ellipses(two_outputs):
    _, g, _ = two_outputs
    # one budget figure per output, a heat map and the pairwise ellipses
    assert _figures(g._repr_html_()) == 4


def test_mcm_with_guf_draws_one_histogram_per_output_and_the_regions(two_outputs):
    _, g, r = two_outputs
    rep = add_result(Report("mcm"), r, guf=g)
    html = rep.html()
    assert _figures(html) == 2 + 2  # histograms, correlation, ellipses
    assert "Monte Carlo results" in html


def test_validation_report_states_the_verdict(two_outputs):
    _, g, r = two_outputs
    v = validate_guf(g.estimate, g.covariance, r, tolerance=0.05, p=0.95)
    html = v._repr_html_()
    passed = re.findall(r"<td>(yes|no)</td>", html)
    assert len(passed) == len(v.rows) and (set(passed) == {"yes"}) == v.passed


def test_identification_and_parameter_set_render():
    m = Machine.load("five-axis-wcbxfzyst")
    setup = SambaSetup(
        balls={"1": (-80.0, -40.0, 100.0), "2": (80.0, 120.0, 150.0)},
        scale_bar={"SB1": (-152.60525, 0.0, 30.0), "SB2": (152.60525, 0.0, 30.0)},
    )
    pairs = [(b, c) for b in (-90, -45, 0, 45, 90) for c in range(0, 360, 60)]
    ids, q = probing_sequence(m, setup, pairs)
    bar = ScaleBar(("SB1", "SB2"), setup.scale_bar_length, u=0.001)
    result = levenberg_marquardt(
        BallCentreProblem(m, q, ids, scale_bars=[bar], estimate_tool=True, sigma=0.001)
    )
    html = result._repr_html_()
    assert _figures(html) == 2  # correlation map, singular values
    assert html.count("<tr><td>E_") == m.n_params
    pset = result.parameter_set(m)
    html = pset._repr_html_()
    assert _figures(html) == 1 and html.count("<tr><td>E_") == m.n_params
    assert _figures(result.diagnostics._repr_html_()) == 1


def test_fit_results_render_with_and_without_points():
    rng = np.random.default_rng(2)
    d = rng.standard_normal((30, 3))
    points = 12.7 * d / np.linalg.norm(d, axis=1, keepdims=True)
    ls = fit_sphere(points)
    assert _figures(ls._repr_html_()) == 1
    rep = add_result(Report("sphere"), sphericity(points), points=points)
    assert _figures(rep.html()) == 2


def test_unregistered_result_is_a_type_error_and_registration_works():
    class Custom:
        pass

    with pytest.raises(TypeError, match="no renderer registered"):
        result_report(Custom())

    @renders(Custom, "Custom result")
    def _custom(rep, result, **_):
        rep.section("custom", "drawn")

    assert result_report(Custom()).title == "Custom result"


def test_engines_do_not_load_the_report_machinery():
    """The mixin imports nothing: importing the engines loads neither matplotlib nor Jinja2."""
    import subprocess
    import sys

    code = (
        "import sys, mtmetrology.uncertainty, mtmetrology.fitting, mtmetrology.identification, "
        "mtmetrology.kinematics; print(sorted(m for m in ('matplotlib', 'jinja2') if m in "
        "sys.modules))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]"


def _budget_blocks(rep: Report, output: str):
    """The table and figure of the section "Uncertainty budget of <output>"."""
    section = next(s for s in rep._sections if s.heading == f"Uncertainty budget of {output}")
    table = next(b for b in section.blocks if b.kind == "table")
    figure = next(b for b in section.blocks if b.kind == "figure")
    return table, figure


def _task_like_guf():
    """A gauge length through machine parameters in internal units, correlated (issue 18)."""
    from mtmetrology.uncertainty.inputs import InputSet

    names = ["X_1", "B_1", "E_A0B", "E_XX1", "ex_1"]
    units = ["mm", "rad", "rad", "mm/mm", "mm"]
    x = np.array([250.0, 0.5, -9.587416744e-06, 7.9e-05, 0.0])
    u = np.array([0.4e-3, 0.0, 1.8e-06, 0.6e-06, 0.3e-3])
    corr = np.eye(5)
    corr[2, 3] = corr[3, 2] = -0.8
    cov = corr * np.outer(u, u)
    c = np.array([[1.0, 0.0, 150.0, 200.0, 1.0]])
    return guf(
        lambda xx: xx @ c.T,
        InputSet.from_covariance(names, x, cov, units),
        jacobian=lambda _x: c,
        output_units=["mm"],
    )


def test_budget_shows_display_units_one_share_definition_and_folds_zero_rows():
    """E_A0B in µrad and E_XX1 in µm/m (not 'unit 1'), the readings in mm; table shares =
    figure shares, Σ = 100 %."""
    g = _task_like_guf()
    rep = result_report(g)
    table, figure = _budget_blocks(rep, "y")
    rows = {r[0]: r for r in table.rows}
    assert rows["E_A0B"][1:4] == ("-9.6", "1.8", "µrad")
    assert rows["E_XX1"][1:4] == ("79.00", "0.60", "µm/m")
    # an axis reading is a position, in mm (to the decimal of its u), not 91 662.67 µm
    assert rows["X_1"][2:4] == ("0.00040", "mm")
    assert len(rows["X_1"][1].split(".")[1]) == 5
    assert "B_1" not in rows and rows["1 input with u = 0: B_1"][2] == "0"
    shares = [float(r[7].removesuffix(" %")) for r in table.rows]
    assert sum(shares) == pytest.approx(100.0, abs=0.05 * len(shares))
    budget = {b.input: b.share for b in g.budget(0)}
    assert sum(budget.values()) == pytest.approx(1.0)
    assert rows["E_XX1"][7] == f"{100 * budget['E_XX1']:.1f} %"
    assert budget["E_XX1"] < 0  # its covariance with E_A0B cancels part of u_c²
    drawn = sorted(re.findall(r">\s*(-?\d+\.\d) %\s*<", figure.svg))
    assert drawn == sorted(r[7].removesuffix(" %") for r in table.rows if "u = 0" not in r[0])
    assert "sum to 100 %" in table.caption and "c_i Σ_j c_j u(x_i, x_j)" in figure.caption
    assert g.to_dict()["budget"]["y"][3]["display_unit"] == "µm/m"


def test_budget_of_units_the_units_module_does_not_know_is_shown_as_given():
    """JCGM 101 §9.3 weighs in mg: a unit outside mm/rad is neither converted nor refused."""
    from mtmetrology.formatting import budget_cells
    from mtmetrology.uncertainty.guf import BudgetRow

    rows = (
        BudgetRow("m_W", "g", 100.0, 5e-5, 1000.0, 0.05, float("inf"), 0.8),
        BudgetRow("dm", "mg", 1.2, 0.025, 1.0, 0.025, float("inf"), 0.2),
    )
    lines, shown = budget_cells(rows, "mg")
    assert shown == [0, 1]
    assert [line[3] for line in lines] == ["g", "mg"]
    assert lines[0][4] == "1000 mg/g" and lines[1][4] == "1"


def test_guf_rows_name_the_unit_of_every_number():
    """A gauge length in mm with u in µm: the row's unit cell says both (no row mixes mm
    and µm unannounced), and u is the number in µm."""
    g = _task_like_guf()
    rep = result_report(g)
    [results] = [
        b
        for s in rep._sections
        if s.heading.startswith("GUF results")
        for b in s.blocks
        if b.kind == "table"
    ]
    row = dict(zip(results.columns, results.rows[0], strict=True))
    assert row["unit"] == "mm; u, U in µm"
    assert float(row["u"]) == pytest.approx(float(g.standard_uncertainty[0]) * 1e3, rel=0.05)
    assert len(row["value"].split(".")[1]) >= 4  # mm, to the decimal of u


def test_validation_rows_show_delta_in_the_display_unit(two_outputs):
    """Outputs in mm: |difference| and δ are shown in µm (δ = 0.05 mm reads 50), and the
    unit cell says so, not "5.0e-05 mm"-like internal values."""
    _, g, r = two_outputs
    v = validate_guf(g.estimate, g.covariance, r, tolerance=0.05, p=0.95)
    rep = Report("validation")
    add_result(rep, v, units={w.name: "mm" for w in v.rows})
    [table] = [b for s in rep._sections for b in s.blocks if b.kind == "table"]
    cells = dict(zip(table.columns, table.rows[0], strict=True))
    assert cells["unit"] == "mm; |difference|, δ in µm"
    assert float(cells["δ"]) == 50.0
    assert float(cells["|difference|"]) == pytest.approx(1e3 * v.rows[0].difference, rel=0.05)
