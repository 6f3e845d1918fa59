"""Reproducible randomness: one seed, independent streams.

Every stochastic routine takes ``seed`` (an int, a :class:`numpy.random.SeedSequence`
or a :class:`numpy.random.Generator`).  Parallel work draws its streams from one
``SeedSequence`` by chunk index, never by worker, so a result does not depend on the
number of workers.
"""

from __future__ import annotations

import numpy as np

__all__ = ["SeedLike", "as_generator", "chunk_generators"]

SeedLike = int | np.random.SeedSequence | np.random.Generator | None


def as_generator(seed: SeedLike = None) -> np.random.Generator:
    """A PCG64 generator from a seed-like value (a Generator is returned as is)."""
    if isinstance(seed, np.random.Generator):
        return seed
    if isinstance(seed, np.random.SeedSequence):
        return np.random.Generator(np.random.PCG64(seed))
    return np.random.default_rng(seed)


def chunk_generators(seed: SeedLike, n_chunks: int) -> list[np.random.Generator]:
    """``n_chunks`` independent generators, the k-th depending only on (seed, k).

    A Generator passed as ``seed`` is used to draw the root entropy, so a call with
    the same Generator state is reproducible too.
    """
    if isinstance(seed, np.random.Generator):
        root = np.random.SeedSequence(int(seed.integers(2**63)))
    elif isinstance(seed, np.random.SeedSequence):
        root = seed
    else:
        root = np.random.SeedSequence(seed)
    return [np.random.Generator(np.random.PCG64(s)) for s in root.spawn(n_chunks)]
