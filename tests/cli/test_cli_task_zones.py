"""``mtm task uncertainty --form minimum-zone``: the Monte Carlo solves every trial's zone
with the batched solver (fitting.batch_zones), and gets the per-set loop's answer."""

from __future__ import annotations

import json

import numpy as np
import pytest
import test_cli_task as base

from mtmetrology.fitting import zone_features


def _plate_points(d, n=9):
    """A 40 mm square face at Z ≈ 100 mm, 2-5 µm off flat: a generic minimum zone."""
    rng = np.random.default_rng(8)
    xy = rng.uniform(-20.0, 20.0, (n, 2))
    pts = np.column_stack([xy, 100.0 + 0.005 * rng.uniform(size=n)])
    q = base.MACHINE.inverse(pts, np.zeros((n, 6)))
    rows = ["point,X,Y,Z,B,C,i,j,k"] + [
        f"p{s + 1},{q[s, 0]:.6f},{q[s, 1]:.6f},{q[s, 2]:.6f},0,0,0,0,-1" for s in range(n)
    ]
    (d / "plate.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    return d / "plate.csv"


def _loop(self, stack, name):
    return zone_features._zones(stack, self.solve, name)


@pytest.mark.parametrize("feature", ["circle", "plane"])
def test_the_monte_carlo_of_a_minimum_zone_equals_the_per_set_loop(tmp_path, monkeypatch, feature):
    """Same seed, same draws: the Monte Carlo estimate and standard uncertainty of the
    minimum-zone form error agree with those of the per-set loop to 1e-9 mm."""
    d = base._files(tmp_path)
    points = base._bore_points(d) if feature == "circle" else _plate_points(d)
    args = (feature, "--form", "minimum-zone", "--method", "mcm", "--trials", "200", "--seed", "3")
    batched = base._run_on(d, points, *args, "--json")
    assert batched.exit_code == 0, batched.output
    monkeypatch.setattr(zone_features._ZoneShape, "solve_sets", _loop)
    looped = base._run_on(d, points, *args, "--json")
    assert looped.exit_code == 0, looped.output
    form_b = json.loads(batched.stdout)["outputs"][-1]
    form_l = json.loads(looped.stdout)["outputs"][-1]
    assert form_b["name"].startswith("minimum_zone_")
    assert form_b["value"] == pytest.approx(form_l["value"], abs=1e-9)
    assert form_b["u"] == pytest.approx(form_l["u"], abs=1e-9)
    assert form_b["u"] > 0
