"""UPF per parameter in the SAMBA calibration's result, against the design's prediction."""

import csv

import numpy as np

from mtmetrology.design.inputs import ScaleBarPlacement, default_indexations
from mtmetrology.design.programme import evaluate_programme
from mtmetrology.kinematics import Machine
from mtmetrology.samba import SambaArtefact, calibrate, read_records

IDS = ["1", "2", "3", "4"]
CENTRES = np.array(
    [(-80.0, -40.0, 100.0), (80.0, -40.0, 150.0), (80.0, 120.0, 75.0), (-80.0, 120.0, 175.0)]
)


def test_calibration_upf_equals_the_designs_upf_for_the_same_setup(tmp_path):
    """Plan a programme (4 balls × 12 indexations, σ = 2 µm, bar u = 2 µm so that the bar's u
    is proportional to σ), write its nominal readings as records, calibrate them: at the
    nominal machine the calibration's Jacobian is the design's, so each UPF = u/σ equals
    the design's (Alami Mchichi (2018) eq. 6.14) to 1e-6 relative. The u themselves scale
    with σ: the same records calibrated with σ = 1 µm and a 1 µm bar give the same UPF."""
    m = Machine.load("five-axis-wcbxfzyst", "13")
    bar = ScaleBarPlacement(u_mm=0.002)
    prog = evaluate_programme(
        m, IDS, CENTRES, default_indexations()[::40][:12], bar=bar, sigma_mm=0.002
    )
    header, rows = prog.table()
    path = tmp_path / "records.csv"
    with path.open("w", newline="") as f:
        csv.writer(f).writerows([header, *rows])
    art = SambaArtefact.model_validate(
        {
            "balls": [{"id": b, "diameter_mm": 25.4} for b in [*IDS, *bar.ends]],
            "scale_bar": {"ends": list(bar.ends), "length_mm": bar.length, "u_mm": bar.u_mm},
        }
    )
    records = read_records(path, m, art)
    cal = calibrate(m, records, art, sigma=0.002, estimate_tool=True)
    got = cal.to_dict()["propagation_factors"]
    planned = prog.parameters()
    assert [g["name"] for g in got] == list(m.parameter_names)
    assert [g["upf_unit"] for g in got] == [p["upf_unit"] for p in planned]
    np.testing.assert_allclose([g["upf"] for g in got], [p["upf"] for p in planned], rtol=1e-6)
    np.testing.assert_allclose([g["u"] for g in got], [2.0 * g["upf"] for g in got], rtol=1e-12)
    art1 = art.model_copy(update={"scale_bar": art.scale_bar.model_copy(update={"u_mm": 0.001})})
    cal1 = calibrate(m, read_records(path, m, art1), art1, sigma=0.001, estimate_tool=True)
    np.testing.assert_allclose(
        [g["upf"] for g in cal1.propagation_factors()], [g["upf"] for g in got], rtol=1e-6
    )
