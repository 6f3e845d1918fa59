"""Every case of the fixed catalogue: malformed inputs end with one clear line (exit 2/3,
nothing written), valid-but-unusual ones succeed."""

from __future__ import annotations

import pytest
from tests.fuzz.catalogue import base_files, cases
from tests.fuzz.corpus import materialise, run, sampled

# CI runs a fixed sample of the refusals and every accepted case; MTM_FUZZ=all runs all.
CASES = [c for c in cases() if c.expect == "accepted" or sampled(c.id)]


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_catalogue_case(case, tmp_path, census):
    paths = materialise(tmp_path, case.mutate(dict(base_files())))
    args = [a.format(**paths) for a in case.args]
    outcome = run(args, tmp_path, None if case.names is None else paths.get(case.names, case.names))
    label = (
        outcome.label
        if case.expect == "refused"
        else ("accepted" if outcome.exit_code == 0 and outcome.label != "slow" else "refused-valid")
    )
    census[label] += 1
    if case.expect == "accepted":
        assert label == "accepted", outcome
        return
    assert label == "clear", outcome
    assert outcome.exit_code == 2 or (outcome.exit_code == 3 and "option" in case.id), outcome
