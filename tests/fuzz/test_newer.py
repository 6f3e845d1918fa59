"""The extended corpus (issue 32): every newer command refuses each malformed input with
one clear line (exit 2, the file or option named, nothing written) and accepts its valid
input."""

from __future__ import annotations

import pytest
from tests.fuzz.corpus import run, sampled
from tests.fuzz.newer import cases, materialise, valid_files

# CI runs a fixed sample (every refusal class is in it across runs of the catalogue);
# MTM_FUZZ=all (make fuzz) runs every case.
CASES = [c for c in cases() if sampled(c.id, every=5)]


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_newer_command_case(case, tmp_path, census):
    paths = materialise(tmp_path, case.mutate(dict(valid_files())))
    args = [a.format(**paths) for a in case.args]
    names = None if case.names is None else paths.get(case.names, case.names)
    outcome = run(args, tmp_path, names)
    if case.expect == "accepted":
        label = (
            "accepted" if outcome.exit_code == 0 and outcome.label != "slow" else "refused-valid"
        )
        census[label] += 1
        assert label == "accepted", outcome
        return
    census[outcome.label] += 1
    assert outcome.label == "clear", outcome
    assert outcome.exit_code == 2, outcome
