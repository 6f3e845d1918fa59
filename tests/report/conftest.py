"""Fixtures of the report tests: input files for each command with ``--report``, and the
headless browser that checks the pages.

Without Chromium the browser tests skip with the reason; with ``MTM_REQUIRE_BROWSER=1``
(set by ``.ci/run``) a missing browser fails them instead. Screenshots and printed PDFs
go to ``$MTM_TEST_ARTIFACTS/browser`` or ``test-artifacts/browser/`` (git-ignored).
"""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import numpy as np
import pytest
from chromium import Chromium, find_chromium

from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.samba import SambaSetup, probing_sequence

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"

ARTEFACT = """kind: samba-artefact
balls:
  - {id: "1", diameter_mm: 12.7}
  - {id: "2", diameter_mm: 12.7}
  - {id: SB1, diameter_mm: 12.7}
  - {id: SB2, diameter_mm: 12.7}
scale_bar: {ends: [SB1, SB2], length_mm: 305.2105, u_mm: 0.0012}
"""

#: E_X0C of the parameter set: a pure offset of the C axis line, −104.6 µm (mm here).
E_X0C_MM = -0.1046


@pytest.fixture(scope="session")
def command_inputs(tmp_path_factory) -> dict[str, Path]:
    """Files for one run of each command that writes a report.

    ``model``: GUM H.1 end gauge; ``sphere``: 20 points on a 12.7 mm sphere; ``poses``
    and ``artefact``: a two-ball SAMBA strategy with spindle indexing (30 B/C pairs);
    ``params``: a parameter set with only E_X0C; ``records``: two probing records.
    """
    d = tmp_path_factory.mktemp("command-inputs")
    m = Machine.load("five-axis-wcbxfzyst")
    rng = np.random.default_rng(7)
    u = rng.standard_normal((20, 3))
    points = 12.7 * u / np.linalg.norm(u, axis=1, keepdims=True)
    sphere = d / "sphere.csv"
    sphere.write_text("x,y,z\n" + "\n".join(",".join(f"{v:.9f}" for v in p) for p in points) + "\n")
    setup = SambaSetup(
        balls={"1": (-80, -40, 100), "2": (80, 120, 150)},
        scale_bar={"SB1": (-152.60525, 0, 30), "SB2": (152.60525, 0, 30)},
    )
    pairs = [(b, c) for b in (-90, -45, 0, 45, 90) for c in range(0, 360, 60)]
    ids, q = probing_sequence(m, setup, pairs)
    rows = zip(ids, m.readings_to_customary(q), strict=True)
    poses = d / "poses.csv"
    poses.write_text(
        "ball,X,Y,Z,B,C,S\n"
        + "\n".join(f"{i}," + ",".join(f"{v:.6f}" for v in r) for i, r in rows)
        + "\n"
    )
    (d / "artefact.yaml").write_text(ARTEFACT)
    values = np.zeros(m.n_params)
    values[m.parameter_names.index("E_X0C")] = E_X0C_MM
    ParameterSet(m.parameter_names, values, m.parameter_units, machine=m.name).save(
        d / "params.json"
    )
    records = d / "records.csv"
    records.write_text("id,X,Y,Z,B,C\np1,-138.565,94.656,196.232,-42,-293\np2,10,20,30,15,40\n")
    return {
        "model": EXAMPLES / "gum-h1-end-gauge.yaml",
        "sphere": sphere,
        "poses": poses,
        "n_poses": len(ids),
        "artefact": d / "artefact.yaml",
        "params": d / "params.json",
        "records": records,
    }


@pytest.fixture(scope="session")
def report_commands(command_inputs):
    """``commands(out)``: one ``mtm`` argument list per command with ``--report`` into out."""
    return lambda out: _report_commands(command_inputs, out)


def _report_commands(inputs: dict, out: Path) -> dict[str, list[str]]:
    return {
        "uncertainty": ["uncertainty", "run", str(inputs["model"]), "--method", "both",
                        "--trials", "20000", "--seed", "4",
                        "--report", str(out / "uncertainty.html")],
        "fit": ["fit", "sphere", str(inputs["sphere"]), "--report", str(out / "fit.html")],
        "identifiability": ["machine", "identifiability", "five-axis-wcbxfzyst",
                            str(inputs["poses"]), "--artefact", str(inputs["artefact"]),
                            "--report", str(out / "identifiability.html")],
        "predict": ["predict", "--machine", "five-axis-wcbxfzyst", "--params",
                    str(inputs["params"]), str(inputs["records"]), "-o", str(out / "xyz.csv"),
                    "--report", str(out / "predict.html")],
    }  # fmt: skip


@pytest.fixture(scope="session")
def browser():
    executable = find_chromium()
    missing = None
    if executable is None:
        missing = "Chromium not found (Debian: apt-get install chromium; or set MTM_CHROMIUM)"
    elif importlib.util.find_spec("websocket") is None:
        missing = "websocket-client not installed (pip install -e '.[test]')"
    if missing:
        if os.environ.get("MTM_REQUIRE_BROWSER") == "1":
            pytest.fail(f"MTM_REQUIRE_BROWSER=1 but {missing}")
        pytest.skip(f"browser checks skipped: {missing}")
    chromium = Chromium(executable)
    yield chromium
    chromium.close()


@pytest.fixture(scope="session")
def artefacts() -> Path:
    path = Path(os.environ.get("MTM_TEST_ARTIFACTS", ROOT / "test-artifacts")) / "browser"
    path.mkdir(parents=True, exist_ok=True)
    return path
