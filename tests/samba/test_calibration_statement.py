"""Issue 31: a SAMBA calibration states itself in customary units with u, and its
``to_dict()`` carries the uncertainty evaluation attached to it, with the policy's k = 2."""

from __future__ import annotations

import pytest

from mtmetrology.formatting import format_result
from mtmetrology.samba import evaluate_uncertainty, indication_inputs

from .samba_helpers import NOISE


@pytest.fixture(scope="module")
def evaluated(noisy_calibration):
    cal = noisy_calibration
    inputs = indication_inputs(cal.problem, noise=NOISE)
    unc = evaluate_uncertainty(cal, inputs, "noise", method="guf")
    return cal, unc


def test_to_dict_of_a_calibration_with_its_uncertainty(evaluated):
    cal, unc = evaluated
    attached = cal.with_uncertainty(unc)
    doc = attached.to_dict()
    assert "uncertainty" not in cal.to_dict() and "uncertainty" in doc
    assert doc == cal.to_dict(unc)  # the attached evaluation is the one stated
    assert doc["coverage"]["k"] == 2.0
    outputs = doc["uncertainty"]["guf"]["outputs"]
    assert all(o["k"] == pytest.approx(2.0, abs=1e-9) for o in outputs)
    assert all(o["U"] == pytest.approx(o["k"] * o["u"]) for o in outputs)


def test_reprs_show_values_and_u_in_customary_units(evaluated):
    """``SambaUncertainty`` showed only ``source=…``; ``SambaCalibration`` mm values labelled
    µm. Both now list each parameter as ``name = value unit, u = … unit``."""
    cal, unc = evaluated
    expected = [format_result(o.value, o.u, o.unit, name=o.name) for o in unc.guf.outputs[:12]]
    assert repr(unc).splitlines()[1:13] == [f"  {line}" for line in expected]
    params = cal.with_uncertainty(unc).to_dict()["parameters"]
    shown = repr(cal.with_uncertainty(unc)).splitlines()
    assert "u from guf" in shown[0]
    assert shown[1] == "  " + format_result(
        params[0]["value"], params[0]["u"], params[0]["unit"], name=params[0]["name"]
    )
