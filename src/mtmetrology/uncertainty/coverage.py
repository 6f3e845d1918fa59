"""One coverage policy: U = k u, k stated beside every U, p beside every interval.

Every expanded uncertainty mtmetrology states (console, JSON, report, notebook, DCC) is

    U = k u                                              (JCGM 100:2008, 6.2.1)

with the coverage factor k written beside it, and every coverage interval states its
coverage probability p.  The default is **k = 2**: calibration certificates state k = 2
for a coverage probability of about 95 % (EA-4/02 M:2022, 5.1 and Annex E; ILAC-P14:09/2020,
5.4), so a number of this program can be copied into a certificate as it stands.  The
probability that goes with k = 2 for a normal output is

    p = 2 Φ(2) − 1 = 0.9545                              (JCGM 100:2008, G.1.3, Table G.1)

and that p is what the Monte Carlo coverage intervals (JCGM 101:2008, 7.7) and the GUF
with few effective degrees of freedom (k = t_p(ν_eff), JCGM 100:2008, G.4; EA-4/02 Annex E
uses 95.45 %) are evaluated at, so that the one policy gives k = 2 exactly where the
output is normal.  A user who states p instead (``--p 0.95``) gets k = Φ⁻¹((1 + p)/2)
(1.96) for a normal output; stating k gives p = 2 Φ(k) − 1.

:class:`CoveragePolicy` is that choice as a value; :data:`DEFAULT` is k = 2;
:func:`coverage_policy` builds one from a user's ``k`` or ``p`` and refuses anything else.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mtmetrology.errors import InputError

__all__ = ["DEFAULT", "DEFAULT_K", "DEFAULT_P", "CoveragePolicy", "coverage_policy"]

#: The default coverage factor (EA-4/02, ILAC-P14: k = 2, about 95 %).
DEFAULT_K = 2.0


def _normal_p(k: float) -> float:
    """p = 2 Φ(k) − 1 = erf(k/√2), the coverage probability of y ± k u for a normal y."""
    return math.erf(k / math.sqrt(2.0))


def _normal_k(p: float) -> float:
    """k = Φ⁻¹((1 + p)/2), the coverage factor of a normal output at probability p."""
    from scipy import stats

    return float(stats.norm.ppf((1.0 + p) / 2.0))


@dataclass(frozen=True)
class CoveragePolicy:
    """The coverage factor and the coverage probability every U and interval states.

    Attributes
    ----------
    k : float
        Coverage factor of U = k u (JCGM 100:2008, 6.2.1), > 0.
    p : float
        Coverage probability of a normal output's interval y ± k u, ``2 Φ(k) − 1``
        (JCGM 100:2008, G.1.3); the probability Monte Carlo intervals are evaluated at.
    stated : str
        ``"k"`` or ``"p"``: which of the two the user chose (the other follows from it).
    """

    k: float = DEFAULT_K
    p: float = _normal_p(DEFAULT_K)
    stated: str = "k"

    def expanded(self, u):
        """U = k u (JCGM 100:2008, 6.2.1) of a scalar or array ``u``."""
        return self.k * u

    @property
    def label(self) -> str:
        """``k = 2`` (or ``k = 1.96``): what a person reads beside every U."""
        return f"k = {self.k:.3g}"

    @property
    def probability_label(self) -> str:
        """``p ≈ 95.45 %``: the coverage probability beside an interval."""
        return f"p ≈ {100.0 * self.p:.4g} %"

    def to_dict(self) -> dict:
        """``k``, ``coverage_probability``, ``stated`` and the rule, for a result document."""
        return {
            "k": self.k,
            "coverage_probability": self.p,
            "stated": self.stated,
            "rule": "U = k u; p = 2 Φ(k) − 1 for a normal output (EA-4/02, ILAC-P14: k = 2)",
        }


#: k = 2, p = 95.45 %: the policy of every command unless the user states another.
DEFAULT = CoveragePolicy()
#: Its coverage probability 2 Φ(2) − 1: the default ``p`` of the application engines.
DEFAULT_P = DEFAULT.p


def coverage_policy(k: float | None = None, p: float | None = None) -> CoveragePolicy:
    """The policy for a user's coverage factor ``k`` or coverage probability ``p``.

    Parameters
    ----------
    k : float, optional
        Coverage factor, finite and > 0.
    p : float, optional
        Coverage probability, 0 < p < 1.  At most one of ``k`` and ``p``; neither gives
        :data:`DEFAULT` (k = 2).

    Returns
    -------
    CoveragePolicy
        ``p = 2 Φ(k) − 1`` for a stated k, ``k = Φ⁻¹((1 + p)/2)`` for a stated p.

    Raises
    ------
    InputError
        Both given, k not a finite positive number, p outside (0, 1).

    Examples
    --------
    >>> coverage_policy().k, round(coverage_policy().p, 4)
    (2.0, 0.9545)
    >>> round(coverage_policy(p=0.95).k, 2)
    1.96
    """
    if k is not None and p is not None:
        raise InputError("--k and --p: state the coverage factor or the probability, not both")
    if k is not None:
        if not (math.isfinite(k) and k > 0):
            raise InputError(f"--k: the coverage factor must be a finite number > 0, got {k}")
        return CoveragePolicy(float(k), _normal_p(float(k)), "k")
    if p is not None:
        if not (math.isfinite(p) and 0.0 < p < 1.0):
            raise InputError(f"--p: the coverage probability must be between 0 and 1, got {p}")
        return CoveragePolicy(_normal_k(float(p)), float(p), "p")
    return DEFAULT
