"""The report of an export: the sections, the per-direction profiles with their bands, the
grid's slice and the residual maps of both directions."""

import numpy as np

from mtmetrology.export import report
from mtmetrology.export.workflow import export_compensation
from mtmetrology.kinematics import Machine
from mtmetrology.report.results import result_report


def _sections(rep):
    return {s.heading: [b.kind for b in s.blocks] for s in rep._sections}


def test_fanuc_report_draws_both_directions_with_bands_and_both_residual_maps(
    reversal_machine, make_set
):
    m = reversal_machine
    ps = make_set(m, {"E_XX1": 100.0, "E_XXb": 3.0}, u={"E_XX1": 5.0, "E_XXb": 0.5})
    result = export_compensation(m, ps, "fanuc", pitch=20, functions=["E_XX"])
    (row,) = result.tables
    assert len(row["correction_reverse"]) == len(row["correction"])
    # the negative-direction u includes the reversal term's: larger than the forward one
    assert np.all(np.asarray(row["u_reverse"]) > np.asarray(row["u"]) - 1e-12)
    fig = report.correction_profiles([row])
    (ax,) = fig.axes
    assert [line.get_label() for line in ax.get_lines()] == ["correction", "negative direction"]
    assert len(ax.collections) == 2  # the two ± U bands
    sections = _sections(result_report(result))
    tables = sections["Compensation tables: fanuc"]
    assert tables.count("figure") == 1 and "table" in tables
    residual = sections["Residual after the control applies the tables"]
    assert residual.count("figure") == 2  # both directions of approach


def test_grid_report_draws_the_slice_and_its_uncertainty(make_set):
    m = Machine.load("three-axis-xfyz")
    ps = make_set(m, {"E_YX2": 10.0}, u={"E_YX2": 0.5})
    result = export_compensation(m, ps, "grid", pitch=50)
    sections = _sections(result_report(result))
    assert sections["Compensation tables: grid"].count("figure") == 2
    assert sections["Residual after the control applies the tables"].count("figure") == 1
    piece = result.tables[0]["slice"]
    assert np.asarray(piece["length_um"]).shape == (len(piece["x_mm"]), len(piece["y_mm"]))


def test_the_report_says_what_each_file_means_and_whether_its_sign_is_established(make_set):
    m = Machine.load("three-axis-xfyz")
    result = export_compensation(m, make_set(m, {"E_XX1": 10.0}), "fanuc", pitch=20)
    rep = result_report(result)
    (section,) = [s for s in rep._sections if s.heading == "What the files mean to the control"]
    (table,) = [b for b in section.blocks if b.kind == "table"]
    assert [tuple(row[:3]) for row in table.rows] == [("fanuc_pitch.txt", "correction", "no")]
