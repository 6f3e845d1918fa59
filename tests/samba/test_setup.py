"""SAMBA helpers: the probing sequence (count, order, indications) and artefact files.

Measurement counts are those of Alami Mchichi (2018), eq. 5.14 and Table 5.5:
M_T = M·n + 2·(scale-bar placements) + n + 3 for one tool, which gives 22, 29 and 163
measurements for (1 ball, 14 configurations), (1 ball, 21) and (4 balls, 38).
"""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.identification.observations import ScaleBar
from mtmetrology.io.files import InputFileError
from mtmetrology.kinematics import Machine
from mtmetrology.samba import SambaSetup, probing_sequence
from mtmetrology.samba.artefact import load_artefact

BAR = {"SB1": (-152.60525, 0.0, 30.0), "SB2": (152.60525, 0.0, 30.0)}
FOUR_BALLS = {
    "1": (-80.0, -40.0, 100.0),
    "2": (80.0, -40.0, 150.0),
    "3": (80.0, 120.0, 75.0),
    "4": (-80.0, 120.0, 175.0),
}


def pairs(count: int) -> list[tuple[float, float]]:
    rng = np.random.default_rng(count)
    return [
        (float(b), float(c))
        for b, c in zip(rng.uniform(-90, 90, count), rng.uniform(0, 360, count), strict=True)
    ]


@pytest.mark.parametrize(
    ("balls", "configurations", "published"), [(1, 14, 22), (1, 21, 29), (4, 38, 163)]
)
def test_measurement_count_of_alami_mchichi_eq_5_14(balls, configurations, published):
    m = Machine.load("five-axis-wcbxfzyst")
    setup = SambaSetup(balls=dict(list(FOUR_BALLS.items())[:balls]), scale_bar=BAR)
    ids, readings = probing_sequence(m, setup, pairs(configurations))
    assert len(ids) == published
    assert readings.shape == (published, m.n_axes)


def test_sequence_order_and_indexations():
    """Balls at B = C = 0, the bar at (0°, 0°) and (0°, 90°), one ball at S = 90°, 180°,
    270°, then every ball at every (B, C) pair."""
    m = Machine.load("five-axis-wcbxfzyst")
    setup = SambaSetup(balls={"1": FOUR_BALLS["1"], "2": FOUR_BALLS["2"]}, scale_bar=BAR)
    ids, readings = probing_sequence(m, setup, [(45.0, 30.0), (-60.0, 200.0)])
    assert ids == ["1", "2", "SB1", "SB2", "SB1", "SB2", "1", "1", "1", "1", "2", "1", "2"]
    c = dict(zip(m.axis_names, m.readings_to_customary(readings).T, strict=True))
    np.testing.assert_allclose(c["B"], [0, 0, 0, 0, 0, 0, 0, 0, 0, 45, 45, -60, -60], atol=1e-9)
    np.testing.assert_allclose(c["C"], [0, 0, 0, 0, 90, 90, 0, 0, 0, 30, 30, 200, 200], atol=1e-9)
    np.testing.assert_allclose(c["S"][6:9], [90, 180, 270], atol=1e-9)
    # the spindle ball may be chosen
    chosen = SambaSetup(balls=setup.balls, scale_bar=BAR, spindle_ball="2")
    assert probing_sequence(m, chosen, [])[0][6:9] == ["2", "2", "2"]


@pytest.mark.parametrize("model", ["13", "84"])
def test_indications_put_the_stylus_on_the_ball_centres(model):
    """With the machine's errors, the forward model at the indications returns each ball
    centre (the readings are the inverse kinematics of the erroneous machine)."""
    m = Machine.load("five-axis-wcbxfzyst", model)
    rng = np.random.default_rng(5)
    theta = 20.0 * rng.standard_normal(m.n_params) * m.parameter_scales
    setup = SambaSetup(balls=FOUR_BALLS, scale_bar=BAR)
    senses = np.ones((4 + 4 + 3 + 4 * 6, m.n_axes))
    ids, readings = probing_sequence(m, setup, pairs(6), params=theta, senses=senses)
    centres = {**FOUR_BALLS, **BAR}
    targets = np.array([centres[i] for i in ids])
    np.testing.assert_allclose(m.forward(readings, theta, senses=senses), targets, atol=1e-9)
    # and the nominal readings miss them by the errors' effect
    assert np.abs(m.forward(readings) - targets).max() > 1e-3


def test_scale_bar_length_is_the_centre_distance():
    setup = SambaSetup(balls=FOUR_BALLS, scale_bar={"A": (0.0, 0.0, 0.0), "B": (3.0, 4.0, 12.0)})
    assert setup.scale_bar_length == 13.0


def test_a_sequence_needs_rotary_axes_b_and_c():
    m = Machine.load("three-axis-xfyz")
    with pytest.raises(InputError, match="three-axis-xfyz: a SAMBA sequence needs rotary axes"):
        probing_sequence(m, SambaSetup(balls=FOUR_BALLS), [(0.0, 0.0)])


ARTEFACT = """kind: samba-artefact
balls:
  - {id: "1", diameter_mm: 12.7}
  - {id: SB1, diameter_mm: 12.7}
  - {id: SB2, diameter_mm: 12.7}
scale_bar: {ends: [SB1, SB2], length_mm: 305.2105, u_mm: 0.0012}
stylus_tip_diameter_mm: 5.925
"""


def test_artefact_file_reads_into_scale_bars(tmp_path):
    path = tmp_path / "artefact.yaml"
    path.write_text(ARTEFACT)
    artefact = load_artefact(path)
    assert [b.id for b in artefact.balls] == ["1", "SB1", "SB2"]
    assert artefact.stylus_tip_diameter_mm == 5.925
    assert artefact.scale_bars() == [ScaleBar(("SB1", "SB2"), 305.2105, 0.0012)]
    path.write_text(ARTEFACT.split("scale_bar")[0])
    assert load_artefact(path).scale_bars() == []


@pytest.mark.parametrize(
    ("edit", "field"),
    [
        (
            lambda t: t.replace("{id: SB2, diameter_mm: 12.7}", "{id: SB1, diameter_mm: 12.7}"),
            "SB1",
        ),
        (lambda t: t.replace("ends: [SB1, SB2]", "ends: [SB1, SB9]"), "SB9"),
        (lambda t: t.replace("length_mm: 305.2105", "length_mm: -1"), "scale_bar.length_mm"),
        (lambda t: t.replace("diameter_mm: 12.7}", "diameter_mm: 12.7, colour: red}", 1), "colour"),
        (lambda t: t.replace("samba-artefact", "sphere"), "kind"),
        (
            lambda t: t.replace("stylus_tip_diameter_mm: 5.925", "stylus_tip_diameter_mm: 0"),
            "stylus",
        ),
    ],
)
def test_bad_artefact_files_are_refused_naming_file_and_field(tmp_path, edit, field):
    path = tmp_path / "artefact.yaml"
    path.write_text(edit(ARTEFACT))
    with pytest.raises(InputFileError) as err:
        load_artefact(path)
    message = str(err.value)
    assert str(path) in message and field in message
