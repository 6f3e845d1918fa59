"""Benchmark: compensation tables for a control and the residual check (issue 23).

Problem 1 — all tables and the residual check at 1 mm pitch (1° on rotary axes) for the
84-coefficient five-axis model (26 error functions, C over 720°: 721 points) and the
21-function three-axis model, ISG volumetric compensation (it carries every function):
``export_compensation`` builds the neutral model with the covariance of every table
(A U Aᵀ), the control tables and files, and the residual on the 5-per-axis check grid
(3 125 and 125 poses).  Contenders: ours; a vectorised numpy baseline of the tables alone
(``numpy.polynomial`` Vandermonde matrices times θ and A U Aᵀ from each function's own
columns, no files, no check); the
floor: writing the files once.

Problem 2 — the residual map on 10^6 poses of the three-axis model (tables at 1 mm):
``control.residual`` (r̂ only, and r̂ with its uncertainty); floors: writing the (10^6, 3)
result once, and one pass of the forward kinematics (the map needs three).

Targets (issue 23): problem 1 under 1 s; the map under 2 s.  Run:
``python bench/bench_export.py``.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from harness import Benchmark
from mtmetrology.export import isg
from mtmetrology.export.control import residual
from mtmetrology.export.model import compensation_model, function_columns
from mtmetrology.export.workflow import export_compensation
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet

POSES = 1_000_000


def parameter_set(machine: Machine, scale: float, u: float, seed: int) -> ParameterSet:
    rng = np.random.default_rng(seed)
    theta = rng.normal(0, scale, machine.n_params) * machine.parameter_scales
    cov = np.diag((u * machine.parameter_scales) ** 2)
    return ParameterSet(
        machine.parameter_names,
        theta,
        machine.parameter_units,
        cov,
        machine=machine.name,
        model=machine.model_name,
    )


def numpy_tables(machine: Machine, pset: ParameterSet, pitch: float) -> list:
    """The tables' values and covariances with numpy.polynomial (the baseline)."""
    theta, cov = pset.values, pset.covariance
    out = []
    for cols in function_columns(machine).values():
        axis = machine.axes[machine.parameters[cols[0]].axis]
        lo, hi = axis.travel
        step = pitch if axis.linear else np.radians(pitch)
        q = lo + step * np.arange(int(np.ceil((hi - lo) / step - 1e-9)) + 1)
        b = axis.basis
        u = (q - b.centre) / b.half_range
        degrees = [machine.parameters[j].degree or 0 for j in cols]
        vander = {
            "monomial": np.polynomial.polynomial.polyvander,
            "legendre": np.polynomial.legendre.legvander,
            "chebyshev": np.polynomial.chebyshev.chebvander,
        }[b.kind](u, max(degrees))
        a = np.zeros((q.size, machine.n_params))
        for j, d in zip(cols, degrees, strict=True):
            a[:, j] = vander[:, d] if machine.parameters[j].kind == "motion" else 1.0
        ac = a[:, cols]
        out.append((-a @ theta, ac @ cov[np.ix_(cols, cols)] @ ac.T))
    return out


def main() -> None:
    m5 = Machine.load("five-axis-wcbxfzyst", model="84")
    m3 = Machine.load("three-axis-xfyz")
    p5 = parameter_set(m5, 1e-3, 1e-4, seed=1)
    p3 = parameter_set(m3, 5.0, 0.3, seed=2)
    results = [export_compensation(m, p, "isg", pitch=1) for m, p in ((m5, p5), (m3, p3))]
    ours5 = compensation_model(m5, p5, pitch=1).table("E_XC").forward
    np.testing.assert_allclose(numpy_tables(m5, p5, 1.0)[-6][0], ours5, atol=1e-12)
    texts = {f"{k}_{n}": t for k, r in enumerate(results) for n, t in r.files.items()}
    tmp = Path(tempfile.mkdtemp())

    def write_files():
        for name, text in texts.items():
            (tmp / name).write_text(text)

    b = Benchmark(
        "export_tables",
        "ISG tables + covariance + residual check at 1 mm: five-axis 84 coefficients "
        "(3 125 check poses) and three-axis 21 functions (125)",
    )
    b.time(
        "export_compensation (both models)",
        "ours",
        lambda: [export_compensation(m, p, "isg", pitch=1) for m, p in ((m5, p5), (m3, p3))],
    )
    b.time(
        "numpy.polynomial tables + A U A^T only",
        "baseline",
        lambda: (numpy_tables(m5, p5, 1.0), numpy_tables(m3, p3, 1.0)),
        note="no control tables, files or check",
    )
    b.time("write the files once", "floor", write_files)
    b.target("export_compensation (both models)", 1.0, text="issue 23: under 1 s")
    b.notes.append("the machine is shared (2 cores, several users): min and median of 5 repeats")
    b.report()

    cm = compensation_model(m3, p3, pitch=1, covariance=False)
    tables, constants = isg.build(cm), isg.constants(cm)
    rng = np.random.default_rng(3)
    q = np.stack([rng.uniform(*m3.axes[a].travel, POSES) for a in m3.axis_names], axis=-1)
    theta, cov = cm.theta, p3.covariance
    out = np.empty((POSES, 3))
    path = tmp / "map.npy"
    r = Benchmark(
        "export_residual_map", f"residual after ISG tables at {POSES:,} poses, three-axis"
    )
    r.time(
        "residual r^ (control.residual)",
        "ours",
        lambda: residual(m3, theta, None, tables, q, constants=constants),
    )
    r.time(
        "residual r^ and u (J U J^T)",
        "ours",
        lambda: residual(m3, theta, cov, tables, q, constants=constants),
    )
    r.time("write the (10^6, 3) map once to disk", "floor", lambda: np.save(path, out))
    r.time("write the (10^6, 3) map once in memory", "floor", lambda: out.fill(0.0))
    r.time("one forward-kinematics pass", "floor", lambda: m3.forward(q, theta))
    r.target("residual r^ (control.residual)", 2.0, text="issue 23: under 2 s")
    r.notes.append("r^ needs three forward passes: with errors, nominal, and the tables applied")
    r.report()


if __name__ == "__main__":
    main()
