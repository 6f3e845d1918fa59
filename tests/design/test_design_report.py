"""The plan report: words for counts, GUM digits, and a DETMAX section that shows something."""

import numpy as np

from mtmetrology.design.detmax import DetmaxResult, DetmaxRun
from mtmetrology.design.report import _count, add_convergence
from mtmetrology.report import Report


def _run(history):
    members = np.array([5, 9])
    return DetmaxRun(members, members, history[-1], history[0], tuple(history), 1)


def _blocks(rep):
    return [b for s in rep._sections for b in s.blocks]


def test_counts_are_written_in_words_with_the_plural():
    assert _count(2, "master ball") == "two master balls"
    assert _count(1, "master ball") == "one master ball"
    assert _count(0, "exchange") == "no exchanges"
    assert _count(13, "exchange") == "13 exchanges"


def test_start_already_optimal_is_said_in_words_not_drawn_as_one_point():
    """The demo's step 1 (starts=1): the start {5, 9} is a local optimum, history of one."""
    rep = Report("plan").section("DETMAX convergence")
    run = _run([-51.01])
    add_convergence(rep, "step 1: balls", DetmaxResult(run, (run,), "D"))
    blocks = _blocks(rep)
    assert [b.kind for b in blocks] == ["text"]
    assert "after no exchanges" in blocks[0].text and "local optimum" in blocks[0].text


def test_runs_with_exchanges_are_drawn_one_curve_per_start():
    rep = Report("plan").section("DETMAX convergence")
    runs = (_run([-46.7, -46.0, -45.6]), _run([-47.0]))
    add_convergence(rep, "step 2: indexations", DetmaxResult(runs[0], runs, "D"))
    (figure,) = _blocks(rep)
    assert figure.kind == "figure" and "after two exchanges" in figure.caption
    assert figure.svg.count("start 1") == 1 and figure.svg.count("start 2") == 1


def test_plan_tables_print_gum_digits_and_the_artefact_in_words(m13):
    """u and UPF with two significant digits (JCGM 100, 7.2.6), not 0.009459852299."""
    import re

    from lab_balls import LAB_CENTRES, LAB_IDS

    import mtmetrology.design.report  # noqa: F401  (registers the renderer)
    from mtmetrology.design.inputs import default_indexations
    from mtmetrology.design.samba import plan_samba
    from mtmetrology.report.results import add_result

    design = plan_samba(
        m13, default_indexations(), balls=(LAB_IDS[:2], LAB_CENTRES[:2]), k=3, starts=1, seed=1
    )
    rep = add_result(Report("plan"), design)
    artefact = next(s for s in rep._sections if s.heading == "Artefact")
    assert artefact.blocks[0].text.startswith("two master balls and a scale bar")
    tables = [b for b in _blocks(rep) if b.kind == "table"]
    u_table = next(t for t in tables if t.columns[:2] == ("parameter", "u"))
    doc = {p["name"]: p for p in design.to_dict()["parameters"]}
    for name, u, _unit, upf, _upf_unit in u_table.rows:
        for text, value in ((u, doc[name]["u"]), (upf, doc[name]["upf"])):
            digits = re.sub(r"^[0.]+", "", text.split("e")[0]).replace(".", "")
            assert len(digits) == 2, text  # two significant digits
            assert abs(float(text) - value) <= 0.05 * value  # rounded, not truncated away
    programme = dict(next(t for t in tables if t.columns == ("item", "value")).rows)
    assert programme["estimated duration, h"] == f"{design.to_dict()['duration_h']:.1f}"
