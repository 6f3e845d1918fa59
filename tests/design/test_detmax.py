"""DETMAX exchange: known optimum, rank-r updates against scratch, monotone runs,
reproducibility whatever the executor."""

import numpy as np
import pytest

from mtmetrology.design.choices import CRITERIA
from mtmetrology.design.criteria import criterion_from_spectrum, scaled_spectrum
from mtmetrology.design.detmax import BlockInformation, detmax, detmax_run
from mtmetrology.errors import InputError
from mtmetrology.uncertainty.executors import ProcessPoolExecutor


def random_space(criterion, n_candidates=60, rows=3, unknowns=8, seed=0):
    """Candidate blocks of unequal scales and a few zero (inaccessible) rows."""
    rng = np.random.default_rng(seed)
    blocks = rng.standard_normal((n_candidates, rows, unknowns))
    blocks *= np.logspace(-3, 3, unknowns)  # mixed parameter units
    blocks[::7, -1] = 0.0  # padded rows
    fixed = rng.standard_normal((2, unknowns)) * np.logspace(-3, 3, unknowns)
    return BlockInformation(fixed, blocks, criterion, 2, np.full(n_candidates, rows))


def scratch_value(space, members):
    """Criterion of a design from scratch (information matrix and eigenvalues)."""
    mask = np.zeros(space.n_candidates, bool)
    mask[members] = True
    f = space.information(mask)
    m = space.measurements_fixed + int(space.measurements[mask].sum())
    lam = scaled_spectrum(f) if space.criterion.startswith("O") else np.linalg.eigvalsh(f)
    return float(criterion_from_spectrum(space.criterion, lam, m))


def test_cubic_regression_d_optimum_is_found():
    """Cubic on [-1, 1]: the D-optimal 4-point design is {±1, ±1/√5} (Atkinson, Donev &
    Tobias 2007, §11.2); 81 candidates contain ±0.45 ≈ ±0.447."""
    t = np.linspace(-1, 1, 81)
    blocks = np.stack([t**0, t, t**2, t**3], axis=1)[:, None, :]
    space = BlockInformation(np.zeros((0, 4)), blocks, "D", 0, np.ones(81, int))
    res = detmax(space, 4, starts=4, seed=2)
    np.testing.assert_allclose(np.sort(t[res.best.members]), [-1, -0.45, 0.45, 1], atol=1e-12)


@pytest.mark.parametrize("criterion", ["D", "A", "E", "O2", "O5"])
def test_exchange_scores_agree_with_scratch_to_1e_9(criterion):
    """Every add/remove score (determinant lemma, Woodbury) equals the criterion of the
    trial design recomputed from scratch, after a whole run of updates."""
    space = random_space(criterion)
    run = detmax_run(space, np.arange(0, 60, 4), refresh=10**6)  # updates only
    state = space.start(run.members)
    for k in range(5):  # ten more rank-r updates of F⁻¹ and log det F, no refresh
        space.update(state, int(np.flatnonzero(~state.members)[k]), +1)
        space.update(state, int(np.flatnonzero(state.members)[0]), -1)
    members = np.flatnonzero(state.members)
    outside = np.flatnonzero(~state.members)
    add = space.scores(state, +1, outside)
    remove = space.scores(state, -1, members)
    for c, v in zip(outside, add, strict=True):
        assert v == pytest.approx(scratch_value(space, np.r_[members, c]), rel=1e-9)
    for c, v in zip(members, remove, strict=True):
        assert v == pytest.approx(scratch_value(space, members[members != c]), rel=1e-9)
    assert space.value(state) == pytest.approx(scratch_value(space, members), rel=1e-9)


@pytest.mark.parametrize("criterion", CRITERIA)
def test_criterion_never_decreases_and_run_stops_cleanly(criterion):
    space = random_space(criterion, seed=1)
    run = detmax_run(space, np.arange(12))
    assert np.all(np.diff(run.history) >= 0)
    assert run.status in (1, 2)  # converged, not the iteration limit
    assert run.value == pytest.approx(scratch_value(space, run.members), rel=1e-9)
    assert run.value >= run.start_value


def test_result_does_not_depend_on_the_number_of_workers():
    space = random_space("D", seed=2)
    serial = detmax(space, 10, starts=4, seed=11)
    with ProcessPoolExecutor(2) as pool:
        parallel = detmax(space, 10, starts=4, seed=11, executor=pool)
    assert [r.members.tolist() for r in serial.runs] == [r.members.tolist() for r in parallel.runs]
    assert serial.best.value == parallel.best.value
    other = detmax(space, 10, starts=4, seed=12)
    assert [r.start.tolist() for r in other.runs] != [r.start.tolist() for r in serial.runs]


def test_detmax_beats_the_best_of_many_random_subsets():
    """2000 random designs of the same size never beat the DETMAX design."""
    space = random_space("D", n_candidates=80, seed=3)
    res = detmax(space, 10, starts=4, seed=0)
    rng = np.random.default_rng(99)
    best_random = max(scratch_value(space, rng.choice(80, 10, replace=False)) for _ in range(2000))
    assert res.best.value > best_random


def test_bad_sizes_name_the_parameter():
    space = random_space("D")
    with pytest.raises(InputError) as err:
        detmax(space, 0)
    assert "design size" in str(err.value)
    with pytest.raises(InputError, match=r"^starts must be at least 1, got 0"):
        detmax(space, 5, starts=0)


@pytest.mark.parametrize("criterion", ["O2", "E", "A"])
def test_a_rank_deficient_start_is_repaired(criterion):
    """Start on candidates that never see the last two unknowns: the exchange follows the
    ridge D criterion until the design has full rank, then the requested one."""
    space = random_space(criterion, n_candidates=40, seed=4)
    space.blocks[:6, :, -2:] = 0.0
    space.fixed_info[:, -2:] = space.fixed_info[-2:, :] = 0.0
    run = detmax_run(space, np.arange(6))
    # no value for the spectral criteria; the ridge's huge penalty for A
    assert run.start_value == -np.inf if criterion != "A" else run.start_value < -1e9
    assert np.isfinite(run.value) and run.status in (1, 2)
    assert np.all(np.diff(run.history) >= 0)
