"""Independent identifications of one machine combined into one parameter set.

Each calibration (a SAMBA campaign, a tracker verification, an ISO 230-2 laser run of one
axis …) gives estimates θ_k of some of the machine's parameters with covariance U_k.  When
they are independent, in the same error model (the same basis on the same travels) and of
the same machine state, the generalised least-squares combination over the union of their
names is (Aitken 1935)

    U = (Σ_k P_kᵀ U_k⁻¹ P_k)⁻¹,    θ = U Σ_k P_kᵀ U_k⁻¹ θ_k,

``P_k`` the selection of set k's names from the union.  A name only one set holds keeps
that set's estimate; names correlated within a set stay correlated.  Import this module by
its path (``from mtmetrology.identification.combine import combine_parameter_sets``).

References
----------
Aitken, A. C. (1935). On least squares and linear combination of observations.
*Proceedings of the Royal Society of Edinburgh* 55, 42–48.
"""

from __future__ import annotations

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.kinematics.parameter_set import ParameterSet

__all__ = ["combine_parameter_sets"]


def combine_parameter_sets(*sets: ParameterSet) -> ParameterSet:
    """The generalised least-squares combination of independent parameter sets.

    Parameters
    ----------
    *sets : ParameterSet
        Two or more sets of one machine, each with a full-rank covariance.

    Returns
    -------
    ParameterSet
        Over the union of the names (first-seen order), with the combined covariance; the
        provenance lists the sets' own.

    Raises
    ------
    InputError
        Fewer than two sets, sets of different machines or models, a set without a
        covariance or with a singular one, or a name whose units differ between sets.
    """
    if len(sets) < 2:
        raise InputError("combine: give two parameter sets at least")
    machine, model = sets[0].machine, sets[0].model
    names: list[str] = []
    units: dict[str, str] = {}
    for k, s in enumerate(sets):
        if s.machine != machine or s.model != model:
            raise InputError(
                f"combine: set {k + 1} is of machine {s.machine!r} model {s.model!r}, "
                f"set 1 of {machine!r} model {model!r}"
            )
        if s.covariance is None:
            raise InputError(f"combine: set {k + 1} has no covariance")
        for n, u in zip(s.names, s.units, strict=True):
            if units.setdefault(n, u) != u:
                raise InputError(f"combine: {n} in {u} in set {k + 1}, in {units[n]} before")
            if n not in names:
                names.append(n)
    info = np.zeros((len(names), len(names)))
    vector = np.zeros(len(names))
    for k, s in enumerate(sets):
        index = [names.index(n) for n in s.names]
        try:
            weight = np.linalg.inv(s.covariance)
        except np.linalg.LinAlgError:
            raise InputError(f"combine: the covariance of set {k + 1} is singular") from None
        info[np.ix_(index, index)] += weight
        vector[index] += weight @ s.values
    cov = np.linalg.inv(info)
    cov = 0.5 * (cov + cov.T)
    return ParameterSet(
        tuple(names),
        cov @ vector,
        tuple(units[n] for n in names),
        cov,
        {"combined": [dict(s.provenance) for s in sets]},
        machine=machine,
        model=model,
    )
