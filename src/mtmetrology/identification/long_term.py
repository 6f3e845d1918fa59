"""Long-term covariance of machine parameters from repeated calibrations.

The full-covariance method needs the long-term covariance Σ of the machine parameters:
how much the machine's geometric errors move from one day to the next (Sepahi Boroujeni
(2021), eq. 6-4, Δ ~ N(δ, Σ)). The thesis measures it directly: a SAMBA calibration once
a day for 15 days, and the 13×13 sample covariance of the 15 estimates (§5.3, Table 5-2
"Exp." and Table 5-4). :func:`long_term_parameters` does the same with any number of
calibrations of one machine and returns a :class:`ParameterSet` whose covariance is the
long-term variation Σ_lt of a task's budget (``mtm task uncertainty --long-term``, or
``long_term_covariance`` of :func:`mtmetrology.omm.task.task_uncertainty`); the
calibration that compensates brings its own U_θ (``--params``).  The scatter of the
estimates holds their estimation noise too, so Σ_lt from it counts part of U_θ again
(conservative).
It lives in the identification engine so that ``mtm samba long-term`` (on files) and
``mtm history covariance`` (on the calibration database) call the same statistic.

References
----------
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, §5.3 (Tables 5-2 and 5-4) and §6.2.

JCGM 100:2008. *Evaluation of measurement data — Guide to the expression of uncertainty in
measurement*, 4.2.2–4.2.3 (experimental variance and covariance, n − 1 divisor) and 5.2.3.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.kinematics.parameter_set import ParameterSet

__all__ = ["long_term_parameters"]

VALUE_CHOICES = ("latest", "mean")


def long_term_parameters(
    calibrations: Sequence[ParameterSet],
    *,
    values: Literal["latest", "mean"] = "latest",
    add_within: bool = False,
    sources: Sequence[str] | None = None,
) -> ParameterSet:
    """Parameter values with the day-to-day covariance of several calibrations.

    Parameters
    ----------
    calibrations : sequence of ParameterSet, length K >= 2
        Calibrations of one machine, in time order (the last is the latest), with the same
        parameter names (their order may differ; the first set's order is kept).
    values : {"latest", "mean"}
        ``"latest"`` (default): the values of the last calibration, the thesis's δ, the
        current estimate that compensates the machine today (Sepahi Boroujeni (2021),
        eq. 6-4: Δ ~ N(δ, Σ) about the current δ). ``"mean"``: the mean of the K
        calibrations, a better estimate of the machine's *average* state when the
        compensation is meant to hold for the whole period.
    add_within : bool
        Also add the mean of the calibrations' own covariances (each must have one).
        The day-to-day scatter cannot show what is common to every calibration, such as
        the error of the scale bar's calibrated length (the same bar every day); the
        within-calibration covariance of a SAMBA GUF contains it. In the thesis this is
        why the MCM u of E_XX1, E_YY1 and E_ZZ1 (6.1, 5.4, 5.5 µm/m) exceeds their
        day-to-day u (4.6, 3.7, 3.8 µm/m) (Table 5-2). Adding it is conservative: the
        probing-noise part of each calibration's covariance is then counted twice (it is
        already in the scatter).
    sources : sequence of str, optional
        A name per calibration (the file it came from), for the messages and the
        provenance.

    Returns
    -------
    ParameterSet
        ``values`` as chosen, ``covariance`` the sample covariance (internal units)::

            Σ = 1/(K − 1) · Σ_k (δ_k − δ̄)(δ_k − δ̄)ᵀ   [+ 1/K · Σ_k cov_k  if add_within]

        the first set's names, units, machine and model, and a provenance recording K,
        the choices and the rank of Σ (at most K − 1: with fewer than P + 1 calibrations
        of P parameters Σ is singular, which the task uncertainty accepts).

    Raises
    ------
    InputError
        Fewer than two calibrations, sets of different machines, error models or
        parameter names, an unknown ``values``, ``sources`` of the wrong length, or
        ``add_within`` with a set that has no covariance. The message names the
        calibration (its source, else its position).

    Notes
    -----
    The unbiased (n − 1) estimator of JCGM 100:2008, 4.2.3 and C.3.6, applied to the
    parameter vectors: Sepahi Boroujeni (2021) calls it the "Exp." uncertainty of Table
    5-2 (15 daily SAMBA runs). Its expectation is Σ_day + Σ_est (the machine's day-to-day
    variation plus each calibration's estimation noise); it is Wishart distributed with
    K − 1 degrees of freedom, so a handful of calibrations gives only a rough Σ (the
    relative standard uncertainty of a variance is √(2/(K − 1)), 38 % for K = 15).

    Examples
    --------
    >>> import numpy as np
    >>> from mtmetrology.kinematics.parameter_set import ParameterSet
    >>> days = [ParameterSet(("E_X0C", "E_Y0S"), np.array(v) * 1e-3, ("µm", "µm"),
    ...                      machine="m") for v in ([1.0, 2.0], [3.0, 4.0], [2.0, 6.0])]
    >>> lt = long_term_parameters(days)
    >>> (lt.values * 1e3).round(9)
    array([2., 6.])
    >>> (lt.covariance * 1e6).round(9)
    array([[1., 1.],
           [1., 4.]])
    """
    sets = list(calibrations)
    if values not in VALUE_CHOICES:
        raise InputError(f"values must be one of {', '.join(VALUE_CHOICES)}, got {values!r}")
    if sources is not None and len(sources) != len(sets):
        raise InputError(f"sources: {len(sources)} names for {len(sets)} calibrations")
    names_of = (
        list(sources) if sources is not None else [f"calibration {k + 1}" for k in range(len(sets))]
    )
    if len(sets) < 2:
        raise InputError(
            f"a long-term covariance needs at least 2 calibrations of the machine, got "
            f"{len(sets)}; give the parameter sets of several days"
        )
    first = sets[0]
    for name, s in zip(names_of[1:], sets[1:], strict=True):
        if s.machine != first.machine:
            raise InputError(
                f"{name}: a calibration of machine {s.machine!r}, not {first.machine!r} "
                f"like {names_of[0]}"
            )
        if s.model != first.model:
            raise InputError(
                f"{name}: error model {s.model!r}, not {first.model!r} like {names_of[0]}"
            )
        if s.names != first.names and sorted(s.names) != sorted(first.names):
            extra = sorted(set(s.names) ^ set(first.names))
            raise InputError(
                f"{name}: parameter names differ from {names_of[0]} (not in both: "
                f"{', '.join(extra) or 'a parameter listed twice'})"
            )
    # each set's positions of the first set's names (identity when they are in the same order)
    order = [
        np.arange(len(first.names))
        if s.names == first.names
        else np.array([s.names.index(n) for n in first.names])
        for s in sets
    ]
    estimates = np.stack([s.values[o] for s, o in zip(sets, order, strict=True)])  # (K, P)
    centred = estimates - estimates.mean(axis=0)
    sigma = centred.T @ centred / (len(sets) - 1)
    if add_within:
        missing = [n for n, s in zip(names_of, sets, strict=True) if s.covariance is None]
        if missing:
            raise InputError(
                f"{missing[0]}: has no covariance; add_within needs each calibration's "
                "covariance (calibrate with --uncertainty guf)"
            )
        sigma = sigma + np.mean(
            [s.covariance[np.ix_(o, o)] for s, o in zip(sets, order, strict=True)], axis=0
        )
    sigma = 0.5 * (sigma + sigma.T)
    chosen = estimates[-1] if values == "latest" else estimates.mean(axis=0)
    provenance = {
        "method": "long-term sample covariance of repeated calibrations (n - 1 divisor)",
        "calibrations": len(sets),
        "values": values,
        "within_calibration_covariance_added": add_within,
        "rank": int(np.linalg.matrix_rank(sigma)),
        "reference": "Sepahi Boroujeni (2021), §5.3, Tables 5-2 and 5-4",
    }
    if sources is not None:
        provenance["sources"] = [str(s) for s in sources]
    return ParameterSet(
        first.names,
        chosen,
        first.units,
        sigma,
        provenance,
        machine=first.machine,
        model=first.model,
    )
