"""--keep-a-priori-covariance on a calibrate command (multilateration as the example: the
option is one shared type, the rule one engine call): lengths with twice the stated noise,
the default scales the covariance by s², the option keeps it; both say so."""

from __future__ import annotations

import json

import numpy as np
from typer.testing import CliRunner

from mtmetrology.cli import build_app

STATIONS = """kind: multilateration-stations
version: 1
stations:
  - {name: S1, position_mm: [750, 50, 30], dead_path_mm: 100}
  - {name: S2, position_mm: [1250, 60, 40], dead_path_mm: 200}
  - {name: S3, position_mm: [760, 560, 20], dead_path_mm: 300}
  - {name: S4, position_mm: [1240, 540, 50], dead_path_mm: 400}
"""


def _run(group, *args):
    return CliRunner().invoke(build_app(group), [group, *map(str, args)])


def test_default_scales_and_the_option_keeps_the_a_priori_covariance(tmp_path):
    (tmp_path / "st.yaml").write_text(STATIONS)
    lengths = tmp_path / "l.csv"
    r = _run(
        "multilateration", "simulate", "--machine", "three-axis-xfyz", "--stations",
        tmp_path / "st.yaml", "--grid", "4,4,4", "--noise", "0.4um+0.6um/m", "--seed", 3,
        "-o", lengths,
    )  # fmt: skip
    assert r.exit_code == 0, r.output
    docs = {}
    for name, extra in (("scale", ()), ("a-priori", ("--keep-a-priori-covariance",))):
        out = tmp_path / f"{name}.json"
        r = _run(
            "multilateration", "calibrate", lengths, "--machine", "three-axis-xfyz",
            "-o", out, *extra,
        )  # fmt: skip
        assert r.exit_code == 0, r.output
        docs[name] = json.loads(out.read_text())
        adequacy = docs[name]["provenance"]["adequacy"]
        assert adequacy["rule"] == name and adequacy["significant"]
        assert adequacy["message"] in r.stdout
    scaled, kept = (docs[k]["provenance"]["adequacy"] for k in ("scale", "a-priori"))
    assert scaled["scaled"] and not kept["scaled"] and kept["factor"] == 1.0
    u_scaled = np.array([p["u"] for p in docs["scale"]["parameters"]])
    u_kept = np.array([p["u"] for p in docs["a-priori"]["parameters"]])
    np.testing.assert_allclose(u_scaled, np.sqrt(scaled["factor"]) * u_kept, rtol=1e-9)
