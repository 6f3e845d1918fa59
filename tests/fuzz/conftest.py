"""Fuzz suite settings: a sample in CI, everything with ``MTM_FUZZ=all`` (``make fuzz``).

The classes of every catalogue run are printed at the end of the session (the census
issue 9 asks for).
"""

from __future__ import annotations

import os
import zlib
from collections import Counter

import pytest
from hypothesis import HealthCheck, settings

FULL = os.environ.get("MTM_FUZZ", "") == "all"
CENSUS: Counter = Counter()

settings.register_profile(
    "fuzz-ci", max_examples=8, deadline=None, suppress_health_check=list(HealthCheck)
)
settings.register_profile(
    "fuzz-all", max_examples=150, deadline=None, suppress_health_check=list(HealthCheck)
)


def sampled(case_id: str, every: int = 6) -> bool:
    """Whether a case runs in the CI sample (a fixed, spread subset of the catalogue)."""
    return FULL or zlib.crc32(case_id.encode()) % every == 0


def fuzz_settings():
    """The hypothesis settings of the current mode."""
    return settings.get_profile("fuzz-all" if FULL else "fuzz-ci")


def pytest_terminal_summary(terminalreporter):
    if CENSUS:
        counts = ", ".join(f"{label} {n}" for label, n in sorted(CENSUS.items()))
        terminalreporter.write_line(f"fuzz census ({sum(CENSUS.values())} runs): {counts}")


@pytest.fixture
def census():
    return CENSUS
