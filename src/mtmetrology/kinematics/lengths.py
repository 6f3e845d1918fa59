"""Lengths between two machine positions predicted by a calibration, with u(L).

The machine is commanded to readings ``q_a`` and then ``q_b``; the tool tip lands at
``p(q; θ)`` (forward kinematics with the machine's true errors θ), and the length it
realises between them is

    L = ‖p(q_b; θ) − p(q_a; θ)‖.

A calibration gives the estimate θ̂ with covariance U_θ; the length it predicts is
``L̂ = ‖p(q_b; θ̂) − p(q_a; θ̂)‖`` and, to first order (JCGM 100:2008, 5.1.2 and 5.2: the
two points share θ̂, so their correlation is kept),

    u²(L) = g U_θ gᵀ,   g = ∂L/∂θ = nᵀ (G_b − G_a),   n = (p_b − p_a)/L̂,

with ``G = ∂p/∂θ`` (the kinematic engine's analytic Jacobian).  The readings are taken as
exact: the axes' repeatability, the drift since the calibration and the parameters the
calibration could not identify are not in u(L).  ``U = k·u(L)`` with k = 2 (about 95 %
for a normal distribution, JCGM 100:2008, 6.3.3).

A reference length L_ref of the same pair (a laser interferometer, a calibrated artefact)
with standard uncertainty u_ref gives the error ``e = L̂ − L_ref`` and the normalised
error ``E_n = |e| / (k·√(u²(L) + u_ref²))`` (ISO 13528:2015, 9.7; E_n ≤ 1 agrees).

References
----------
JCGM 100:2008, *Evaluation of measurement data — Guide to the expression of uncertainty in
measurement*, 5.1.2, 5.2, 6.3.3.
ISO 13528:2015, *Statistical methods for use in proficiency testing by interlaboratory
comparison*, 9.7 (E_n numbers).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mtmetrology.display import NotebookRepr
from mtmetrology.errors import InputError
from mtmetrology.formatting import format_k, format_uncertainty, format_value
from mtmetrology.io.tables import read_csv_table
from mtmetrology.kinematics.machine import Machine
from mtmetrology.units import from_internal, to_internal

__all__ = ["PairLengths", "pair_lengths", "read_reference_lengths"]

KIND = "length-prediction"


@dataclass(frozen=True, eq=False)
class PairLengths(NotebookRepr):
    """Result of :func:`pair_lengths` (module notes).

    Attributes
    ----------
    names : tuple of str
        The pairs.
    nominal : (n,) ndarray
        ``‖p(q_b; 0) − p(q_a; 0)‖``, mm.
    predicted : (n,) ndarray
        L̂, mm.
    u : (n,) ndarray
        u(L), mm (k = 1).
    k : float
        Coverage factor of the stated U.
    reference, u_reference : (n,) ndarray or None
        Reference lengths and their standard uncertainties, mm.
    """

    names: tuple[str, ...]
    nominal: np.ndarray
    predicted: np.ndarray
    u: np.ndarray
    k: float = 2.0
    reference: np.ndarray | None = None
    u_reference: np.ndarray | None = None

    @property
    def errors(self) -> np.ndarray | None:
        """``L̂ − L_ref``, mm (None without references)."""
        return None if self.reference is None else self.predicted - self.reference

    @property
    def en(self) -> np.ndarray | None:
        """``|e| / (k·√(u² + u_ref²))`` (None without references)."""
        if self.reference is None:
            return None
        return np.abs(self.errors) / (self.k * np.hypot(self.u, self.u_reference))

    def to_dict(self) -> dict:
        doc = {
            "kind": KIND,
            "version": 1,
            "k": self.k,
            "model": "L = |p(q_b; θ) - p(q_a; θ)|, u²(L) = g U_θ gᵀ (readings exact)",
            "pairs": [
                {
                    "pair": name,
                    "nominal_mm": float(self.nominal[i]),
                    "length_mm": float(self.predicted[i]),
                    "u_um": float(from_internal(self.u[i], "µm")),
                    "U_um": float(from_internal(self.k * self.u[i], "µm")),
                }
                for i, name in enumerate(self.names)
            ],
        }
        if self.reference is not None:
            for i, row in enumerate(doc["pairs"]):
                row.update(
                    reference_mm=float(self.reference[i]),
                    u_reference_um=float(from_internal(self.u_reference[i], "µm")),
                    error_um=float(from_internal(self.errors[i], "µm")),
                    en=float(self.en[i]),
                )
            doc["within"] = int(np.sum(self.en <= 1.0))
        return doc

    def summary(self) -> str:
        lines = [
            f"{len(self.names)} lengths from the calibration (u at k = 1, U at k = {self.k:g})"
        ]
        for i, name in enumerate(self.names):
            u = float(from_internal(self.u[i], "µm"))
            text = (
                f"  {name}: L = {format_value(self.predicted[i], self.u[i])} mm (nominal "
                f"{self.nominal[i]:.4f} mm), u(L) = {format_uncertainty(u)} µm, "
                f"U = {format_uncertainty(self.k * u)} µm (k = {format_k(self.k)})"
            )
            if self.reference is not None:
                e = float(from_internal(self.errors[i], "µm"))
                text += (
                    f"; reference {self.reference[i]:.4f} mm, e = {e:.2f} µm, E_n {self.en[i]:.2f}"
                )
            lines.append(text)
        if self.reference is not None:
            lines.append(
                f"  {int(np.sum(self.en <= 1.0))} of {len(self.names)} within "
                f"|e| <= k·sqrt(u(L)² + u_ref²)"
            )
        return "\n".join(lines)


def pair_lengths(
    machine: Machine,
    parameters: np.ndarray,
    covariance: np.ndarray,
    readings_a: np.ndarray,
    readings_b: np.ndarray,
    *,
    tool: np.ndarray | None = None,
    names: Sequence[str] | None = None,
    reference: np.ndarray | None = None,
    u_reference: np.ndarray | None = None,
    k: float = 2.0,
) -> PairLengths:
    """Lengths between pairs of machine positions with u(L) from the full covariance.

    Parameters
    ----------
    machine : Machine
        With the calibration's parameters active.
    parameters : (P,) ndarray
        θ̂, internal units, ``machine.parameter_names`` order.
    covariance : (P, P) ndarray
        U_θ.
    readings_a, readings_b : (n, n_axes) ndarray
        The two ends of each pair, internal units.
    tool : (3,) or (n, 3) ndarray, optional
        Tool vector, mm (the machine's when omitted).
    names : sequence of str, optional
        Pair names (1, 2, … when omitted).
    reference, u_reference : (n,) ndarray, optional
        Reference lengths and their standard uncertainties, mm.
    k : float
        Coverage factor of U.

    Returns
    -------
    PairLengths

    Raises
    ------
    InputError
        Readings of different shapes, a covariance of the wrong size, a pair of zero length
        (no direction to project on), a reference without its uncertainty.
    """
    qa, qb = np.atleast_2d(readings_a), np.atleast_2d(readings_b)
    if qa.shape != qb.shape:
        raise InputError(f"pairs: {qa.shape} readings at end a, {qb.shape} at end b")
    cov = np.asarray(covariance, dtype=float)
    if cov.shape != (machine.n_params, machine.n_params):
        raise InputError(f"covariance: {cov.shape} for {machine.n_params} parameters")
    if (reference is None) != (u_reference is None):
        raise InputError("a reference length needs its standard uncertainty")
    ev_a = machine.evaluate(qa, parameters, tool=tool, d_params=True)
    ev_b = machine.evaluate(qb, parameters, tool=tool, d_params=True)
    d = ev_b.position - ev_a.position
    length = np.linalg.norm(d, axis=1)
    if np.any(length <= 0):
        i = int(np.flatnonzero(length <= 0)[0])
        raise InputError(f"pair {i + 1 if names is None else names[i]}: both ends at one point")
    g = np.einsum("nc,ncp->np", d / length[:, None], ev_b.d_params - ev_a.d_params)
    u = np.sqrt(np.einsum("np,pq,nq->n", g, cov, g))
    nominal = np.linalg.norm(
        machine.forward(qb, tool=tool) - machine.forward(qa, tool=tool), axis=1
    )
    labels = tuple(str(i + 1) for i in range(len(qa))) if names is None else tuple(names)
    if reference is not None:
        reference, u_reference = (np.asarray(v, dtype=float) for v in (reference, u_reference))
    return PairLengths(labels, nominal, length, u, float(k), reference, u_reference)


def read_reference_lengths(path: str | Path, names: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    """Reference lengths of the pairs ``names``: CSV ``pair,length_mm,u_um``.

    Returns
    -------
    (length mm, standard uncertainty mm), each (len(names),)

    Raises
    ------
    InputFileError
        A missing column, a non-number, a negative u, a pair given twice or missing.
    """
    table = read_csv_table(path, ["pair", "length_mm", "u_um"])
    pairs = table.strings("pair")
    length = table.floats("length_mm")
    u = table.floats("u_um")
    index: dict[str, int] = {}
    for i, p in enumerate(pairs):
        if p in index:
            raise InputError(f"{path}, line {table.lines[i]}: pair {p!r} given twice")
        if u[i] < 0:
            raise InputError(f"{path}, line {table.lines[i]}: u_um must be >= 0")
        index[p] = i
    missing = [n for n in names if n not in index]
    if missing:
        raise InputError(f"{path}: no reference length for pair {missing[0]!r}")
    rows = [index[n] for n in names]
    return length[rows], to_internal(u[rows], "µm")
