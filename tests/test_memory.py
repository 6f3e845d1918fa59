"""mtmetrology._memory: freed memory goes back to the system (glibc), silently skipped elsewhere.

The glibc effects are measured in a fresh interpreter (the resident set of its own
``/proc/self/statm``), so that the allocator of the test process is left as it was.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest

from mtmetrology import _memory


def _glibc() -> bool:
    try:
        return bool(os.confstr("CS_GNU_LIBC_VERSION"))
    except (AttributeError, ValueError):
        return False


glibc_only = pytest.mark.skipif(not _glibc(), reason="glibc's allocator only")

PROBE = """
import numpy as np
from mtmetrology import _memory

def resident():  # MiB
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096 / 2**20

print(_memory.limit_heap_retention())
base = resident()
for _ in range(3):  # three whole columns of a million rows (24 MB), in turn
    column = np.ones((1_000_000, 3))
    del column
print(resident() - base)
base = resident()
blocks = [np.ones(131_072) for _ in range(40)]  # 40 chunks of 1 MiB, from the heap
last = blocks.pop()  # the newest stays: the heap cannot shrink from its top
del blocks
print(resident() - base)
_memory.release_free_memory()
print(resident() - base)
"""


def _probe(**env) -> list[str]:
    done = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(PROBE)],
        capture_output=True,
        text=True,
        check=True,
        env={k: v for k, v in {**os.environ, **env}.items() if v is not None},
    )
    return done.stdout.split()


@glibc_only
def test_freed_columns_and_heap_chunks_go_back_to_the_system():
    """With the threshold fixed, three (10⁶, 3) arrays allocated and freed in turn leave
    less than 4 MiB resident (glibc's adaptive threshold would serve the second and third
    from the heap and keep them: about 23 MiB).  39 freed 1 MiB chunks under a live one
    stay resident until release_free_memory trims the heap: then less than 8 MiB remain."""
    applied, columns, held, released = _probe(
        MALLOC_MMAP_THRESHOLD_=None, MALLOC_TRIM_THRESHOLD_=None
    )
    assert applied == "True"
    assert float(columns) < 4.0
    assert float(held) > 30.0 and float(released) < 8.0


@glibc_only
@pytest.mark.parametrize("variable", ["MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_"])
def test_a_threshold_set_in_the_environment_wins(variable):
    applied = _probe(**{variable: "131072"})[0]
    assert applied == "False"


def test_without_glibc_both_calls_do_nothing(monkeypatch):
    """Off glibc (no ``CS_GNU_LIBC_VERSION``: macOS, musl; no ``os.confstr``: Windows)."""

    def no_such_name(name):
        raise ValueError("unrecognized configuration name")

    monkeypatch.setattr(os, "confstr", no_such_name)
    assert _memory.limit_heap_retention() is False
    assert _memory.release_free_memory() is None
    monkeypatch.delattr(os, "confstr")
    assert _memory.limit_heap_retention() is False


def test_require_memory_refuses_above_half_of_what_is_available_naming_both():
    _memory.require_memory(2e9, "--grid 10,10,10: 1000 poses", available=4 << 30)
    with pytest.raises(_memory.ResourceLimitError) as err:
        _memory.require_memory(2.2e9, "--grid 10,10,10: 1000 poses", available=4 << 30)
    message = str(err.value)
    assert message.startswith("--grid 10,10,10: 1000 poses: needs about 2.2 GB of memory;")
    assert "2.15 GB (half of the 4.29 GB available)" in message
    with pytest.raises(_memory.ResourceLimitError):  # NaN bytes is never under a limit
        _memory.require_memory(float("nan"), "x", available=4 << 30)


def test_available_memory_is_a_positive_number_of_bytes():
    assert _memory.available_memory() > 0
