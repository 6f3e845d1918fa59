"""Datum choice by rank: which error parameters a set-up can identify, for any model.

An identification Jacobian ``[J_θ | J_ν]`` (machine parameters θ, nuisance unknowns ν such
as an instrument pose, ball centres or a tool offset) is rank deficient when the set-up
cannot see some combinations of parameters.  A *datum* keeps a maximal independent subset
of θ: the nuisance columns are taken first, then the candidates in a stated order (lower
degree before higher, so that E_ZZ3 rather than E_ZZ1 goes when three Z levels cannot
tell a cubic from a line); a candidate whose column, scaled to unit norm, has a component
orthogonal to the columns kept so far below ``rtol`` is dropped and named with the kept
parameters (and nuisance unknowns) it is confounded with.

The same function serves every topology and model; the bridge CMM's
:func:`mtmetrology.cmm.models.choose_datum` is the special case of its own reference
set-up.

Set-up-aware model terms (:func:`exposed_terms`): a model may leave out constants because
"they are absorbed by the tool offset and the instrument pose".  Whether they are depends on
the set-up: a constant rotation ε of the tool-side axes moves a tool tip at tool vector t by
ε × t, a common translation when there is one tool (absorbed by an instrument position or a
tool offset unknown) but a different one for each of several laterally offset tools.  The
check is the same rank test: the candidate columns against the model's columns and the
nuisance columns; a candidate with a component outside their span is exposed by the set-up
and is added to the model, the others are named with what absorbs them.

References
----------
Å. Björck, *Numerical Methods for Least Squares Problems*, SIAM, 1996, §2.7 (rank-revealing
column pivoting; Gram–Schmidt with re-orthogonalisation).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from mtmetrology.kinematics.parameters import parse_parameter

if TYPE_CHECKING:
    from collections.abc import Callable

    from mtmetrology.kinematics.machine import Machine

__all__ = [
    "Datum",
    "SetupTerms",
    "choose_datum",
    "constant_rotation_candidates",
    "degree_order",
    "exposed_terms",
]


@dataclass(frozen=True)
class Datum:
    """The parameters kept and dropped by :func:`choose_datum`.

    Attributes
    ----------
    kept : tuple of str
        Identifiable parameters, in the order of the candidates given.
    dropped : tuple of (str, tuple of str)
        Each dropped parameter with the kept parameters and nuisance unknowns its column
        is a combination of (empty: the set-up does not see it at all).
    rank : int
        Rank of the full Jacobian (kept parameters plus nuisance unknowns).
    n_unknowns : int
        Candidates plus nuisance unknowns.
    """

    kept: tuple[str, ...]
    dropped: tuple[tuple[str, tuple[str, ...]], ...]
    rank: int
    n_unknowns: int

    @property
    def dropped_names(self) -> tuple[str, ...]:
        return tuple(name for name, _ in self.dropped)

    @property
    def message(self) -> str:
        if not self.dropped:
            return f"rank {self.rank} of {self.n_unknowns}: every parameter is identifiable"
        parts = [f"{n} ~ {' + '.join(p)}" if p else f"{n} (not seen)" for n, p in self.dropped]
        return f"rank {self.rank} of {self.n_unknowns}; not identifiable: {'; '.join(parts)}"

    def to_dict(self) -> dict:
        return {
            "rank": self.rank,
            "n_unknowns": self.n_unknowns,
            "kept": list(self.kept),
            "dropped": [{"name": n, "confounded_with": list(p)} for n, p in self.dropped],
            "message": self.message,
        }

    @classmethod
    def from_dict(cls, doc: dict) -> Datum:
        dropped = tuple((d["name"], tuple(d["confounded_with"])) for d in doc["dropped"])
        return cls(tuple(doc["kept"]), dropped, int(doc["rank"]), int(doc["n_unknowns"]))


def degree_order(name: str) -> tuple:
    """Sort key of a parameter: location errors, then error motions by degree, then name."""
    try:
        p = parse_parameter(name)
    except ValueError:
        return (2, 0, name)
    if p.kind == "location":
        return (0, 0, name)
    return (1, p.degree, name)


def choose_datum(
    jacobian: np.ndarray,
    names: Sequence[str],
    *,
    nuisance: Sequence[str] = (),
    rtol: float = 1e-7,
    prefer: Sequence[str] = (),
    order=degree_order,
) -> Datum:
    """Keep the parameters whose columns are independent of the nuisance and kept columns.

    Parameters
    ----------
    jacobian : ndarray, shape (m, n + n_nuisance)
        Sensitivities of the observations to the candidate parameters (first ``n``
        columns, named ``names``) and to the nuisance unknowns (last columns).
    names : sequence of str
        The candidate parameters.
    nuisance : sequence of str
        Names of the nuisance unknowns (always kept, taken first).
    rtol : float
        A column (scaled to unit norm) whose component orthogonal to the kept columns is
        below ``rtol`` is dependent.
    prefer : sequence of str
        Candidates taken before all others.
    order : callable
        Sort key of the remaining candidates (default: :func:`degree_order`).

    Returns
    -------
    Datum

    Notes
    -----
    Classical Gram–Schmidt with one re-orthogonalisation per column on the column-scaled
    Jacobian ``J D⁻¹``; the partners of a dropped column are the kept columns with a
    non-negligible coefficient (above 10⁻⁶ of the largest) in its least-squares expansion.
    """
    jac = np.asarray(jacobian, dtype=float)
    n = len(names)
    if jac.ndim != 2 or jac.shape[1] != n + len(nuisance):
        raise ValueError(
            f"jacobian has shape {jac.shape}; expected (m, {n} + {len(nuisance)}) columns"
        )
    norms = np.linalg.norm(jac, axis=0)
    jac = jac / np.where(norms > 0, norms, 1.0)
    basis = np.zeros((jac.shape[0], 0))
    if len(nuisance):
        u, s, _ = np.linalg.svd(jac[:, n:], full_matrices=False)
        basis = u[:, s > rtol * max(s[0], 1e-300)]
    kept: list[int] = []
    dropped_idx: list[int] = []
    ranked = sorted(range(n), key=lambda j: (names[j] not in prefer, order(names[j])))
    for j in ranked:
        c = jac[:, j].copy()
        for _ in range(2):
            c -= basis @ (basis.T @ c)
        size = np.linalg.norm(c)
        if norms[j] > 0 and size > rtol:
            kept.append(j)
            basis = np.column_stack([basis, c / size])
        else:
            dropped_idx.append(j)
    all_names = [*names, *nuisance]
    independent = [*kept, *range(n, jac.shape[1])]
    dropped = []
    if dropped_idx:
        coef = np.linalg.lstsq(jac[:, independent], jac[:, dropped_idx], rcond=None)[0]
        for k, j in enumerate(dropped_idx):
            ck = np.abs(coef[:, k])
            big = np.flatnonzero(ck > 1e-6 * max(ck.max(initial=0.0), 1e-300))
            partners = tuple(all_names[independent[i]] for i in big) if norms[j] > 0 else ()
            dropped.append((names[j], partners))
    return Datum(
        tuple(names[j] for j in sorted(kept)),
        tuple(dropped),
        basis.shape[1],
        n + len(nuisance),
    )


@dataclass(frozen=True)
class SetupTerms:
    """Constants a model leaves out as absorbed, checked on one set-up (:func:`exposed_terms`).

    Attributes
    ----------
    candidates : tuple of str
        The constants checked, in the order they were taken.
    added : tuple of str
        Those the set-up exposes: added to the identified model.
    absorbed : tuple of (str, tuple of str)
        The others, each with the model parameters and nuisance unknowns that absorb it
        (empty: the set-up does not see it at all).
    """

    candidates: tuple[str, ...] = ()
    added: tuple[str, ...] = ()
    absorbed: tuple[tuple[str, tuple[str, ...]], ...] = ()

    @property
    def message(self) -> str:
        if not self.candidates:
            return "no constant left out of the model"
        absorbed = [f"{n} ~ {' + '.join(p)}" if p else f"{n} (not seen)" for n, p in self.absorbed]
        parts = []
        if self.added:
            parts.append(f"added (exposed by the set-up): {', '.join(self.added)}")
        if absorbed:
            parts.append(f"absorbed: {'; '.join(absorbed)}")
        return "; ".join(parts)

    def to_dict(self) -> dict:
        return {
            "candidates": list(self.candidates),
            "added": list(self.added),
            "absorbed": [{"name": n, "absorbed_by": list(p)} for n, p in self.absorbed],
            "message": self.message,
        }

    @classmethod
    def from_dict(cls, doc: dict) -> SetupTerms:
        absorbed = tuple((d["name"], tuple(d["absorbed_by"])) for d in doc["absorbed"])
        return cls(tuple(doc["candidates"]), tuple(doc["added"]), absorbed)


def constant_rotation_candidates(machine: Machine) -> tuple[str, ...]:
    """The degree-0 angular error motions of the tool-side axes the model does not have.

    ``E_AZ0, E_BZ0, E_CZ0, E_AY0, …`` (the axis nearest the tool first, so that a constant
    rotation of the tool is named on the axis that carries it): the constants a preset
    leaves out as absorbed by the tool offset and the instrument pose.
    """
    have = set(machine.parameter_names)
    return tuple(
        name
        for axis in reversed(machine.topology.tool_axes)
        for name in (f"E_{c}{axis}0" for c in "ABC")
        if name not in have
    )


def exposed_terms(
    jacobian_of: Callable[[Machine], np.ndarray],
    machine: Machine,
    nuisance: Sequence[str],
    *,
    candidates: Sequence[str] | None = None,
    rtol: float = 1e-7,
) -> SetupTerms:
    """Which left-out constants a set-up exposes, by rank (module notes).

    Parameters
    ----------
    jacobian_of : callable
        ``jacobian_of(m)`` → the set-up's identification Jacobian, shape (rows,
        ``m.n_params + len(nuisance)``), for a machine ``m`` with more active parameters
        (the application's own Jacobian: tracker points, interferometer lengths, ...).
    machine : Machine
        The model as identified (its active parameters: the datum).
    nuisance : sequence of str
        Names of the nuisance unknowns (instrument pose, station centres, tool offsets),
        the last columns of the Jacobian.
    candidates : sequence of str, optional
        Constants to check; :func:`constant_rotation_candidates` by default.
    rtol : float
        As in :func:`choose_datum`.

    Returns
    -------
    SetupTerms
        ``added``: candidates whose columns have a component outside the span of the
        model's and the nuisance columns (and of the candidates added before them).

    Notes
    -----
    :func:`choose_datum` with the model's parameters taken as nuisance (always kept,
    first), then the candidates in the order given.
    """
    cands = tuple(constant_rotation_candidates(machine) if candidates is None else candidates)
    if not cands:
        return SetupTerms()
    n, k = machine.n_params, len(cands)
    big = machine.with_parameters([*machine.parameter_names, *cands])
    jac = np.asarray(jacobian_of(big), dtype=float)
    cols = np.concatenate([jac[:, n : n + k], jac[:, :n], jac[:, n + k :]], axis=1)
    d = choose_datum(
        cols,
        cands,
        nuisance=[*machine.parameter_names, *nuisance],
        rtol=rtol,
        order=cands.index,
    )
    return SetupTerms(cands, d.kept, d.dropped)
