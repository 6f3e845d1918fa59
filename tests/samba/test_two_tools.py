"""SAMBA records with a ``tool`` column: two stylus lengths in one test (Alami Mchichi
(2018) Table 4.4), each tool's vector estimated, and what the second length buys."""

import numpy as np
import pytest

from mtmetrology.design.inputs import default_indexations
from mtmetrology.errors import RankDeficientError
from mtmetrology.io.files import InputFileError
from mtmetrology.kinematics import Machine
from mtmetrology.samba import SambaArtefact, calibrate, read_records

BALLS = {
    "1": (-50.0, -50.0, 50.0),  # examples/samba/balls.yaml: within the travels
    "2": (50.0, -50.0, 75.0),
    "3": (50.0, 50.0, 60.0),
    "4": (-50.0, 50.0, 65.0),
    "SB1": (-100.0, 0.0, 30.0),
    "SB2": (100.0, 0.0, 30.0),
}
TOOLS = {"long": (0.0, 0.0, -150.0), "short": (0.0, 0.0, -130.0)}
ARTEFACT = SambaArtefact.model_validate(
    {
        "balls": [{"id": b, "diameter_mm": 25.4} for b in BALLS],
        "scale_bar": {"ends": ["SB1", "SB2"], "length_mm": 200.0, "u_mm": 0.001},
        "tools": [{"id": t, "vector_mm": list(v)} for t, v in TOOLS.items()],
    }
)


@pytest.fixture(scope="module")
def machine():
    """13 parameters plus E_AY1, which one stylus length confounds with E_YY1."""
    m = Machine.load("five-axis-wcbxfzyst", "13")
    return m.with_parameters([*m.parameter_names, "E_AY1"])


def _records(path, machine, theta, tool_of_row, offsets):
    """Noise-free indications of the machine with errors theta, each row with its tool
    (true vector = nominal + offset), written with a tool column."""
    rows = [(b, B, C, 0.0) for B, C in default_indexations()[::25] for b in "1234"]
    rows += [("SB1", 0, 0, 0), ("SB2", 0, 0, 0), ("SB1", 0, 90, 0), ("SB2", 0, 90, 0)]
    rows += [("SB1", 0, 0, s) for s in (90.0, 180.0, 270.0)]
    tools = [tool_of_row(i) for i in range(len(rows))]
    cols = {a: np.zeros(len(rows)) for a in machine.axis_names}
    for k, a in ((1, "B"), (2, "C"), (3, "S")):
        cols[a] = np.array([r[k] for r in rows], dtype=float)
    guess = machine.readings_from_customary(cols)
    true_tool = np.array([np.add(TOOLS[t], offsets[t]) for t in tools])
    q = machine.inverse(np.array([BALLS[r[0]] for r in rows]), guess, theta, tool=true_tool)
    cust = machine.readings_to_customary(q)
    lines = ["ball," + ",".join(machine.axis_names) + ",tool"]
    for r, c, t in zip(rows, cust, tools, strict=True):
        lines.append(f"{r[0]}," + ",".join(f"{v:.9f}" for v in c) + f",{t}")
    path.write_text("\n".join(lines) + "\n")
    return read_records(path, machine, ARTEFACT)


def test_one_stylus_length_is_refused_naming_the_pair_and_the_second_length(tmp_path, machine):
    rec = _records(tmp_path / "one.csv", machine, None, lambda i: "long", {"long": (0, 0, 0)})
    with pytest.raises(RankDeficientError) as err:
        calibrate(machine, rec, ARTEFACT, sigma=0.001, estimate_tool=True)
    assert any({"E_AY1", "E_YY1"} <= set(g) for g in err.value.confounded)
    assert "second stylus length" in str(err.value)


def test_two_stylus_lengths_identify_every_error_and_both_tools(tmp_path, machine):
    """Every other indication with the short stylus: full rank; noise-free readings of
    errors within ±50 µm, µrad, µm/m and tools 10-30 µm off nominal are recovered."""
    rng = np.random.default_rng(8)
    theta = 50.0 * rng.uniform(-1, 1, machine.n_params) * machine.parameter_scales
    offsets = {"long": (0.01, -0.02, 0.03), "short": (-0.015, 0.005, 0.02)}
    rec = _records(
        tmp_path / "two.csv", machine, theta, lambda i: ("long", "short")[i % 2], offsets
    )
    cal = calibrate(machine, rec, ARTEFACT, sigma=0.001, estimate_tool=True)
    doc = cal.to_dict()
    assert doc["identification"]["rank"] == doc["identification"]["unknowns"]
    got = cal.parameters.values / machine.parameter_scales
    np.testing.assert_allclose(got, theta / machine.parameter_scales, atol=1e-4)
    for t in doc["tools"]:
        np.testing.assert_allclose(
            t["vector_mm"], np.add(TOOLS[t["id"]], offsets[t["id"]]), atol=1e-7
        )


def test_a_tool_not_in_the_artefact_names_the_line(tmp_path, machine):
    path = tmp_path / "bad.csv"
    _records(path, machine, None, lambda i: "long", {"long": (0, 0, 0)})
    text = path.read_text().splitlines()
    text[3] = text[3].rsplit(",", 1)[0] + ",medium"
    path.write_text("\n".join(text) + "\n")
    with pytest.raises(InputFileError, match="line 4: tool 'medium' is not in the artefact"):
        read_records(path, machine, ARTEFACT)
