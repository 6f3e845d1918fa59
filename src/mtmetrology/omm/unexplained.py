"""Unexplained volumetric errors E: the ``unexplained-volumetric-error`` document.

cov(e) is the covariance of the compensated residuals at positions not used in the
identification (Sepahi Boroujeni (2021), eqs. 6-13 to 6-15); it is added to every
compensated point independently. The file holds it in µm²::

    kind: unexplained-volumetric-error
    version: 1
    unit: µm²
    covariance: [[45, -17, 5], [-17, 66, 7], [5, 7, 58]]

An estimate from data (:mod:`mtmetrology.uncertainty.unexplained_estimate`, ``mtm samba calibrate
--unexplained-out``) adds ``source`` and ``estimate`` (the estimator and its terms).
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, ValidationError

from mtmetrology.errors import InputError
from mtmetrology.io.covariance import symmetric_covariance
from mtmetrology.io.documents import load_document
from mtmetrology.io.schema import describe_validation_error
from mtmetrology.units import to_internal

__all__ = ["load_unexplained_covariance"]


class _Document(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    kind: Literal["unexplained-volumetric-error"]
    version: Literal[1]
    unit: Literal["µm²"]
    covariance: list[list[float]]
    source: str | None = None
    estimate: dict | None = None  # how it was estimated (uncertainty.unexplained_estimate)


def load_unexplained_covariance(path: str | Path) -> np.ndarray:
    """Read cov(e) (3×3, returned in mm²) and check that it is a covariance matrix.

    Raises
    ------
    InputError
        Schema errors, a matrix that is not 3×3 and symmetric, or one that is not
        positive semidefinite. (Eq. 6-15 as printed in the thesis, with
        cov_XZ = −22.0·10⁻⁵ mm², is not: its smallest eigenvalue is −1.7·10⁻⁴ mm².)
    """
    try:
        doc = _Document.model_validate(load_document(path, "unexplained volumetric error"))
    except ValidationError as err:
        text = describe_validation_error(str(path), "unexplained volumetric error", err)
        raise InputError(text.replace("\n  ", "; ")) from None
    rows = doc.covariance
    if len(rows) != 3 or any(len(r) != 3 for r in rows):
        raise InputError(f"{path}: covariance must be a symmetric 3×3 matrix (µm²)")
    c = symmetric_covariance(np.array(rows, dtype=float), f"{path}: covariance")
    low = float(np.linalg.eigvalsh(c)[0])
    if low < -1e-12 * np.abs(c).max():
        raise InputError(
            f"{path}: covariance is not positive semidefinite (smallest eigenvalue "
            f"{low:.3g} µm²); check the off-diagonal terms (eq. 6-15 of Sepahi Boroujeni "
            "(2021) as printed, cov_XZ = -220 µm², is not PSD either)"
        )
    um = to_internal(1.0, "µm")
    return c * um * um
