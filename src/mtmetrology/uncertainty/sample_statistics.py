"""Statistics of Monte Carlo model values: streaming moments, correlation, joint factors.

The estimate and covariance of the outputs are accumulated chunk by chunk (JCGM
102:2011, 7.6), so the values of a run are reduced in one pass whatever their number;
the joint coverage factors come from the sample (JCGM 102:2011, 7.7).
"""

from __future__ import annotations

import numpy as np

from mtmetrology.uncertainty.regions import (
    ellipsoidal_coverage_factor,
    rectangular_coverage_factor,
    scatter,
)

__all__ = ["Moments", "correlation_matrix", "joint_coverage_factors"]


class Moments:
    """Streaming mean and scatter matrix of model values, chunk by chunk.

    ``add(values)`` merges a (k, m) block by the pairwise update of Chan, Golub and
    LeVeque (1983): with n, ȳ, S so far and k, ȳ_b, S_b of the block, δ = ȳ_b − ȳ,
    ȳ ← ȳ + δ·k/(n + k) and S ← S + S_b + δδᵀ·nk/(n + k); ``covariance`` is
    S/(n − 1), the sample covariance of JCGM 102:2011, 7.6 (eq. 5-10 of Sepahi
    Boroujeni 2021).

    References
    ----------
    T. F. Chan, G. H. Golub and R. J. LeVeque, "Algorithms for computing the sample
    variance: analysis and recommendations", Am. Stat. 37 (1983) 242–247.

    Examples
    --------
    >>> import numpy as np
    >>> values = np.arange(12.0).reshape(6, 2) ** 2
    >>> moments = Moments()
    >>> moments.add(values[:4]); moments.add(values[4:])
    >>> bool(np.allclose(moments.covariance, np.cov(values.T)))
    True
    """

    def __init__(self):
        self.count = 0
        self.mean: np.ndarray | None = None
        self.scatter: np.ndarray | None = None

    def add(self, values: np.ndarray) -> None:
        count = values.shape[0]
        mean = values.mean(axis=0)  # (m,)
        deviations = values - mean  # (count, m)
        scatter_matrix = scatter(deviations)  # (m, m)
        if self.count == 0:
            self.count, self.mean, self.scatter = count, mean, scatter_matrix
            return
        total = self.count + count
        delta = mean - self.mean
        self.mean = self.mean + delta * (count / total)
        self.scatter = (
            self.scatter + scatter_matrix + np.outer(delta, delta) * (self.count * count / total)
        )
        self.count = total

    @property
    def covariance(self) -> np.ndarray:
        """(m, m) sample covariance S/(n − 1)."""
        return self.scatter / (self.count - 1)


def correlation_matrix(covariance: np.ndarray) -> np.ndarray:
    """R = D⁻¹ U D⁻¹ with D = diag sqrt(U_jj) (JCGM 102:2011, 3.21).

    Rows and columns of zero-variance outputs are 0, with a unit diagonal.

    Examples
    --------
    >>> correlation_matrix(np.array([[4.0, 2.0, 0.0], [2.0, 9.0, 0.0], [0.0, 0.0, 0.0]]))
    array([[1.        , 0.33333333, 0.        ],
           [0.33333333, 1.        , 0.        ],
           [0.        , 0.        , 1.        ]])
    """
    u = np.sqrt(np.diag(covariance))
    positive = u > 0
    safe = np.where(positive, u, 1.0)
    correlation = covariance / np.outer(safe, safe)
    correlation[~positive, :] = 0.0
    correlation[:, ~positive] = 0.0
    np.fill_diagonal(correlation, 1.0)
    return correlation


def joint_coverage_factors(values, estimate, covariance, p) -> tuple[float | None, float | None]:
    """k_p and k_q of the sample over the outputs that vary (a constant output adds no
    dimension): hyper-ellipsoidal (JCGM 102:2011, 7.7.2) and hyper-rectangular (7.7.3)
    coverage factors for probability p.

    None for one output: its coverage region is its coverage interval, and skipping the
    sample distances saves a pass over the values.
    """
    if values.shape[1] == 1:
        return None, None
    u = np.sqrt(np.diag(covariance))
    varying = np.flatnonzero(u > 0)
    if varying.size == 0:
        return 0.0, 0.0
    sub = values[:, varying]
    k_p = ellipsoidal_coverage_factor(
        sub, p, estimate=estimate[varying], covariance=covariance[np.ix_(varying, varying)]
    )
    k_q = rectangular_coverage_factor(
        sub, p, estimate=estimate[varying], standard_uncertainty=u[varying]
    )
    return k_p, k_q
