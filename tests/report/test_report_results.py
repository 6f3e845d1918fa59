"""Result objects render their report in Jupyter (``_repr_html_``) and in reports."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from mtmetrology.fitting.least_squares import fit_sphere
from mtmetrology.fitting.minimum_zone import sphericity
from mtmetrology.identification import BallCentreProblem, ScaleBar, gauss_newton
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
    result = gauss_newton(
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
