"""mtmetrology.io.plausibility: the shared plausibility checks refuse, in one line naming
the place, what is a number but not the quantity meant (issue 32)."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.io import plausibility as pl


def test_temperature_range_and_the_kelvin_hint():
    assert pl.check_temperatures([-50.0, 20.0, 100.0], "T").tolist() == [-50.0, 20.0, 100.0]
    with pytest.raises(InputError, match=r"^--t: 293.15 °C is outside .* \(kelvin\?"):
        pl.check_temperatures(293.15, "--t")
    with pytest.raises(InputError, match=r"^f.csv, line 4: 2000 °C is outside") as err:
        pl.check_temperatures([[20, 21], [22, 2000]], lambda i: f"f.csv, line {i + 1}")
    assert "kelvin" not in str(err.value)
    with pytest.raises(InputError, match="nan °C is outside"):
        pl.check_temperatures([20.0, np.nan], "T")
    with pytest.raises(InputError, match=r"-50\.1 °C"):
        pl.check_temperatures(-50.1, "T")


@pytest.mark.parametrize("value", [0.0, -282.0, float("nan"), float("inf")])
def test_positive_length(value):
    with pytest.raises(InputError, match=r"^--reference-mm: "):
        pl.check_positive(value, "--reference-mm")


def test_uncertainty_zero_is_allowed_negative_is_not():
    assert pl.check_uncertainty(0.0, "--u") == 0.0
    with pytest.raises(InputError, match=r"^--u: an uncertainty must be >= 0 µm, got -1$"):
        pl.check_uncertainty(-1.0, "--u", "µm")


def test_within_travel_with_a_margin():
    pl.check_within([800.0, 1200.0, 1219.0], 800.0, 1200.0, "X", margin=20.0)
    with pytest.raises(InputError, match=r"^row 3 = 1221 mm lies outside the travel \[800, 1200\]"):
        pl.check_within([800.0, 1200.0, 1221.0], 800.0, 1200.0, lambda i: f"row {i + 1}",
                        margin=20.0)  # fmt: skip


SCALES = [(305.21, True), (290.0, True), (0.30521, False), (305210.0, False), (30.0, False),
          (3000.0, False)]  # fmt: skip


@pytest.mark.parametrize(("value", "ok"), SCALES)
def test_scale_within_a_factor_of_root_ten(value, ok):
    if ok:
        pl.check_scale(value, 305.2, "bar")
    else:
        with pytest.raises(InputError, match=r"^bar: .* is the length in mm\?"):
            pl.check_scale(value, 305.2, "bar")


def test_distinct_files_by_content(tmp_path):
    a, b, c = tmp_path / "a.json", tmp_path / "b.json", tmp_path / "c.json"
    a.write_text("{}")
    b.write_text("{} ")
    c.write_text("{}")
    pl.distinct_files([a, b])
    with pytest.raises(InputError, match=rf"^{a}: is given twice"):
        pl.distinct_files([a, b, a])
    with pytest.raises(InputError, match=rf"^{c}: has the content of {a}"):
        pl.distinct_files([a, c])


def test_expansion_coefficient_in_per_kelvin():
    assert pl.check_expansion_coefficient(-2e-4, "a").tolist() == -2e-4
    with pytest.raises(InputError, match=r"^cte: 11.5 1/K is not an expansion coefficient"):
        pl.check_expansion_coefficient([11.5e-6, 11.5], "cte")
