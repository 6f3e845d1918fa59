"""The ``fit-result`` document built in the library: layout, units at the edge."""

import math

import numpy as np
import pytest

from mtmetrology.fitting.documents import FORM_NAMES, element_parameters, fit_document
from mtmetrology.fitting.elements import Circle, Cone


def test_element_parameters_carry_their_units():
    cone = Cone(apex=[1.0, 2.0, 3.0], direction=[0.0, 0.0, 1.0], half_angle=math.pi / 6)
    rows = element_parameters(cone)
    assert [(r["name"], r["unit"]) for r in rows] == [
        ("x0", "mm"),
        ("y0", "mm"),
        ("z0", "mm"),
        ("ax", "1"),
        ("ay", "1"),
        ("az", "1"),
        ("half_angle", "deg"),
    ]
    assert [r["value"] for r in rows[:6]] == [1.0, 2.0, 3.0, 0.0, 0.0, 1.0]
    assert rows[6]["value"] == pytest.approx(30.0, rel=1e-14)  # π/6 rad
    assert all(type(r["value"]) is float for r in rows)


def test_fit_document_layout_and_units():
    circle = Circle(centre=[10.0, -5.0], radius=25.0)
    residuals = np.array([-0.002, 0.001, 0.003, -0.002])  # mm
    doc = fit_document("circle", "ls", "ring.csv", circle, residuals, 0.005, extra={"status": 0})
    assert list(doc) == [
        "kind",
        "version",
        "source",
        "element",
        "method",
        "parameters",
        "residuals",
        "form_error",
        "status",
    ]
    assert (doc["kind"], doc["version"], doc["source"], doc["element"], doc["method"]) == (
        "fit-result",
        1,
        "ring.csv",
        "circle",
        "ls",
    )
    assert doc["parameters"] == [
        {"name": "x0", "value": 10.0, "unit": "mm"},
        {"name": "y0", "value": -5.0, "unit": "mm"},
        {"name": "r", "value": 25.0, "unit": "mm"},
    ]
    res = doc["residuals"]
    assert (res["n"], res["unit"]) == (4, "µm")
    # rms of (-2, 1, 3, -2) µm = sqrt(18/4) µm
    assert res["rms"] == pytest.approx(math.sqrt(4.5), rel=1e-12)
    assert res["min"] == pytest.approx(-2.0, rel=1e-12)
    assert res["max"] == pytest.approx(3.0, rel=1e-12)
    assert doc["form_error"]["name"] == "roundness" and doc["form_error"]["unit"] == "µm"
    assert doc["form_error"]["value"] == pytest.approx(5.0, rel=1e-12)
    assert doc["status"] == 0
    assert "status" not in fit_document("circle", "ls", "r", circle, residuals, 0.0)


@pytest.mark.parametrize(
    ("element", "form"),
    # ISO 12780-1 straightness, ISO 12781-1 flatness, ISO 12181-1 roundness,
    # ISO 12180-1 cylindricity; sphericity and conicity by analogy
    [
        ("line", "straightness"),
        ("plane", "flatness"),
        ("circle", "roundness"),
        ("sphere", "sphericity"),
        ("cylinder", "cylindricity"),
        ("cone", "conicity"),
    ],
)
def test_every_element_names_its_iso_form_error(element, form):
    assert FORM_NAMES[element] == form
