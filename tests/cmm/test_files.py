"""Plate, probe-set and position files: strict schemas, one-line errors naming the field."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.cmm.files import load_plate, load_positions, load_probes, rotation_matrix
from mtmetrology.io.files import InputFileError

PLATE = """kind: ball-plate
balls:
  - {id: "00", x_mm: 0, y_mm: 0, z_mm: 0}
  - {id: "01", x_mm: 100, y_mm: 0, z_mm: 0}
  - {id: "02", x_mm: 0, y_mm: 100, z_mm: 0}
"""


@pytest.mark.parametrize(
    ("text", "field"),
    [
        (PLATE, "u_mm"),  # neither u_mm nor covariance
        (PLATE + "u_mm: 0.001\ncovariance_mm2: [[1]]\n", "u_mm"),
        (PLATE.replace('"01"', '"00"') + "u_mm: 0.001\n", "listed twice"),
        (PLATE + "u_mm: .nan\n", "u_mm"),
        (PLATE + "u_mm: 0.001\nextra: 1\n", "extra"),
        (PLATE + "covariance_mm2: [[1, 0], [0, 1]]\n", "9x9"),
    ],
)
def test_bad_plate_files(tmp_path, text, field):
    p = tmp_path / "plate.yaml"
    p.write_text(text)
    with pytest.raises(InputFileError) as err:
        load_plate(p)
    msg = str(err.value)
    assert "\n" not in msg and str(p) in msg and field in msg


def test_plate_covariance_and_probes(tmp_path):
    p = tmp_path / "plate.yaml"
    p.write_text(PLATE + "u_mm: 0.002\n")
    plate = load_plate(p)
    np.testing.assert_allclose(plate.covariance, np.eye(9) * 4e-6)
    q = tmp_path / "probes.yaml"
    q.write_text("kind: probe-set\nprobes:\n  - {id: A, offset_mm: [0, 0, -100]}\n")
    probes = load_probes(q)
    r = tmp_path / "pos.yaml"
    r.write_text(
        "kind: ballplate-positions\npositions:\n  - {id: H, origin_mm: [1, 2, 3], probes: [B]}\n"
    )
    with pytest.raises(InputFileError) as err:
        load_positions(r, probes)
    assert "'B'" in str(err.value) and "positions[0].probes" in str(err.value)


def test_rotation_matrix_is_fixed_axis_xyz():
    """R = R_z R_y R_x: a plate turned 90° about X then 90° about Z has its x along +Y."""
    r = rotation_matrix(np.radians([90.0, 0.0, 90.0]))
    np.testing.assert_allclose(r @ [1.0, 0, 0], [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(r @ [0, 1.0, 0], [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(r.T @ r, np.eye(3), atol=1e-12)
