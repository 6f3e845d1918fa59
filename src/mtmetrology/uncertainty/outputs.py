"""One vocabulary for the results of every uncertainty method, and the result document.

Both :class:`~mtmetrology.uncertainty.guf.GUFResult` and
:class:`~mtmetrology.uncertainty.mcm.MCMResult` describe each output quantity Y_j by the
same :class:`Output` record, with the JCGM 100:2008 symbols

======  ==============================  =====================================================
field   JCGM term                       GUF / MCM
======  ==============================  =====================================================
value   estimate y                      f(x) / mean of the model values (JCGM 101, 7.6)
u       standard uncertainty u(y)       sqrt(c U_x cᵀ) / standard deviation of the values
U       expanded uncertainty U_p        k u(y) / half-width of the symmetric interval
k       coverage factor k_p             t_{ν_eff} quantile / U / u(y)
p       coverage probability            as asked
interval coverage interval [low, high]  y ± U / probabilistically symmetric (JCGM 101, 7.7.1)
======  ==============================  =====================================================

and the joint quantities under the same names on both results: ``covariance``,
``correlation``, ``largest_eigenvalue``, ``region_coverage_factor`` (hyper-ellipsoid k_p,
JCGM 102:2011, 6.5.2.3 and 7.7.2) and ``rectangular_coverage_factor``.

:func:`result_document` assembles the JSON document that ``mtm uncertainty run --json``
prints, so a library user gets the same document without the command line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mtmetrology.errors import InputError

__all__ = ["RESULT_KIND", "RESULT_VERSION", "Output", "result_document"]

RESULT_KIND = "uncertainty-result"
RESULT_VERSION = 2


@dataclass(frozen=True)
class Output:
    """The summary of one output quantity, identical for every method.

    Attributes
    ----------
    name, unit : str
    value : float
        Estimate y (output unit).
    u : float
        Standard uncertainty u(y) (output unit).
    U : float
        Expanded uncertainty, half the width of ``interval`` (output unit).
    k : float or None
        Coverage factor U / u(y); None when u(y) = 0.
    p : float
        Coverage probability.
    interval : tuple of float
        Coverage interval (low, high) for probability p (output unit).
    """

    name: str
    value: float
    unit: str
    u: float
    U: float
    k: float | None
    p: float
    interval: tuple[float, float]

    def to_dict(self) -> dict:
        """``{name, value, unit, u, U, k, p, interval: [low, high]}``."""
        return {
            "name": self.name,
            "value": self.value,
            "unit": self.unit,
            "u": self.u,
            "U": self.U,
            "k": self.k,
            "p": self.p,
            "interval": list(self.interval),
        }


def output_records(result, expanded, coverage_factor) -> tuple[Output, ...]:
    """The :class:`Output` of each output of a GUF or Monte Carlo ``result``.

    ``result`` provides names, units, estimate, standard_uncertainty, p and interval
    ((m, 2)); ``expanded`` and ``coverage_factor`` are (m,) arrays (NaN k becomes None).
    """
    return tuple(
        Output(
            name=result.names[j],
            value=float(result.estimate[j]),
            unit=result.units[j],
            u=float(result.standard_uncertainty[j]),
            U=float(expanded[j]),
            k=None if math.isnan(coverage_factor[j]) else float(coverage_factor[j]),
            p=result.p,
            interval=(float(result.interval[j, 0]), float(result.interval[j, 1])),
        )
        for j in range(len(result.names))
    )


def output_labels(given, from_model, m: int, stem: str) -> list[str]:
    """Output names or units: as given, else the model's attribute, else y1..ym / "".

    Raises
    ------
    InputError
        If the number of labels differs from the number of outputs m.
    """
    labels = given if given is not None else from_model
    if labels is None:
        return [stem] if m == 1 and stem else [f"{stem}{j + 1}" if stem else "" for j in range(m)]
    labels = [str(v) for v in labels]
    if len(labels) != m:
        raise InputError(f"expected {m} output labels, got {len(labels)}: {labels}")
    return labels


def json_dof(value: float) -> float | None:
    """Degrees of freedom for JSON: None stands for infinity."""
    return None if math.isinf(value) else float(value)


def result_document(guf=None, mcm=None, validation=None, *, model=None, source=None) -> dict:
    """The uncertainty result document of one evaluation.

    Parameters
    ----------
    guf : GUFResult, optional
    mcm : MCMResult, optional
        At least one of the two.
    validation : ValidationReport, optional
        The GUF validated by the Monte Carlo result (both must be given).
    model, source : str, optional
        Model name and the file it came from, recorded as given.

    Returns
    -------
    dict
        ``{kind, version, method, model, source, p, outputs, guf, mcm, validation}``:
        ``method`` is "guf", "mcm" or "both"; ``outputs`` is the Monte Carlo
        ``outputs`` list when it ran (the reference against which the GUF is validated,
        JCGM 101:2008, 8) and the GUF one otherwise; the complete ``to_dict()`` of each
        method that ran is under its name.

    Raises
    ------
    ValueError
        If neither result is given, a validation comes without both results, or the two
        results disagree on p or on the output names.
    """
    if guf is None and mcm is None:
        raise ValueError("result_document needs a GUF result, a Monte Carlo result or both")
    if validation is not None and (guf is None or mcm is None):
        raise ValueError("a validation needs both the GUF and the Monte Carlo result")
    if guf is not None and mcm is not None:
        if abs(guf.p - mcm.p) > 1e-12 or guf.names != mcm.names:
            raise ValueError(
                f"GUF and Monte Carlo results differ in p ({guf.p}, {mcm.p}) or output names "
                f"({list(guf.names)}, {list(mcm.names)})"
            )
    reference = mcm if mcm is not None else guf
    document = {
        "kind": RESULT_KIND,
        "version": RESULT_VERSION,
        "method": "both" if guf is not None and mcm is not None else reference.method,
        "model": model,
        "source": source,
        "p": reference.p,
        "outputs": [o.to_dict() for o in reference.outputs],
    }
    if guf is not None:
        document["guf"] = guf.to_dict()
    if mcm is not None:
        document["mcm"] = mcm.to_dict()
    if validation is not None:
        document["validation"] = validation.to_dict()
    return document
