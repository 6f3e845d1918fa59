"""Polynomial bases for error motions, with derivatives.

An error motion of axis k is a series ``E(q) = Σ_d c_d φ_d(q)``.  The basis is part
of the model definition:

``monomial``
    ``φ_d(q) = q**d`` in internal units of the axis position (mm or rad) unless the
    travel is normalised; ``E_XX1`` is then a slope (µm/m), as in the sources'
    13-parameter model (Sepahi Boroujeni (2021), Table 5-1; Alami Mchichi (2018), eq. 4.1).
``legendre``, ``chebyshev``
    ``φ_d(q) = P_d(u)`` or ``T_d(u)`` on the normalised travel
    ``u = (q − centre)/half_range`` ∈ [−1, 1]; coefficients carry the unit of the error
    itself (µm or µrad).  Orthogonal bases decouple the degree-0/2 and 1/3 terms that
    the ordinary polynomial mixes (Alami Mchichi (2018), eqs 4.1, 5.1, 8.1; Kruth 1994; Mir 2003).

Recurrences (Abramowitz & Stegun 22.7):

``(n+1) P_{n+1} = (2n+1) u P_n − n P_{n−1}``,  ``P'_{n+1} = P'_{n−1} + (2n+1) P_n``;
``T_{n+1} = 2u T_n − T_{n−1}``,  ``T'_{n+1} = 2 T_n + 2u T'_n − T'_{n−1}``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["BASES", "Basis"]

BASES = ("monomial", "legendre", "chebyshev")


@dataclass(frozen=True)
class Basis:
    """A polynomial basis on an axis.

    Parameters
    ----------
    kind : {"monomial", "legendre", "chebyshev"}
    centre, half_range : float
        Normalisation ``u = (q − centre)/half_range`` in internal units.  For an
        un-normalised monomial basis use ``centre=0, half_range=1``.
    """

    kind: str = "monomial"
    centre: float = 0.0
    half_range: float = 1.0

    def __post_init__(self):
        if self.kind not in BASES:
            raise ValueError(f"unknown basis {self.kind!r}; expected one of {BASES}")
        if not (np.isfinite(self.half_range) and self.half_range > 0):
            raise ValueError(f"basis half_range must be positive, got {self.half_range}")

    @property
    def normalised(self) -> bool:
        return not (self.centre == 0.0 and self.half_range == 1.0)

    def values(self, q: np.ndarray, max_degree: int) -> tuple[np.ndarray, np.ndarray]:
        """Basis values and their derivatives with respect to ``q``.

        Parameters
        ----------
        q : ndarray, shape (...)
            Axis positions in internal units.
        max_degree : int

        Returns
        -------
        phi, dphi : ndarray, shape (max_degree + 1, ...)
            ``phi[d] = φ_d(q)`` and ``dphi[d] = dφ_d/dq``.
        """
        u = (np.asarray(q, dtype=float) - self.centre) / self.half_range
        n = max_degree + 1
        phi = np.empty((n, *u.shape))
        dphi = np.empty((n, *u.shape))
        phi[0] = 1.0
        dphi[0] = 0.0
        if n > 1:
            phi[1] = u
            dphi[1] = 1.0
        for d in range(1, n - 1):
            if self.kind == "monomial":
                phi[d + 1] = phi[d] * u
                dphi[d + 1] = (d + 1) * phi[d]
            elif self.kind == "legendre":
                phi[d + 1] = ((2 * d + 1) * u * phi[d] - d * phi[d - 1]) / (d + 1)
                dphi[d + 1] = dphi[d - 1] + (2 * d + 1) * phi[d]
            else:
                phi[d + 1] = 2 * u * phi[d] - phi[d - 1]
                dphi[d + 1] = 2 * phi[d] + 2 * u * dphi[d] - dphi[d - 1]
        return phi, dphi / self.half_range
