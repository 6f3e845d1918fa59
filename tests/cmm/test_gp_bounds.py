"""GP hyper-parameters at a bound are flagged; a non-rigid error separates GP and kinematic.

The demo's virtual CMM (``mtm demo``, ``examples/cmm_ballplate.py``): with rigid errors
of the seed model only, the GP with a seed-model mean has nothing left to fit, its
amplitude ends at the lower bound of its search range and it predicts the kinematic mean
(the two rows of the report's comparison were identical, issue 18); the result now says
so in a structured field. With the demo's non-rigid error the GP wins on the held-out
position.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from mtmetrology.cmm.compare import compare_models
from mtmetrology.cmm.files import load_plate, load_positions, load_probes
from mtmetrology.cmm.simulate import simulate_ballplate
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.units import to_internal

_SCRIPT = Path(__file__).resolve().parents[2] / "examples" / "cmm_ballplate.py"
_SPEC = importlib.util.spec_from_file_location("cmm_ballplate", _SCRIPT)
demo_cmm = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(demo_cmm)
SIGMA = float(to_internal(demo_cmm.SIGMA_UM, "µm"))


class _Files:
    """What ``demo_cmm._write_inputs`` needs of the demo context."""

    def __init__(self, root: Path) -> None:
        self.root = root

    def path(self, *parts: str) -> Path:
        return self.root.joinpath(*parts)

    def write_text(self, text: str, *parts: str) -> None:
        self.path(*parts).parent.mkdir(parents=True, exist_ok=True)
        self.path(*parts).write_text(text, encoding="utf-8")


@pytest.fixture(scope="module")
def demo_setup(tmp_path_factory):
    files = _Files(tmp_path_factory.mktemp("cmm"))
    demo_cmm._write_inputs(files)
    base = Machine.load(demo_cmm.CMM)
    plate = load_plate(files.path("cmm", "plate.yaml"))
    probes = load_probes(files.path("cmm", "probes.yaml"))
    positions = load_positions(files.path("cmm", "positions.yaml"), probes)
    truth = ParameterSet.load(files.path("cmm", "truth.yaml"), base)
    return base, truth.machine_for(base), truth, plate, probes, positions


def _compare(demo_setup, residual_error):
    base, machine, truth, plate, probes, positions = demo_setup
    campaign = simulate_ballplate(
        machine, truth.vector_for(machine), plate, positions, probes, sigma=SIGMA, seed=2026,
        residual_error=residual_error,
    )  # fmt: skip
    comparison = compare_models(
        base, campaign, plate, probes, demo_cmm.HELD_OUT, sigma=SIGMA, kinematic_model="seed"
    )
    return {r["model"].split()[0]: r for r in comparison.table}, comparison


def test_residual_error_moves_the_stylus_along_the_positive_axis(demo_setup):
    """Closed form: a constant e = +2 µm in Z puts the error-free model 2 µm below the
    target (p(q) = c − e), with exact readings and the certificate plate."""
    base, _, _, plate, probes, positions = demo_setup
    nominal = base.with_parameters([])
    e = np.array([0.0, 0.0, 2e-3])
    camp = simulate_ballplate(
        nominal, None, plate, positions, probes, sigma=0.0, perturb_plate=False,
        residual_error=lambda q: np.broadcast_to(e, q.shape),
    )  # fmt: skip
    rec = camp.records
    p = nominal.forward(rec.readings, None, tool=probes.offsets(rec.probes))
    np.testing.assert_allclose(p, camp.true_points - e, atol=1e-9)


def test_gp_at_bounds_is_flagged_and_rows_agree_on_a_rigid_machine(demo_setup):
    rows, comparison = _compare(demo_setup, None)
    assert rows["GP"]["rms_error_um"] == pytest.approx(rows["kinematic"]["rms_error_um"], abs=1e-3)
    flags = comparison.gp_at_bounds
    amplitude = {f["component"] for f in flags if f["hyperparameter"] == "amplitude s"}
    assert amplitude == {"x", "y", "z"}
    assert all(f["side"] == "lower" and f["value"] == pytest.approx(f["bound"], rel=0.02)
               for f in flags if f["hyperparameter"] == "amplitude s")  # fmt: skip
    assert comparison.to_dict()["gp_at_bounds"] == flags
    import mtmetrology.cmm.report  # noqa: F401  (registers the renderers)
    from mtmetrology.report.results import result_report

    rep = result_report(comparison)
    texts = [b.text for s in rep._sections for b in s.blocks if b.kind == "text"]
    assert sum("ended at a bound of their search range" in t for t in texts) == 1


def test_non_rigid_error_is_where_the_gp_wins(demo_setup):
    """The demo's e_z ∝ u²v², e_x ∝ uv²: the kinematic model cannot follow, the GP can."""
    rows, comparison = _compare(demo_setup, demo_cmm.non_rigid_error)
    kin, gp = rows["kinematic"], rows["GP"]
    assert gp["rms_error_um"] < 0.9 * kin["rms_error_um"]
    assert gp["coverage"] > kin["coverage"]
    flagged = {(f["component"], f["hyperparameter"]) for f in comparison.gp_at_bounds}
    assert ("z", "amplitude s") not in flagged and ("x", "amplitude s") not in flagged
