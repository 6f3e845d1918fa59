"""DETMAX exchange (Mitchell 1974) over a candidate set, with rank-r information updates.

A design is a subset of ``size`` candidates. Each candidate adds a block of rows ``X_c``
(r × n) to the identification Jacobian (a (B, C) indexation: 3 rows per ball probed
there), so the information matrix is ``F = F_0 + Σ_{c∈design} X_cᵀ X_c`` (``F_0``: rows
every design has). One DETMAX iteration (Alami Mchichi 2018, §5.5 and Annex A; Mitchell
1974):

1. add the candidate outside the design whose addition gives the best criterion;
2. remove the member of the enlarged design whose removal gives the best criterion;
3. stop when the point removed is the point added (ξ⁺ = ξ⁻), or when the exchange does
   not improve the criterion by more than a relative ``tol``; else go to 1.

Step 2 never takes a worse design than the one it started from (removing the point just
added returns it), so the criterion never decreases along a run.

**Rank-r updates instead of one SVD per trial design.** With ``G = X_c F⁻¹`` and
``K = I_r ± G X_cᵀ`` (generalised matrix determinant lemma and Sherman–Morrison–Woodbury
formula; for a single row r = 1 they are the rank-1 lemma and Sherman–Morrison)::

    det(F ± XᵀX)   = det F · det K
    (F ± XᵀX)⁻¹    = F⁻¹ ∓ Gᵀ K⁻¹ G

every candidate of the set is scored with one product ``X F⁻¹`` and small r × r
determinants and solves, all candidates at once; the accepted exchange updates ``F⁻¹``
the same way (refreshed from scratch every ``refresh`` exchanges to bound rounding).
The criteria are those of :mod:`mtmetrology.design.criteria`: D, A and E on ``F`` in
the fixed reference scaling below (``log det F`` and ``trace F⁻¹`` follow exactly from the
updates), O1–O5 on the per-design column-scaled matrix ``D⁻¹ F D⁻¹``, ``D² = diag F``,
like the diagnostics. E and O1–O5 need the spectrum: they are scored by batched symmetric
eigenvalue problems of the n × n trial matrices (never an SVD of the tall Jacobian).

A tiny ridge ``δ·I`` (δ = 1e-12 of the mean diagonal over the candidate set) keeps ``F``
invertible when a random start is rank deficient, so the D (and A) scores still rank the
candidates by how much rank they restore; E and O1–O5 are evaluated without it (a
rank-deficient design has no value, and its exchanges follow the D scores until it has
full rank). The values reported for a final design are recomputed without it.

References
----------
Mitchell, T. J. (1974). An algorithm for the construction of "D-optimal" experimental
designs. *Technometrics* 16(2), 203–210.
Alami Mchichi, N. (2018). *Étalonnage des machines-outils à cinq axes : configuration
optimisée des artefacts et de la séquence de mesure de la méthode SAMBA en vue d'une
estimation efficace des erreurs géométriques*. PhD thesis, École Polytechnique de
Montréal, §5.5 and Annex A.
Harville, D. A. (1997). *Matrix Algebra from a Statistician's Perspective*. Springer,
§18.1–18.2 (determinant lemma, Woodbury formula).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import partial

import numpy as np

from mtmetrology._memory import require_memory
from mtmetrology.design.choices import SCALED_CRITERIA
from mtmetrology.design.criteria import (
    check_criterion,
    criterion_from_spectrum,
    scaled_spectrum,
)
from mtmetrology.errors import InputError, ResourceLimitError
from mtmetrology.rng import SeedLike, chunk_generators
from mtmetrology.uncertainty.executors import resolve_executor

__all__ = ["BlockInformation", "DetmaxResult", "DetmaxRun", "detmax", "detmax_run"]

#: Why a run stopped.
STOP_MESSAGES = {
    1: "converged: the candidate added is the candidate removed",
    2: "converged: no exchange improves the criterion",
    0: "stopped at the iteration limit",
}

#: Most random starts of one search: each is a complete exchange search (milliseconds to
#: seconds), and the best of a few dozen is the optimum in practice.
MAX_STARTS = 10_000
_CHUNK = 64  # trial matrices per batched eigenvalue call (bounds memory to 64·n² floats)


@dataclass
class _State:
    members: np.ndarray  # bool (N,)
    info: np.ndarray  # F (n, n) with ridge
    inverse: np.ndarray  # F⁻¹
    logdet: float
    n_measurements: int
    exchanges: int = 0


class BlockInformation:
    """Candidate blocks of Jacobian rows and the criterion of any subset of them.

    Parameters
    ----------
    fixed : ndarray, shape (n_fixed_rows, n)
        Rows every design contains (weighted Jacobian rows).
    blocks : ndarray, shape (N, r, n)
        Rows each candidate adds; zero rows pad candidates that add fewer than r rows
        (e.g. a ball not accessible at that indexation).
    criterion : str
        One of :data:`mtmetrology.design.choices.CRITERIA`.
    measurements_fixed : int
        Measurements (poses) in ``fixed`` (for O1).
    measurements : ndarray of int, shape (N,)
        Measurements each candidate adds.

    Notes
    -----
    The columns are rescaled once so that the information of the whole candidate set has
    a unit diagonal: a fixed reparametrisation that leaves D rankings and every O-index
    unchanged, makes A and E independent of the parameter units (a variance counts
    relative to what the whole candidate set would give), and keeps the updates well
    conditioned.
    """

    def __init__(self, fixed, blocks, criterion, measurements_fixed, measurements):
        fixed = np.asarray(fixed, dtype=float)
        blocks = np.asarray(blocks, dtype=float)
        if blocks.ndim != 3 or fixed.ndim != 2 or fixed.shape[1] != blocks.shape[2]:
            raise ValueError("blocks must be (N, r, n) and fixed (rows, n) with the same n")
        self.criterion = check_criterion(criterion)
        stacked = blocks.reshape(-1, blocks.shape[2])
        total = fixed.T @ fixed + stacked.T @ stacked
        scale = np.sqrt(np.diag(total))
        scale = np.where(scale > 0, scale, 1.0)
        self.fixed_info = (fixed.T @ fixed) / scale[:, None] / scale[None, :]
        self.blocks = blocks / scale
        self.ridge = 1e-12 * float(np.mean(np.diag(total / scale[:, None] / scale[None, :])))
        self.measurements_fixed = int(measurements_fixed)
        self.measurements = np.asarray(measurements, dtype=int)

    @property
    def n_candidates(self) -> int:
        return self.blocks.shape[0]

    @property
    def n_unknowns(self) -> int:
        return self.blocks.shape[2]

    # ------------------------------------------------------------------ state
    def information(self, members: np.ndarray) -> np.ndarray:
        """``F`` of a design from scratch (with the ridge), shape (n, n)."""
        x = self.blocks[members].reshape(-1, self.n_unknowns)
        return self.fixed_info + x.T @ x + self.ridge * np.eye(self.n_unknowns)

    def start(self, indices) -> _State:
        members = np.zeros(self.n_candidates, dtype=bool)
        members[np.asarray(indices, dtype=int)] = True
        state = _State(members, np.empty(0), np.empty(0), 0.0, 0)
        self.refresh(state)
        return state

    def refresh(self, state: _State) -> None:
        """Recompute ``F``, ``F⁻¹`` and ``log det F`` from scratch (Cholesky)."""
        f = self.information(state.members)
        chol = np.linalg.cholesky(f)
        inv_chol = np.linalg.solve(chol, np.eye(self.n_unknowns))
        state.info = f
        state.inverse = inv_chol.T @ inv_chol
        state.logdet = float(2.0 * np.sum(np.log(np.diag(chol))))
        state.n_measurements = self.measurements_fixed + int(self.measurements[state.members].sum())

    def value(self, state: _State) -> float:
        """Criterion of the current design, from the state (updated ``F``, ``F⁻¹``)."""
        if self.criterion == "D":
            return state.logdet
        if self.criterion == "A":
            return -float(np.trace(state.inverse))
        lam = self._spectrum(self._without_ridge(state.info), self.criterion)
        return float(criterion_from_spectrum(self.criterion, lam, state.n_measurements))

    def _without_ridge(self, info: np.ndarray) -> np.ndarray:
        """The spectral criteria see the true information: with the ridge, a column no
        row touches would scale to a perfect unit column."""
        return info - self.ridge * np.eye(self.n_unknowns)

    @staticmethod
    def _spectrum(info: np.ndarray, criterion: str) -> np.ndarray:
        if criterion in SCALED_CRITERIA:
            return scaled_spectrum(info)
        return np.linalg.eigvalsh(info)

    # ------------------------------------------------------------------ scores
    def scores(
        self, state: _State, sign: int, indices: np.ndarray, criterion: str | None = None
    ) -> np.ndarray:
        """Criterion after adding (sign +1) or removing (−1) each candidate in ``indices``.

        ``criterion`` overrides the space's own (the exchange of a rank-deficient start
        follows D); the space is never modified, so threads may share it.

        Returns
        -------
        ndarray, shape (len(indices),)
            ``−inf`` where the trial design is singular.
        """
        criterion = self.criterion if criterion is None else criterion
        if criterion not in ("D", "A"):
            return self._spectral_scores(state, sign, indices, criterion)
        x = self.blocks[indices]  # (k, r, n)
        n = x.shape[2]
        g = (x.reshape(-1, n) @ state.inverse).reshape(x.shape)  # one GEMM for all rows
        k_mat = np.eye(x.shape[1]) + sign * (g @ np.swapaxes(x, 1, 2))  # (k, r, r)
        s, logdet_k = np.linalg.slogdet(k_mat)
        if criterion == "D":
            return np.where(s > 0, state.logdet + logdet_k, -np.inf)
        # trace of the new inverse: trace F⁻¹ ∓ Σ G ∘ (K⁻¹ G)
        out = np.full(len(indices), -np.inf)
        ok = s > 0
        kg = np.linalg.solve(k_mat[ok], g[ok])
        out[ok] = -(np.trace(state.inverse) - sign * np.einsum("crk,crk->c", g[ok], kg))
        return out

    def _spectral_scores(self, state, sign, indices, criterion) -> np.ndarray:
        m = state.n_measurements + sign * self.measurements[indices]
        out = np.empty(len(indices))
        for lo in range(0, len(indices), _CHUNK):
            x = self.blocks[indices[lo : lo + _CHUNK]]
            trial = self._without_ridge(state.info)[None] + sign * (np.swapaxes(x, 1, 2) @ x)
            out[lo : lo + _CHUNK] = criterion_from_spectrum(
                criterion, self._spectrum(trial, criterion), m[lo : lo + _CHUNK]
            )
        return out

    def update(self, state: _State, index: int, sign: int) -> None:
        """Add (+1) or remove (−1) one candidate: Woodbury update of ``F⁻¹``, lemma for
        ``log det F``."""
        x = self.blocks[index]  # (r, n)
        g = x @ state.inverse
        k_mat = np.eye(x.shape[0]) + sign * (g @ x.T)
        state.inverse = state.inverse - sign * (g.T @ np.linalg.solve(k_mat, g))
        state.inverse = 0.5 * (state.inverse + state.inverse.T)
        state.logdet += float(np.linalg.slogdet(k_mat)[1])
        state.info = state.info + sign * (x.T @ x)
        state.members[index] = sign > 0
        state.n_measurements += sign * int(self.measurements[index])


@dataclass(frozen=True)
class DetmaxRun:
    """One DETMAX run from one random start.

    Attributes
    ----------
    members : ndarray of int
        Chosen candidates, ascending.
    start : ndarray of int
        The random starting subset.
    value : float
        Criterion of the final design (larger is better).
    start_value : float
        Criterion of the starting design.
    history : tuple of float
        Criterion after each accepted exchange, starting value first (non-decreasing).
    status : int
        1 or 2: converged (see ``message``); 0: iteration limit.
    """

    members: np.ndarray
    start: np.ndarray
    value: float
    start_value: float
    history: tuple[float, ...]
    status: int

    @property
    def message(self) -> str:
        return STOP_MESSAGES[self.status]

    @property
    def exchanges(self) -> int:
        return len(self.history) - 1


@dataclass(frozen=True)
class DetmaxResult:
    """Best of several DETMAX runs (ties: the earliest start).

    Attributes
    ----------
    best : DetmaxRun
    runs : tuple of DetmaxRun
        Every run, in start order.
    criterion : str
    """

    best: DetmaxRun
    runs: tuple[DetmaxRun, ...] = field(repr=False)
    criterion: str


def detmax_run(
    space: BlockInformation,
    start,
    *,
    max_iter: int = 500,
    tol: float = 1e-10,
    refresh: int = 10,
) -> DetmaxRun:
    """One DETMAX run from a given starting subset.

    Parameters
    ----------
    space : BlockInformation
        Candidates and criterion (or any object with the same ``start``, ``scores``,
        ``update``, ``refresh`` and ``value`` methods).
    start : sequence of int
        Starting subset (its size is the design size).
    max_iter : int
        Iteration limit (status 0 when reached).
    tol : float
        Smallest relative improvement that counts as one.
    refresh : int
        Recompute the state from scratch every ``refresh`` exchanges.

    Returns
    -------
    DetmaxRun
    """
    start = np.unique(np.asarray(start, dtype=int))
    state = space.start(start)
    value = space.value(state)
    history = [value]
    status = 0
    for _ in range(max_iter):
        outside = np.flatnonzero(~state.members)
        if outside.size == 0:
            status = 2
            break
        # a rank-deficient design has no spectral value: its exchanges follow the ridge
        # D criterion, which ranks candidates by the rank and volume they restore
        use = space.criterion if np.isfinite(value) else "D"
        added = int(outside[int(np.argmax(space.scores(state, +1, outside, use)))])
        space.update(state, added, +1)
        inside = np.flatnonzero(state.members)
        remove_scores = space.scores(state, -1, inside, use)
        best = int(np.argmax(remove_scores))
        keep_added = float(remove_scores[np.searchsorted(inside, added)])
        if float(remove_scores[best]) <= keep_added + tol * abs(keep_added):
            space.update(state, added, -1)
            status = 1 if int(inside[best]) == added else 2
            if not np.isfinite(value):
                status = 0  # still rank deficient: not a converged design
            break
        removed = int(inside[best])
        space.update(state, removed, -1)
        state.exchanges += 1
        if state.exchanges % refresh == 0:
            space.refresh(state)
        new_value = space.value(state)
        if use == space.criterion and new_value <= value + tol * abs(value):
            # the updates' rounding cannot buy an exchange: undo it and stop
            space.update(state, removed, +1)
            space.update(state, added, -1)
            status = 2
            break
        value = new_value
        history.append(value)
    members = np.flatnonzero(state.members)
    return DetmaxRun(
        members=members,
        start=start,
        value=history[-1],
        start_value=history[0],
        history=tuple(history),
        status=status,
    )


def _run_task(task, max_iter, tol):
    space, start = task
    return detmax_run(space, start, max_iter=max_iter, tol=tol)


def detmax(
    space: BlockInformation,
    size: int,
    *,
    starts: int = 8,
    seed: SeedLike = None,
    executor=None,
    max_iter: int = 500,
    tol: float = 1e-10,
) -> DetmaxResult:
    """DETMAX from several random starts; the best run wins.

    Parameters
    ----------
    space : BlockInformation
    size : int
        Number of candidates in the design.
    starts : int
        Random starting subsets; start k draws from stream k of ``seed``
        (:func:`mtmetrology.rng.chunk_generators`), so the result does not depend on the
        executor or its number of workers.
    seed : int, SeedSequence or Generator, optional
    executor : see :func:`mtmetrology.uncertainty.executors.resolve_executor`
        Where the runs execute (in-process by default; a process pool or Dask).
    max_iter, tol
        As in :func:`detmax_run`.

    Returns
    -------
    DetmaxResult

    Raises
    ------
    InputError
        If ``size`` is not between 1 and the number of candidates, or ``starts`` < 1.
    ResourceLimitError
        More than :data:`MAX_STARTS` starts, or more than the memory holds (before any run).

    Examples
    --------
    Quadratic regression on [−1, 1] (rows 1, t, t²): the 3-point D-optimal design is
    {−1, 0, 1} (Atkinson, Donev & Tobias 2007, §11.1).

    >>> t = np.linspace(-1, 1, 21)
    >>> blocks = np.stack([np.ones_like(t), t, t**2], axis=1)[:, None, :]
    >>> space = BlockInformation(np.zeros((0, 3)), blocks, "D", 0, np.ones(21, int))
    >>> res = detmax(space, 3, starts=4, seed=1)
    >>> t[res.best.members].tolist()
    [-1.0, 0.0, 1.0]
    """
    n = space.n_candidates
    if not 1 <= int(size) <= n:
        raise InputError(f"design size {size} must be between 1 and the {n} candidates")
    if int(starts) < 1:
        raise InputError(f"starts must be at least 1, got {starts}")
    if int(starts) > MAX_STARTS:
        raise ResourceLimitError(
            f"--starts {starts}: at most {MAX_STARTS} random starts (each is a complete "
            "exchange search; the best of a few dozen is already the optimum in practice)"
        )
    # each start keeps its generator (about 1 KB), its design and its run's result
    require_memory(int(starts) * (2048 + 16 * int(size)), f"--starts {starts}")
    gens = chunk_generators(seed, int(starts))
    tasks = [(space, np.sort(g.choice(n, int(size), replace=False))) for g in gens]
    runner, owned = resolve_executor(executor)
    try:
        runs = runner.map(partial(_run_task, max_iter=max_iter, tol=tol), tasks)
    finally:
        if owned:
            runner.close()
    values = np.array([r.value for r in runs])
    best = runs[int(np.argmax(values))]
    return DetmaxResult(best=best, runs=tuple(runs), criterion=space.criterion)
