"""Tests for mtmetrology.display: one renderer per class, found through the MRO, serving
the notebook display and the HTML report alike."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from mtmetrology import display
from mtmetrology.uncertainty.guf import guf
from mtmetrology.uncertainty.modelfile import load_model

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "gum-h1-end-gauge.yaml"


def _sections(html: str) -> list[str]:
    """The numbered sections of a page or fragment, figures (SVG ids vary) cut out."""
    found = re.findall(r'<section class="mtm-section" id="s\d+">(.*?)</section>', html, re.S)
    return [re.sub(r"<svg.*?</svg>", "<svg/>", s, flags=re.S) for s in found]


def test_notebook_display_and_report_show_the_same_sections():
    from mtmetrology.report import Report
    from mtmetrology.report.results import add_result

    loaded = load_model(EXAMPLE)
    g = guf(loaded.model, loaded.inputs)
    notebook = _sections(g._repr_html_())
    report = _sections(add_result(Report("page"), g).html())
    assert len(notebook) == 2 and notebook == report


class _Base(display.NotebookRepr):
    _renderer_module = None


class _Child(_Base):
    pass


class _Grandchild(_Child):
    pass


def test_lookup_follows_the_mro_and_the_nearest_registration_wins():
    @display.register(_Base, "base")
    def _base(rep, result, **_):
        rep.section("base")

    assert display.renderer_for(_Grandchild()).title == "base"

    @display.register(_Child)
    def _child(rep, result, **_):
        rep.section("child")

    assert display.renderer_for(_Grandchild()).func is _child
    assert display.renderer_for(_Grandchild()).title == "_Child"
    assert display.renderer_for(_Base()).func is _base


def test_registration_is_by_class_not_by_name():
    with pytest.raises(TypeError, match="by class"):
        display.register("mtmetrology.fitting.odr.FitResult")


def test_unregistered_class_is_a_type_error_naming_it():
    class Lonely(display.NotebookRepr):
        _renderer_module = None

    with pytest.raises(TypeError, match=r"test_display\..*Lonely"):
        display.html(Lonely())


def test_display_is_a_leaf_and_the_renderer_module_loads_on_first_display():
    """Importing an engine result class loads no report; showing it loads the renderers."""
    code = (
        "import sys, mtmetrology.display as d\n"
        "assert not [m for m in sys.modules if m.startswith('mtmetrology.') "
        "and m not in ('mtmetrology.display', 'mtmetrology._lazy')]\n"
        "from mtmetrology.kinematics import Machine\n"
        "assert 'mtmetrology.report' not in sys.modules and 'matplotlib' not in sys.modules\n"
        "from mtmetrology.kinematics.parameter_set import ParameterSet\n"
        "p = ParameterSet.zeros(Machine.load('three-axis-xfyz'))\n"
        "html = p._repr_html_()\n"
        "print('mtmetrology.report.results' in sys.modules, html.startswith('<div'))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.split() == ["True", "True"]
