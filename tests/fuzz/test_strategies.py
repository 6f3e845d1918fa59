"""Hypothesis strategies over the file schemas: a hostile value in any field of a valid
file ends with one clear line, and any cell text is either a strict number within the
axis travel (accepted) or refused with its line.

CI runs a few examples per strategy; ``MTM_FUZZ=all`` (``make fuzz``) runs many.
"""

from __future__ import annotations

import json
import math
import re
import tempfile
from pathlib import Path

import yaml
from hypothesis import given
from hypothesis import strategies as st
from tests.fuzz.catalogue import CHECK, PREDICT, base_files
from tests.fuzz.corpus import CENSUS, fuzz_settings, materialise, run

#: Values that are never a valid number in a file: non-finite, booleans, numbers as text,
#: nothing, containers.
NOT_A_NUMBER = st.one_of(
    st.sampled_from([math.nan, math.inf, -math.inf, True, False, None, [], {}]),
    st.floats(allow_nan=False, allow_infinity=False).map(lambda v: f"{v}"),
    st.text(max_size=8),
    st.lists(st.integers(-3, 3), min_size=4, max_size=5),
)

_NUMBER = re.compile(r"^[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?$")


def _numeric_leaves(doc, path=()):
    """Paths of every number in a parsed document (list indices and mapping keys)."""
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield from _numeric_leaves(v, (*path, k))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield from _numeric_leaves(v, (*path, i))
    elif isinstance(doc, int | float) and not isinstance(doc, bool):
        yield path


def _replaced(doc, path, value):
    doc = json.loads(json.dumps(doc))
    target = doc
    for key in path[:-1]:
        target = target[key]
    target[path[-1]] = value
    return doc


MACHINE_DOC = yaml.safe_load(base_files()["machine"])
MACHINE_LEAVES = list(_numeric_leaves(MACHINE_DOC))
PARAMS_DOC = json.loads(base_files()["params"])
PARAMS_LEAVES = [p for p in _numeric_leaves(PARAMS_DOC) if p[0] == "parameters"]


def _run_case(files, args, names, *, may_be_valid=False):
    """Run one generated case; count it in the census (``accepted`` for a valid input that
    succeeded, when the strategy can generate valid inputs)."""
    with tempfile.TemporaryDirectory() as d:
        directory = Path(d)
        paths = materialise(directory, files)
        outcome = run([a.format(**paths) for a in args], directory, paths[names])
    valid = may_be_valid and outcome.label == "silent"
    CENSUS["accepted" if valid else outcome.label] += 1
    return outcome


@fuzz_settings()
@given(path=st.sampled_from(MACHINE_LEAVES), value=NOT_A_NUMBER)
def test_a_hostile_value_anywhere_in_a_machine_file_is_refused(path, value):
    doc = _replaced(MACHINE_DOC, path, value)
    text = yaml.safe_dump(doc, allow_unicode=True, sort_keys=False)
    outcome = _run_case({**base_files(), "machine": text}, CHECK, "machine")
    assert outcome.label == "clear", (path, value, outcome)


@fuzz_settings()
@given(path=st.sampled_from(PARAMS_LEAVES), value=NOT_A_NUMBER)
def test_a_hostile_value_anywhere_in_a_parameter_set_is_refused(path, value):
    doc = _replaced(PARAMS_DOC, path, value)
    text = json.dumps(doc, allow_nan=True)
    outcome = _run_case({**base_files(), "params": text}, PREDICT, "params")
    assert outcome.label == "clear", (path, value, outcome)


TRAVEL = {0: (-220, 230), 1: (-170, 180), 2: (-110, 220), 3: (-90, 90), 4: (-360, 360)}
CELL = st.one_of(
    # a file holds UTF-8: no lone surrogate can be written to one (codec)
    st.text(alphabet=st.characters(codec="utf-8", exclude_characters=',"\r\n#'), max_size=12),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.floats(-1e4, 1e4).map(lambda v: f"{v:.3f}"),
)


@fuzz_settings()
@given(row=st.integers(1, 20), col=st.integers(0, 4), cell=CELL)
def test_any_cell_is_a_strict_number_within_the_travel_or_refused_with_its_line(row, col, cell):
    lines = base_files()["records"].split("\n")
    cells = lines[row].split(",")
    cells[col] = cell
    lines[row] = ",".join(cells)
    files = {**base_files(), "records": "\n".join(lines)}
    outcome = _run_case(files, PREDICT, "records", may_be_valid=True)
    text = cell.strip(" \t")
    blank_row = not ",".join(cells).strip(" \t,")
    if outcome.exit_code == 0:
        low, high = TRAVEL[col]
        assert blank_row or (_NUMBER.match(text) and low <= float(text) <= high), (cell, outcome)
    else:
        assert outcome.label == "clear", (cell, outcome)
        assert f"line {row + 1}" in outcome.stderr, (cell, outcome)


EXPRESSION = st.recursive(
    st.sampled_from(["a", "b", "1", "2.5", "pi", "0", "1e300", "x", "__a", "''", "a.b"]),
    lambda inner: st.one_of(
        st.tuples(inner, st.sampled_from(["+", "-", "*", "/", "**", "%", "<", "and"]), inner).map(
            lambda t: f"({t[0]} {t[1]} {t[2]})"
        ),
        st.tuples(
            st.sampled_from(["sqrt", "exp", "log", "sin", "hypot", "open", "abs"]), inner
        ).map(lambda t: f"{t[0]}({t[1]})"),
    ),
    max_leaves=12,
)


@fuzz_settings()
@given(expression=EXPRESSION)
def test_any_expression_is_evaluated_or_refused_in_one_line(expression):
    model = base_files()["model"].replace('"a + b"', json.dumps(expression), 1)
    args = ["uncertainty", "run", "{model}", "--method", "guf"]
    outcome = _run_case({**base_files(), "model": model}, args, "model", may_be_valid=True)
    assert outcome.label in ("clear", "silent"), (expression, outcome)
