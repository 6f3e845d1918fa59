"""mtmetrology.rng: reproducible generators and chunk streams independent of worker count."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mtmetrology.rng import as_generator, chunk_generators


def test_a_generator_is_passed_through_unchanged():
    g = np.random.default_rng(1)
    assert as_generator(g) is g


def test_integer_seeds_and_seed_sequences_reproduce_numpy_pcg64():
    """The streams are numpy's PCG64 seeded the documented way, so a user can
    reproduce a result with numpy alone."""
    expected = np.random.Generator(np.random.PCG64(np.random.SeedSequence(2024))).random(5)
    np.testing.assert_array_equal(as_generator(2024).random(5), expected)
    np.testing.assert_array_equal(as_generator(np.random.SeedSequence(2024)).random(5), expected)
    assert isinstance(as_generator(None).bit_generator, np.random.PCG64)
    # no seed: fresh entropy, two calls differ
    assert as_generator(None).integers(2**63) != as_generator(None).integers(2**63)


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(min_value=0, max_value=2**64 - 1),
    k=st.integers(min_value=0, max_value=7),
    extra=st.integers(min_value=1, max_value=9),
)
def test_the_kth_stream_depends_only_on_seed_and_k(seed, k, extra):
    """Chunk k draws the same numbers whether the work is split in k+1 or k+1+extra
    chunks: the result does not depend on the number of workers."""
    few = chunk_generators(seed, k + 1)[k].random(4)
    many = chunk_generators(seed, k + 1 + extra)[k].random(4)
    np.testing.assert_array_equal(few, many)
    # and it is SeedSequence(seed).spawn(...)[k]
    child = np.random.SeedSequence(seed).spawn(k + 1)[k]
    np.testing.assert_array_equal(np.random.Generator(np.random.PCG64(child)).random(4), few)


def test_chunk_streams_are_distinct_and_uncorrelated():
    """Pairwise sample correlation of 20 000 uniform draws between 6 streams: under
    independence each is ~N(0, 1/n); |r| < 5/sqrt(n) for all 15 pairs (two-sided level
    about 1e-5 overall)."""
    n = 20_000
    draws = np.array([g.random(n) for g in chunk_generators(7, 6)])
    r = np.corrcoef(draws)
    off = r[np.triu_indices(6, 1)]
    assert np.all(np.abs(off) < 5 / np.sqrt(n))
    assert len({tuple(d[:3]) for d in draws}) == 6


def test_a_generator_seed_is_reproducible_from_its_state():
    a = chunk_generators(np.random.default_rng(11), 3)
    b = chunk_generators(np.random.default_rng(11), 3)
    for ga, gb in zip(a, b, strict=True):
        np.testing.assert_array_equal(ga.random(3), gb.random(3))
    # the passed generator advanced: a second call gives new streams
    g = np.random.default_rng(11)
    first = chunk_generators(g, 1)[0].random(3)
    second = chunk_generators(g, 1)[0].random(3)
    assert not np.array_equal(first, second)


def test_a_seed_sequence_root_gives_the_same_streams_on_every_call():
    """SeedSequence.spawn() is stateful; chunk_generators must not be."""
    root = np.random.SeedSequence(99)
    first = chunk_generators(root, 2)[1].random(3)
    second = chunk_generators(root, 2)[1].random(3)
    expected = np.random.Generator(np.random.PCG64(np.random.SeedSequence(99).spawn(2)[1]))
    np.testing.assert_array_equal(first, expected.random(3))
    np.testing.assert_array_equal(second, first)
    # the pool size of the root is kept
    wide = np.random.SeedSequence(99, pool_size=8)
    np.testing.assert_array_equal(
        chunk_generators(wide, 2)[1].random(3),
        np.random.Generator(
            np.random.PCG64(np.random.SeedSequence(99, pool_size=8).spawn(2)[1])
        ).random(3),
    )
    # a child sequence (non-empty spawn key) roots its own streams
    child = np.random.SeedSequence(99).spawn(3)[2]
    grandchild = np.random.SeedSequence(99).spawn(3)[2].spawn(2)[1]
    np.testing.assert_array_equal(
        chunk_generators(child, 2)[1].random(3),
        np.random.Generator(np.random.PCG64(grandchild)).random(3),
    )


@pytest.mark.parametrize("n", [0, 1, 5])
def test_the_number_of_streams_is_the_number_asked(n):
    assert len(chunk_generators(3, n)) == n
