"""What every uncertainty evaluation of m output quantities reports, whatever the method.

:class:`UncertaintyResult` holds the fields that the GUF
(:class:`~mtmetrology.uncertainty.guf.GUFResult`, JCGM 100:2008 and JCGM 102:2011,
clause 6) and Monte Carlo (:class:`~mtmetrology.uncertainty.mcm.MCMResult`, JCGM 101:2008
and JCGM 102:2011, clause 7) share with one meaning, the :class:`.Output` record of each
output, and the common part of their file form; each method adds only its own fields.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from mtmetrology.display import NotebookRepr
from mtmetrology.errors import InputError
from mtmetrology.uncertainty.outputs import Output, output_records

__all__ = ["UncertaintyResult"]


@dataclass(frozen=True, eq=False)
class UncertaintyResult(NotebookRepr):
    """The estimate, covariance and coverage of m output quantities (JCGM 102:2011, 3.21).

    Attributes
    ----------
    names, units : tuple of str, length m
        Output names and unit labels.
    estimate : (m,) ndarray
        y: f(x) for the GUF, the mean of the model values for Monte Carlo.
    covariance : (m, m) ndarray
        U_y: C U_x Cᵀ for the GUF (JCGM 102, 6.2.1.3), the sample covariance for Monte
        Carlo (JCGM 102, 7.6).
    standard_uncertainty : (m,) ndarray
        u(y_j) = sqrt(U_y[j, j]).
    correlation : (m, m) ndarray
        R_y = D⁻¹ U_y D⁻¹, D = diag u(y) (rows of zero-variance outputs are 0 with a unit
        diagonal).
    largest_eigenvalue : float
        λ_max of R_y (1 for m = 1), a JCGM 102 validation quantity (7.9).
    region_coverage_factor : float or None
        k_p of the hyper-ellipsoidal coverage region for probability p (JCGM 102, 6.5.2.3
        and 7.7.2); Monte Carlo gives None for one output.
    rectangular_coverage_factor : float or None
        k_q of the hyper-rectangular coverage region (JCGM 102, 6.5.3 and 7.7.3); Monte
        Carlo gives None for one output.
    p : float
        Coverage probability.
    interval : (m, 2) ndarray
        Coverage interval of each output for probability p: y ± U for the GUF, the
        probabilistically symmetric interval for Monte Carlo (JCGM 101, 7.7.1).
    expanded_uncertainty : (m,) ndarray
        U_j, half the width of ``interval`` (JCGM 100, 6.2.1).
    coverage_factor : (m,) ndarray
        k_j = U_j / u(y_j) (JCGM 100, 6.2.1): the GUF's t quantile (JCGM 100, G.3),
        Monte Carlo's ratio (NaN for an output of zero variance).
    """

    method: ClassVar[str]

    names: tuple[str, ...]
    units: tuple[str, ...]
    estimate: np.ndarray
    covariance: np.ndarray
    standard_uncertainty: np.ndarray
    correlation: np.ndarray
    largest_eigenvalue: float
    region_coverage_factor: float | None
    rectangular_coverage_factor: float | None
    p: float
    interval: np.ndarray
    expanded_uncertainty: np.ndarray
    coverage_factor: np.ndarray

    @property
    def m(self) -> int:
        """Number of outputs."""
        return len(self.names)

    @property
    def outputs(self) -> tuple[Output, ...]:
        """One :class:`.Output` per output quantity."""
        return output_records(self, self.expanded_uncertainty, self.coverage_factor)

    def output(self, key: int | str = 0) -> Output:
        """The :class:`.Output` of one output quantity, by index or name.

        Raises
        ------
        InputError
            If no output has that name or the index is out of range.
        """
        return self.outputs[self._index(key)]

    def _index(self, key: int | str) -> int:
        if isinstance(key, str):
            if key not in self.names:
                raise InputError(f"no output named {key!r}; outputs are {list(self.names)}")
            return self.names.index(key)
        if not -self.m <= int(key) < self.m:
            raise InputError(f"output index {key} out of range for {self.m} outputs")
        return int(key)

    def to_dict(self) -> dict:
        """JSON-ready result: ``method``, ``outputs`` (:class:`.Output` layout), the
        method's per-output lists, the joint data (``covariance``, ``correlation``,
        ``largest_eigenvalue``, ``region_coverage_factor``,
        ``rectangular_coverage_factor``), then the method's own fields."""
        return {
            "method": self.method,
            "outputs": [o.to_dict() for o in self.outputs],
            **self._per_output_dict(),
            "covariance": {
                "names": list(self.names),
                "units": list(self.units),
                "matrix": self.covariance.tolist(),
            },
            "correlation": self.correlation.tolist(),
            "largest_eigenvalue": self.largest_eigenvalue,
            "region_coverage_factor": self.region_coverage_factor,
            "rectangular_coverage_factor": self.rectangular_coverage_factor,
            **self._method_dict(),
        }

    def _per_output_dict(self) -> dict:
        """The method's per-output lists, written after ``outputs``."""
        return {}

    def _method_dict(self) -> dict:
        """The method's own fields, written after the joint data."""
        return {}
