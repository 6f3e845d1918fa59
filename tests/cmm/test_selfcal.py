"""Probes and plate as unknowns: the source's design (Salacheep 2016, §4.4–4.5, Tables 4.1–4.2)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mtmetrology.cmm.selfcal import (
    THESIS_TABLES,
    SelfCalibrationDesign,
    selfcal_design,
    thesis_locations,
    thesis_plate,
)
from mtmetrology.errors import InputError
from mtmetrology.kinematics import Machine

FILE = Path(__file__).resolve().parents[2] / "examples" / "cmm" / "cmm-salacheep-xyz.yaml"
SIGMA = 0.0005
SETS = (("L0",), ("L1",), ("L2",), ("L0", "L1"), ("L0", "L1", "L2"))


@pytest.fixture(scope="module")
def designs():
    m = Machine.load(FILE)
    return {"+".join(s): selfcal_design(m, s, sigma=SIGMA, seed=1) for s in SETS}


def test_locations_are_the_sources_formulas():
    """Ball (x, y) at L1: (500 + u/√2, 500 − u/√2, 500 + w); at L2: (…, 500 + u/√2, …)."""
    y = thesis_plate()
    u, w = y[:, 0] - 500, y[:, 1] - 500
    locs = thesis_locations()
    h = 1 / np.sqrt(2)
    expected = {
        "L0": np.column_stack([y[:, 0], y[:, 1], np.full(9, 500.0)]),
        "L1": np.column_stack([500 + u * h, 500 - u * h, 500 + w]),
        "L2": np.column_stack([500 + u * h, 500 + u * h, 500 + w]),
    }
    for key, (r, t, _) in locs.items():
        np.testing.assert_allclose(y @ r.T + t, expected[key], atol=1e-12)
        assert np.linalg.det(r) == pytest.approx(1.0)


def test_each_constraint_fixes_what_it_names(designs):
    """All three locations: 10 free directions without constraints (plate frame 6, scale 1,
    stylus centroid 3); dropping one group frees exactly its own; the scale direction holds
    the three positioning (scale) errors."""
    f = designs["L0+L1+L2"].freedoms
    assert f["no constraints"]["free"] == 10
    assert f["without plate frame"]["free"] == 6
    assert f["without one length"]["free"] == 1
    assert f["without stylus centroid"]["free"] == 3
    assert f["all constraints"]["free"] == 0 and designs["L0+L1+L2"].full_rank
    scale = f["without one length"]["message"]
    assert all(n in scale for n in ("E_XX1", "E_YY1", "E_ZZ1"))


def test_location_0_alone_is_rank_deficient_as_the_source_says(designs):
    d = designs["L0"]
    assert not d.full_rank and d.U_full is None
    assert d.freedoms["all constraints"]["free"] > 0


def test_truncated_u1_falls_as_locations_are_added_tables_4_1_4_2(designs):
    """The trend of the tables: U1 (mean over axes) L1 > L0+L1 > L0+L1+L2, with K = 36."""
    u1 = {k: np.mean(d.U_truncated["U1"]) for k, d in designs.items()}
    assert u1["L1"] > u1["L0+L1"] > u1["L0+L1+L2"]
    pub = {k: np.mean(THESIS_TABLES[k]["U1"]) for k in ("L1", "L0+L1", "L0+L1+L2")}
    assert pub["L1"] > pub["L0+L1"] > pub["L0+L1+L2"]


def test_distance_from_the_published_u1_recorded(designs):
    """K = 36, σ = 0.5 µm. U1 of a single diagonal location is within 25 % of Table 4.1
    (0.21/0.21/0.22 against 0.21/0.26/0.27 µm at L1); for the combinations
    ours is 0.14–0.16 against 0.11–0.25 at L0+L1, 0.11–0.12 against 0.13–0.19 at L0+L1+L2.  Why
    not closer: the source's U1 passes the ball covariance through an unlisted NPL routine
    (xux2uzsp), its sphere centre is held fixed, and the ranking of its 36 kept singular
    values depends on its unlisted scaling."""
    for key in ("L1", "L2"):
        ratio = np.array(designs[key].U_truncated["U1"]) / THESIS_TABLES[key]["U1"]
        assert np.all((ratio > 0.75) & (ratio < 1.05)), (key, ratio)
    ratio = np.array(designs["L0+L1+L2"].U_truncated["U1"]) / THESIS_TABLES["L0+L1+L2"]["U1"]
    assert np.all((ratio > 0.5) & (ratio < 1.0)), ratio


def test_full_covariance_is_larger_than_the_truncated(designs):
    """Where the full covariance exists (L0+L1+L2) it is an order of magnitude above the
    truncated one and the published U1 (0.19/0.13/0.14 µm): 44 of the 80 free directions
    are weakly determined and the truncation simply leaves them out."""
    d = designs["L0+L1+L2"]
    for key in ("U1", "U2", "U3"):
        assert np.all(np.array(d.U_full[key]) > np.array(d.U_truncated[key]))
    assert np.all(np.array(d.U_full["U1"]) > 5 * np.array(THESIS_TABLES["L0+L1+L2"]["U1"]))


def test_round_trip_and_bad_input(designs):
    doc = designs["L0+L1"].to_dict()
    assert SelfCalibrationDesign.from_dict(doc).to_dict() == doc
    m = Machine.load(FILE)
    with pytest.raises(InputError, match="location 'L9'"):
        selfcal_design(m, ["L9"], sigma=SIGMA)
    with pytest.raises(InputError, match="truncation 500"):
        selfcal_design(m, ["L1"], sigma=SIGMA, truncation=500)
