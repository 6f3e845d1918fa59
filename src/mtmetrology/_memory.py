"""Keeping the resident memory of a run on millions of rows close to what it holds, and
refusing a run that would not fit.

Two allocators serve a run: glibc's ``malloc`` (numpy arrays, Python objects) and
Arrow's pool (the CSV reader's and writer's buffers).  Both keep freed memory for reuse,
so a process that reads a large file, frees the text and computes on the numbers would
otherwise stay as large as its largest moment, and the peaks of later steps add on top:

- glibc serves an allocation of at least its *mmap threshold* by ``mmap`` and returns it
  to the system when freed; smaller ones come from the heap, which gives back only its
  top.  The threshold adapts upwards to every mapped block freed (up to 32 MiB), so after
  the first 8 MB column of a million-row file is freed the next ones stay in the heap,
  fragment it and remain resident.  :func:`limit_heap_retention` fixes the threshold
  (which also stops the adaptation) at :data:`MMAP_THRESHOLD`: whole-column arrays are
  mapped and truly freed, while the per-chunk temporaries of a chunked computation (a few
  MiB) keep being reused from the heap without new page faults.  The heap's *trim
  threshold* (free memory kept at its top) is fixed at the same size, as glibc's own
  adaptation would have it grow: with its starting 128 KiB, every freed chunk temporary
  at the top would be given back and faulted in again for the next chunk.
- :func:`release_free_memory` hands back, after a large file is read, what both
  allocators hold free (Arrow's ``release_unused``, glibc's ``malloc_trim``).

And one check bounds a run before it starts: :func:`require_memory` refuses a request
whose estimated peak (from the sizes asked: trials, grid nodes, table points) exceeds half
of the memory available, saying how much it needs (issue 32: runs that grew until the
system killed them).

The allocator settings are for the command line (``mtm``), which owns its process; a
library call leaves the allocators of its host alone.  Elsewhere than on glibc (macOS,
Windows, musl) the glibc calls are skipped without a word.

References
----------
GNU C Library manual, "Memory Allocation Tunables" and ``mallopt(3)``, ``malloc_trim(3)``
(M_MMAP_THRESHOLD, its dynamic adjustment, and the trimming of the heap).

Examples
--------
>>> from mtmetrology import _memory
>>> _memory.limit_heap_retention() in (True, False)  # True on glibc
True
>>> _memory.release_free_memory()
"""

from __future__ import annotations

import os
import sys

from mtmetrology.errors import ResourceLimitError

#: Share of the available memory one run may plan to hold (the rest: the interpreter, the
#: temporaries of numpy's expressions, the other programs of the machine).
MEMORY_SHARE = 0.5
#: When the available memory cannot be read (no ``/proc/meminfo``, no ``sysconf``).
FALLBACK_AVAILABLE = 4 << 30

#: ``mallopt`` parameter numbers of the trim and mmap thresholds (glibc ``malloc.h``).
M_TRIM_THRESHOLD = -1
M_MMAP_THRESHOLD = -3
#: Allocations of at least this many bytes are mapped (and unmapped when freed): above the
#: per-chunk temporaries of the chunked kinematic chain and CSV writer (up to 8 MiB each,
#: reused from the heap at no page-fault cost), below the (n, 3) arrays of a million rows
#: (24 MB).  128 KiB, glibc's starting value, made ``mtm predict`` on 1 M rows spend
#: 0.6 s more CPU on page faults (bench/bench_csv.py).  Also the trim threshold.
MMAP_THRESHOLD = 16 << 20


def _glibc():
    """The C library when it is glibc, else None."""
    try:
        if not os.confstr("CS_GNU_LIBC_VERSION"):
            return None
        import ctypes

        return ctypes.CDLL(None)
    except (AttributeError, ValueError, OSError):  # no confstr, no such name, no libc
        return None


def limit_heap_retention() -> bool:
    """Fix glibc's mmap and trim thresholds at :data:`MMAP_THRESHOLD` for this process.

    Returns
    -------
    bool
        Whether they were set (False off glibc, or if ``mallopt`` refused).

    Notes
    -----
    ``MALLOC_MMAP_THRESHOLD_`` or ``MALLOC_TRIM_THRESHOLD_`` in the environment is the
    user's choice and wins: then nothing is changed.
    """
    libc = _glibc()
    if libc is None or {"MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_"} & set(os.environ):
        return False
    mapped = libc.mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)
    return bool(mapped and libc.mallopt(M_TRIM_THRESHOLD, MMAP_THRESHOLD))


def release_free_memory() -> None:
    """Return the free memory both allocators hold to the system (after a large read).

    Arrow's pool is released only when pyarrow is already loaded; glibc's heap is trimmed
    (``malloc_trim(0)``: its top, and the free pages inside it) only on glibc.
    """
    pyarrow = sys.modules.get("pyarrow")
    if pyarrow is not None:
        pyarrow.default_memory_pool().release_unused()
    libc = _glibc()
    if libc is not None:
        libc.malloc_trim(0)


def available_memory() -> int:
    """Bytes of memory the system can give a new allocation now.

    ``MemAvailable`` of ``/proc/meminfo`` (Linux: free plus reclaimable caches), else the
    physical memory (``sysconf``), else :data:`FALLBACK_AVAILABLE`.
    """
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, ValueError, OSError):
        return FALLBACK_AVAILABLE


def _gb(nbytes: float) -> str:
    return f"{nbytes / 1e9:.3g} GB"


def require_memory(nbytes: float, what: str, *, available: int | None = None) -> None:
    """Refuse, before any work, a run that would hold more than its share of the memory.

    The check every sized request (trials, grid nodes, table points, feature points) goes
    through at the door: its caller estimates the bytes the run holds at its peak from the
    sizes it was given, and the run is refused when that exceeds :data:`MEMORY_SHARE` of
    :func:`available_memory` -- rather than growing until the system kills it.

    Parameters
    ----------
    nbytes : float
        Estimated peak of the run, bytes.
    what : str
        The request and the reason of the estimate, e.g. ``"--grid 1000,1000,1000: 10⁹
        poses x 4 stations x 96 bytes"``; it starts the refusal.
    available : int, optional
        Bytes available (:func:`available_memory` when omitted; given by tests).

    Raises
    ------
    ResourceLimitError
        ``nbytes`` above the share, with both amounts in the message.

    Examples
    --------
    >>> require_memory(1e6, "a small run")
    >>> require_memory(3e9, "--trials 10**8: 30 bytes per trial", available=4 << 30)
    Traceback (most recent call last):
    ...
    mtmetrology.errors.ResourceLimitError: --trials 10**8: 30 bytes per trial: needs about \
3 GB of memory; 2.15 GB (half of the 4.29 GB available) is the limit of one run
    """
    free = available_memory() if available is None else int(available)
    limit = MEMORY_SHARE * free
    if not nbytes <= limit:
        raise ResourceLimitError(
            f"{what}: needs about {_gb(nbytes)} of memory; {_gb(limit)} (half of the "
            f"{_gb(free)} available) is the limit of one run"
        )
