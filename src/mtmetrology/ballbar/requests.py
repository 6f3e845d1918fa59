"""What the ``mtm ballbar`` commands do, one library call each, from files and options.

- :func:`simulate_file` — a virtual test written as the neutral CSV;
- :func:`analyse_file` — the ISO 230-4 results of one or several tests;
- :func:`calibrate_files` — the diagnosis (identification) of one or several tests.

Tests come either as one CSV with its conditions given as options, or as a tests file
(YAML)::

    kind: ballbar-tests
    version: 1
    tests:
      - {file: xy100.csv, name: xy100, plane: XY, radius_mm: 100, feed_mm_per_min: 1000,
         centre_mm: [0, 0, 0], overshoot_deg: 180}

(``file`` relative to the tests file).  True or identified values at the command line are
``NAME=VALUE`` in the display units: the machine's customary unit of an ISO 230-1 name
(µm, µrad, µm/m), ms for ``servo_mismatch_ab``, µm for ``reversal_spike_a`` and
``length offset``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mtmetrology.ballbar.diagnose import BallbarDiagnosis, diagnose, simulate
from mtmetrology.ballbar.iso230_4 import CircularResults, circular_results
from mtmetrology.ballbar.model import DYNAMIC_UNITS
from mtmetrology.ballbar.records import (
    BallbarConditions,
    BallbarTest,
    nominal_test,
    read_ballbar,
    write_ballbar,
)
from mtmetrology.errors import InputError
from mtmetrology.formatting import format_uncertainty, format_value
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameters import parse_parameter
from mtmetrology.uncertainty.coverage import DEFAULT
from mtmetrology.units import to_internal

__all__ = [
    "CircularAnalysis",
    "analyse_file",
    "calibrate_files",
    "conditions_from_options",
    "diagnosis_summary",
    "display_unit_of_name",
    "load_tests",
    "simulate_file",
    "values_from_pairs",
]


def display_unit_of_name(machine: Machine, name: str) -> str:
    """Display unit of a ballbar unknown's name (ISO 230-1 or dynamic)."""
    if name.startswith("E_"):
        return machine.unit_of(parse_parameter(name))
    if name.startswith("servo_mismatch"):
        return DYNAMIC_UNITS["servo_mismatch"]
    return DYNAMIC_UNITS["length"]


def values_from_pairs(machine: Machine, pairs: Sequence[str], option: str) -> dict[str, float]:
    """``NAME=VALUE`` pairs in display units → internal values.

    Raises
    ------
    InputError
        A pair without ``=``, a value that is not a finite number, or an unknown name,
        naming the option.
    """
    out: dict[str, float] = {}
    for pair in pairs:
        name, sep, text = pair.partition("=")
        name = name.strip()
        try:
            value = float(text)
        except ValueError:
            value = float("nan")
        if not sep or not np.isfinite(value):
            raise InputError(f"{option} {pair!r}: expected NAME=VALUE with a finite number")
        if not (
            name.startswith(("E_", "servo_mismatch_", "reversal_spike_")) or name == "length offset"
        ):
            raise InputError(
                f"{option} {pair!r}: {name!r} is not an ISO 230-1 name, servo_mismatch_ab, "
                "reversal_spike_a or 'length offset'"
            )
        out[name] = float(to_internal(value, display_unit_of_name(machine, name)))
    return out


def conditions_from_options(
    plane: str | None,
    radius: float | None,
    feed: float | None,
    centre: Sequence[float] | None,
    overshoot_deg: float = 0.0,
    name: str = "test",
) -> BallbarConditions | None:
    """Conditions from command-line values (None when no plane is given).

    Raises
    ------
    InputError
        A plane without radius, feed or centre, naming the missing option.
    """
    if plane is None:
        return None
    for option, value in (("--radius", radius), ("--feed", feed), ("--centre", centre)):
        if value is None:
            raise InputError(f"{option} is required with --plane")
    return BallbarConditions(
        plane.upper(),
        float(radius),
        float(feed),
        np.asarray(centre, dtype=float),
        float(to_internal(overshoot_deg, "deg")),
        name,
    )


def load_tests(path: str | Path, conditions: BallbarConditions | None = None) -> list[BallbarTest]:
    """The tests of a tests file (YAML), or of one CSV with ``conditions``.

    Raises
    ------
    InputError
        A CSV without conditions, a tests file of another kind or with a missing field
        (named by test index and field), and every refusal of
        :func:`~mtmetrology.ballbar.records.read_ballbar`.
    """
    from mtmetrology.io.documents import load_document

    p = Path(path)
    if p.suffix.lower() not in (".yaml", ".yml"):
        if conditions is None:
            raise InputError(
                f"{p}: give the test conditions (--plane, --radius, --feed, --centre) or a "
                "tests file (YAML)"
            )
        return [read_ballbar(p, conditions)]
    doc = load_document(p, "ballbar tests file")
    if not isinstance(doc, dict) or doc.get("kind") != "ballbar-tests":
        raise InputError(f"{p}: kind must be ballbar-tests")
    entries = doc.get("tests")
    if not isinstance(entries, list) or not entries:
        raise InputError(f"{p}: tests: a list of at least one test")
    out = []
    for i, e in enumerate(entries):
        where = f"{p}: tests[{i}]"
        need = ("file", "plane", "radius_mm", "feed_mm_per_min", "centre_mm")
        missing = [k for k in need if not isinstance(e, dict) or k not in e]
        if missing:
            raise InputError(f"{where}: missing {missing[0]}")
        try:
            cond = BallbarConditions(
                str(e["plane"]),
                float(e["radius_mm"]),
                float(e["feed_mm_per_min"]),
                np.asarray(e["centre_mm"], dtype=float),
                float(to_internal(float(e.get("overshoot_deg", 0.0)), "deg")),
                str(e.get("name", f"test{i + 1}")),
            )
        except (TypeError, ValueError) as err:
            raise InputError(f"{where}: {err}") from None
        except InputError as err:
            raise InputError(f"{where}: {err}") from None
        out.append(read_ballbar(p.parent / str(e["file"]), cond))
    return out


def simulate_file(
    machine: Machine,
    conditions: BallbarConditions,
    truth: dict[str, float],
    output: str | Path,
    *,
    n_per_run: int = 360,
    noise: float = 0.0,
    seed=None,
) -> BallbarTest:
    """A virtual test of ``machine`` with the errors ``truth`` (internal units), written
    to ``output`` as the neutral CSV."""
    (test,) = simulate(
        machine, [nominal_test(conditions, n_per_run)], truth, sigma=noise, seed=seed
    )
    write_ballbar(test, output)
    return test


@dataclass(frozen=True)
class CircularAnalysis:
    """ISO 230-4 results of one or several tests (:func:`analyse_file`)."""

    machine: str | None
    tests: tuple
    results: tuple

    def to_dict(self) -> dict:
        return {
            "kind": "iso230-4-circular",
            "version": 1,
            "machine": self.machine,
            "category": "verification",
            "tests": [
                {"conditions": t.conditions.to_dict(), "source": t.source, **r.to_dict()}
                for t, r in zip(self.tests, self.results, strict=True)
            ],
        }

    def summary(self) -> str:
        lines = ["ISO 230-4 circular test (µm; G about the least-squares centre)"]
        for r in self.results:
            d = r.to_dict()
            for run in ("ccw", "cw"):
                f = d["radial_deviation_F"][run]
                lines.append(
                    f"  {r.name} {r.plane} {run:>3}: G = {d['circular_deviation_G'][run]:.2f}"
                    f"  F max = {f['max']:.2f}  F min = {f['min']:.2f}"
                )
            lines.append(f"  {r.name} {r.plane}     H = {d['circular_hysteresis_H']:.2f}")
        return "\n".join(lines)


def analyse_file(
    path: str | Path, conditions: BallbarConditions | None = None, *, machine: str | None = None
) -> CircularAnalysis:
    """The ISO 230-4 results (G, H, F) of the tests of ``path`` (see :func:`load_tests`)."""
    tests = load_tests(path, conditions)
    results: list[CircularResults] = [circular_results(t) for t in tests]
    return CircularAnalysis(machine, tuple(tests), tuple(results))


def calibrate_files(
    machine: Machine,
    path: str | Path,
    conditions: BallbarConditions | None = None,
    **options,
) -> BallbarDiagnosis:
    """The diagnosis of the tests of ``path``: :func:`~mtmetrology.ballbar.diagnose.diagnose`
    with ``options`` (parameters, dynamic, length_calibrated, sigma, adequacy,
    minimum_norm)."""
    return diagnose(machine, load_tests(path, conditions), **options)


def diagnosis_summary(result: BallbarDiagnosis) -> str:
    """Console lines of a diagnosis: each unknown with u (2 significant digits) and U, k."""
    lines = [
        f"Ballbar diagnosis of {result.machine.name}: {len(result.problem.tests)} test(s), "
        f"{result.problem.n_rows} readings",
        f"  {result.identification.message}",
        f"  covariance: {result.covariance_source}",
        f"  {'parameter':<22} {'value':>12} {'u':>9} {f'U ({DEFAULT.label})':>10}  unit",
    ]
    for row in result.parameter_rows():
        if row["nuisance"]:
            continue
        lines.append(
            f"  {row['name']:<22} {format_value(row['value'], row['u']):>12} "
            f"{format_uncertainty(row['u']):>9} {format_uncertainty(row['U']):>10}  {row['unit']}"
        )
    if result.advice:
        lines.append(f"  to separate what this set cannot: add {' or '.join(result.advice)}")
    return "\n".join(lines)
