"""Model adequacy of an identification: do the residuals agree with the model and the noise?

Every covariance ``(JᵀJ)⁻¹`` of a weighted least squares assumes that the model fits and
that the weights are the true input standard uncertainties.  Then the sum of squares of
the weighted residuals is chi-squared with ν = m − rank degrees of freedom, and the
variance factor (Birge ratio squared)::

    χ² = ‖r‖²,   s² = χ²/ν,   p = P(χ²_ν ≥ χ²)      (upper tail, scipy.stats.chi2.sf)

is 1 within about √(2/ν).  One rule serves every application (SAMBA, the CMM ball plate,
the laser tracker, multilateration): when ``p < α`` (α = 0.01 by default) the residuals
contradict the model or the stated noise; the result says so in words and, by default,
scales the covariance of the unknowns by s² (``rule="scale"``, Birge 1932; only up, never
down: a good fit does not make the stated noise smaller).  ``rule="a-priori"`` keeps the
covariance of the stated noise (the result still says that the residuals contradict it).

The measurement model behind the scaled covariance: the inputs' standard uncertainties are
the stated ones times an unknown common factor σ₀, estimated by s; the covariance of the
estimate is then ``s²(JᵀJ)⁻¹`` (JCGM 100:2008, H.3, the residual standard deviation of a
fit; Sepahi Boroujeni (2021), eq. 5-6).  It covers a stated noise that is too small by a
common factor; a model term that is missing leaves a systematic pattern, which
:func:`residual_patterns` shows by group (axis, tool, station) so that the user sees where
the model misses.

References
----------
Birge, R. T. (1932). The calculation of errors by the method of least squares. *Physical
Review* 40, 207–227.
JCGM 100:2008, *Evaluation of measurement data — Guide to the expression of uncertainty in
measurement*, H.3.
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, eq. 5-6.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.units import from_internal

__all__ = [
    "ADEQUACY_RULES",
    "SIGNIFICANCE",
    "ModelAdequacy",
    "model_adequacy",
    "residual_patterns",
]

#: The rules: scale the covariance by s² when the misfit is significant, or keep it.
ADEQUACY_RULES = ("scale", "a-priori")
#: Default significance level of the chi-squared test of the residuals.
SIGNIFICANCE = 0.01


@dataclass(frozen=True)
class ModelAdequacy:
    """The chi-squared test of an identification's weighted residuals and what followed.

    Attributes
    ----------
    chi2 : float
        ‖r‖² of the weighted residuals.
    dof : int
        ν = m − rank.
    variance_factor : float or None
        s² = χ²/ν; None without redundancy (ν = 0).
    p_value : float or None
        P(χ²_ν ≥ χ²); None without redundancy.
    alpha : float
        Significance level of the test.
    rule : {"scale", "a-priori"}
    significant : bool
        ``p < alpha``: the residuals contradict the model or the stated noise.
    scaled : bool
        The covariance was multiplied by :attr:`factor`.
    factor : float
        Factor applied to the covariance (1 when not scaled); uncertainties grow by its
        square root.
    message : str
        The finding in words.
    """

    chi2: float
    dof: int
    variance_factor: float | None
    p_value: float | None
    alpha: float
    rule: str
    significant: bool
    scaled: bool
    factor: float
    message: str

    def to_dict(self) -> dict:
        return {
            "kind": "model-adequacy",
            "version": 1,
            "test": "chi-squared of the weighted residuals, upper tail",
            "chi2": self.chi2,
            "dof": self.dof,
            "variance_factor": self.variance_factor,
            "p_value": self.p_value,
            "alpha": self.alpha,
            "rule": self.rule,
            "significant": self.significant,
            "scaled": self.scaled,
            "factor": self.factor,
            "message": self.message,
        }

    @classmethod
    def from_dict(cls, doc: Mapping) -> ModelAdequacy:
        return cls(
            float(doc["chi2"]),
            int(doc["dof"]),
            None if doc["variance_factor"] is None else float(doc["variance_factor"]),
            None if doc["p_value"] is None else float(doc["p_value"]),
            float(doc["alpha"]),
            str(doc["rule"]),
            bool(doc["significant"]),
            bool(doc["scaled"]),
            float(doc["factor"]),
            str(doc["message"]),
        )


def model_adequacy(
    chi2: float, dof: int, *, rule: str = "scale", alpha: float = SIGNIFICANCE
) -> ModelAdequacy:
    """The variance factor, its p-value and the covariance factor of the adequacy rule.

    Parameters
    ----------
    chi2 : float
        ‖r‖² of the weighted residuals (r = residual / stated standard uncertainty).
    dof : int
        ν = m − rank (observations less the rank of the Jacobian).
    rule : {"scale", "a-priori"}
        ``"scale"``: when ``p < alpha`` the covariance is to be multiplied by
        ``max(s², 1)`` (Birge ratio squared); ``"a-priori"``: the covariance of the stated
        noise is kept whatever the residuals say.
    alpha : float
        Significance level, 0 < alpha < 1.

    Returns
    -------
    ModelAdequacy

    Raises
    ------
    InputError
        An unknown rule, alpha outside (0, 1), a negative or non-finite χ², ν < 0.

    Notes
    -----
    ``s² = χ²/ν``, ``p = P(χ²_ν ≥ χ²)`` (JCGM 100:2008, H.3; Birge 1932).  ``p < α`` implies
    s² > 1 for every ν ≥ 1, so the factor only ever widens.

    Examples
    --------
    >>> a = model_adequacy(40.8, 10)
    >>> a.significant, a.scaled, round(a.factor, 2)
    (True, True, 4.08)
    >>> model_adequacy(9.0, 10).scaled
    False
    """
    from scipy import stats  # here, not at the top: importing it takes 0.5 s

    if rule not in ADEQUACY_RULES:
        raise InputError(f"adequacy rule must be one of {', '.join(ADEQUACY_RULES)}, got {rule!r}")
    if not 0.0 < alpha < 1.0:
        raise InputError(f"adequacy significance level must be in (0, 1), got {alpha}")
    chi2 = float(chi2)
    if not (np.isfinite(chi2) and chi2 >= 0.0) or dof < 0:
        raise InputError(f"chi-squared {chi2} with {dof} degrees of freedom is not a test")
    if dof == 0:
        return ModelAdequacy(
            chi2, 0, None, None, alpha, rule, False, False, 1.0,
            "no redundancy (as many observations as unknowns): the residuals cannot test "
            "the model or the stated noise",
        )  # fmt: skip
    s2 = chi2 / dof
    p = float(stats.chi2.sf(chi2, dof))
    significant = p < alpha
    scaled = significant and rule == "scale"
    factor = max(s2, 1.0) if scaled else 1.0
    # below the smallest double the tail reads 0: say how small instead of "p = 0"
    shown = f"p = {p:.2g}" if p > 0.0 else "p < 1e-300"
    test = f"variance factor s² = {s2:.3g} (χ² = {chi2:.4g}, ν = {dof}, {shown}"
    if not significant:
        message = f"the residuals agree with the model and the stated noise: {test}; α = {alpha:g})"
    elif scaled:
        message = (
            f"the residuals contradict the model or the stated noise: {test}; α = {alpha:g}); "
            f"the covariance is scaled by s² (uncertainties × {np.sqrt(factor):.3g})"
        )
    else:
        message = (
            f"the residuals contradict the model or the stated noise: {test}; α = {alpha:g}); "
            "the a-priori covariance is kept as asked, so the uncertainties are optimistic "
            f"by a factor of about {np.sqrt(s2):.3g}"
        )
    return ModelAdequacy(chi2, dof, s2, p, alpha, rule, significant, scaled, factor, message)


def residual_patterns(
    residuals: np.ndarray,
    groupings: Mapping[str, Sequence],
    *,
    weighted: np.ndarray | None = None,
    unit: str = "µm",
) -> dict:
    """RMS of the residuals by group (axis, tool, station …): where the model misses.

    Parameters
    ----------
    residuals : (n,) or (n, k) ndarray
        Residuals in internal units (mm): one length, or one vector (x, y, z) per row.
    groupings : mapping of name → sequence of n labels
        e.g. ``{"station": ids, "tool": tool_ids}``; every label becomes one group.
    weighted : (n,) or (n, k) ndarray, optional
        The same residuals divided by their stated standard uncertainty: their RMS by group
        (over every coordinate) is ≈ √(ν/m) ≈ 1 where the model and the noise agree, and
        well above 1 where the model misses.
    unit : str
        Display unit of the RMS.

    Returns
    -------
    dict
        ``{name: [{"group", "n", "rms_<unit>", ["rms_<unit>_components"],
        ["rms_weighted"]}]}``, and ``"component"`` (the RMS of each column over all rows)
        when the residuals are vectors.  The RMS of a vector residual is
        ``sqrt(mean ‖r‖²)`` over the rows of the group.

    Raises
    ------
    ValueError
        A grouping whose length is not n.
    """
    r = np.asarray(residuals, dtype=float)
    rows = r.reshape(r.shape[0], -1)
    w = None if weighted is None else np.asarray(weighted, dtype=float).reshape(rows.shape)
    key = f"rms_{unit}"
    out: dict = {}
    for name, labels in groupings.items():
        labels = np.asarray([str(v) for v in labels])
        if labels.shape != (rows.shape[0],):
            raise ValueError(f"grouping {name!r} has {labels.size} labels for {rows.shape[0]} rows")
        groups = []
        for label in dict.fromkeys(labels.tolist()):
            sel = labels == label
            sq = rows[sel] ** 2
            entry = {
                "group": label,
                "n": int(sel.sum()),
                key: float(from_internal(np.sqrt(sq.sum(axis=1).mean()), unit)),
            }
            if rows.shape[1] > 1:
                entry[f"{key}_components"] = from_internal(np.sqrt(sq.mean(axis=0)), unit).tolist()
            if w is not None:
                entry["rms_weighted"] = float(np.sqrt((w[sel] ** 2).mean()))
            groups.append(entry)
        out[name] = groups
    if rows.shape[1] > 1:
        out["component"] = from_internal(np.sqrt((rows**2).mean(axis=0)), unit).tolist()
    return out
