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

    The k-th stream is the one ``SeedSequence(seed).spawn(n)[k]`` gives for any
    ``n > k``, built from (entropy, spawn key, k) rather than by ``spawn()``: spawning
    is stateful, and a second call with the same SeedSequence object must give the same
    streams.  A Generator passed as ``seed`` is used to draw the root entropy, so a call
    with the same Generator state is reproducible too.

    Examples
    --------
    >>> a = chunk_generators(2024, 2)[1].random()
    >>> b = chunk_generators(2024, 8)[1].random()
    >>> a == b
    True
    """
    if isinstance(seed, np.random.Generator):
        root = np.random.SeedSequence(int(seed.integers(2**63)))
    elif isinstance(seed, np.random.SeedSequence):
        root = seed
    else:
        root = np.random.SeedSequence(seed)
    return [
        np.random.Generator(
            np.random.PCG64(
                np.random.SeedSequence(
                    root.entropy, spawn_key=(*root.spawn_key, k), pool_size=root.pool_size
                )
            )
        )
        for k in range(n_chunks)
    ]
