"""Fuzz suite settings: a sample in CI, everything with ``MTM_FUZZ=all`` (``make fuzz``).

The classes of every catalogue run are printed at the end of the session (the census
issue 9 asks for).
"""

from __future__ import annotations

import pytest
from tests.fuzz.corpus import CENSUS


def pytest_terminal_summary(terminalreporter):
    if CENSUS:
        counts = ", ".join(f"{label} {n}" for label, n in sorted(CENSUS.items()))
        terminalreporter.write_line(f"fuzz census ({sum(CENSUS.values())} runs): {counts}")


@pytest.fixture
def census():
    return CENSUS
