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
import re
from dataclasses import dataclass

from mtmetrology.errors import InputError

__all__ = [
    "BIAS_ADDED",
    "DEFAULT",
    "DEFAULT_K",
    "DEFAULT_P",
    "CoveragePolicy",
    "coverage_policy",
    "unstated_coverage",
]

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


#: Keys of an expanded uncertainty in a result document: ``U``, ``U_um``, ``Ux_um``,
#: ``U_cmm_um`` (not ``U1_um``: the source's name of a mean *standard* uncertainty).
_EXPANDED = re.compile(r"^U[xyz]?(_\w+)?$")
_K_KEYS = ("k", "coverage_factor")


def _k_of(chain: list[dict]) -> list[float] | None:
    """The k (one, or one per U) of the nearest dict that states one, or its ``coverage``."""
    for d in reversed(chain):
        for key in _K_KEYS:
            if _numbers(d.get(key)) is not None:
                return _numbers(d[key])
        cov = d.get("coverage")
        if isinstance(cov, dict) and _numbers(cov.get("k")) is not None:
            return _numbers(cov["k"])
    return None


def _numbers(value) -> list[float] | None:
    if isinstance(value, bool):
        return None
    if isinstance(value, int | float):
        return [float(value)]
    if (
        isinstance(value, list)
        and value
        and all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
    ):
        return [float(v) for v in value]
    return None


#: The rule of an expanded uncertainty that adds the uncorrected bias (ISO 15530-3:2004,
#: 8: U = k·u + |b|), stated as ``U_rule`` in the documents that use it.
BIAS_ADDED = "U = k·u + |b| (bias b not corrected, ISO 15530-3:2004)"


def _bias_added(chain: list[dict]) -> float:
    """|b| added to k u when an enclosing dict states :data:`BIAS_ADDED` (the nearest
    ``b``, in the unit of the U beside it), else 0."""
    if not any(d.get("U_rule") == BIAS_ADDED for d in chain):
        return 0.0
    b = next((d["b"] for d in reversed(chain) if isinstance(d.get("b"), int | float)), 0.0)
    return abs(float(b))


def unstated_coverage(document, rtol: float = 1e-6) -> list[str]:
    """Where a result document breaks the policy: a U without its k, a U ≠ k u, an
    interval without its coverage probability.

    A dict key ``U`` (or ``U_um``, ``Ux_um``, ``U_cmm_um`` …) is an expanded uncertainty;
    its k is the ``k`` / ``coverage_factor`` of that dict or of the nearest enclosing one
    (or its ``coverage.k``); when the dict also holds the matching standard uncertainty
    (``u``, ``u_um`` …) U must equal k u (JCGM 100:2008, 6.2.1; a Monte Carlo output's k
    is U/u of its interval, JCGM 101:2008, 7.7), or k u + |b| where an enclosing dict
    states ``U_rule`` :data:`BIAS_ADDED`.  A key ``interval`` needs ``p`` or
    ``coverage_probability`` beside it or above it.

    Parameters
    ----------
    document : dict or list
        A JSON result document.
    rtol : float
        Relative tolerance of U = k u.

    Returns
    -------
    list of str
        One line per breach, ``path: what``; empty when the document follows the policy.

    Examples
    --------
    >>> unstated_coverage({"outputs": [{"u": 1.0, "U": 2.0, "k": 2.0, "p": 0.95}]})
    []
    >>> unstated_coverage({"u_um": 1.0, "U_um": 1.96})
    ['/U_um: U without its coverage factor k']
    """
    errors: list[str] = []

    def walk(node, path: str, chain: list[dict]) -> None:
        if isinstance(node, list):
            for i, v in enumerate(node):
                walk(v, f"{path}[{i}]", chain)
            return
        if not isinstance(node, dict):
            return
        chain = [*chain, node]
        for key, value in node.items():
            if isinstance(key, str) and _EXPANDED.match(key) and _numbers(value) is not None:
                k = _k_of(chain)
                if k is None:
                    errors.append(f"{path}/{key}: U without its coverage factor k")
                    continue
                u = _numbers(node.get("u" + key[1:]))
                big = _numbers(value)
                ks = k * len(big) if len(k) == 1 else k
                bias = _bias_added(chain)
                if u is not None and len(u) == len(big) == len(ks):
                    for a, b, f in zip(big, u, ks, strict=True):
                        # under the bias rule a U is k u + |b|, or k_eff u where its own
                        # dict states the effective k = U/u (an output record)
                        if not any(
                            math.isclose(a, f * b + extra, rel_tol=rtol, abs_tol=1e-300)
                            for extra in {0.0, bias}
                        ):
                            errors.append(f"{path}/{key}: U = {a:g} is not k u = {f:g} × {b:g}")
                            break
            if key == "interval" and not any(
                "p" in d or "coverage_probability" in d for d in chain
            ):
                errors.append(f"{path}/interval: an interval without its coverage probability")
        for key, value in node.items():
            walk(value, f"{path}/{key}", chain)

    walk(document, "", [])
    return errors
