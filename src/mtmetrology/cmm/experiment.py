"""Ball-plate set-ups compared with the plate's certificate (Salacheep 2016, Tables 6.1–6.8).

Each set-up gives the ball centres in the plate's own (3-2-1) frame; the experimental error
of the CMM is ``|mean over set-ups − certificate|`` per coordinate (the source's Table 6.8).
Two documented errors of the source are not copied: its Table 6.7 ("average") is a copy of
Table 6.6 (set-up BP312), not the mean, and its Table 7.1 cannot be derived from its own
Appendix 4 with its eq. 7.1 (digest of Salacheep 2016, §3.6–3.7).

References
----------
Salacheep, P. (2016). *Error Compensation and Uncertainty Evaluation of CMMs Based on
Kinematic Error Models and Gaussian Processes*. MPhil thesis, Brunel University London,
Tables 6.1–6.8, Appendix 5.
"""

from __future__ import annotations

import numpy as np

__all__ = ["certificate_deviation", "percentage_error"]


def certificate_deviation(setups, certificate) -> tuple[np.ndarray, np.ndarray]:
    """Mean of the set-ups and its absolute deviation from the certificate.

    Parameters
    ----------
    setups : array_like, shape (n_setups, n_balls, 3)
        Ball centres of each set-up in the plate frame, mm.
    certificate : array_like, shape (n_balls, 3)
        Calibrated centres, mm.

    Returns
    -------
    mean : ndarray (n_balls, 3)
    deviation : ndarray (n_balls, 3)
        ``|mean − certificate|``, mm (Salacheep 2016, Table 6.8).

    Examples
    --------
    >>> m, d = certificate_deviation([[[1.0, 0, 0]], [[1.2, 0, 0]]], [[1.0, 0, 0]])
    >>> np.round(d, 12).tolist()
    [[0.1, 0.0, 0.0]]
    """
    s = np.asarray(setups, dtype=float)
    c = np.asarray(certificate, dtype=float)
    if s.ndim != 3 or s.shape[1:] != c.shape or c.shape[-1] != 3:
        raise ValueError(f"set-ups {s.shape} and certificate {c.shape} do not match")
    mean = s.mean(axis=0)
    return mean, np.abs(mean - c)


def percentage_error(simulated, experimental) -> np.ndarray:
    """``|simulated − experimental| / experimental × 100`` (Salacheep 2016, eq. 7.1).

    Kept to show why the source's Table 7.1 cannot be reproduced; it divides by the error
    itself, so it is not a sound accuracy measure near zero error.
    """
    s = np.asarray(simulated, dtype=float)
    e = np.asarray(experimental, dtype=float)
    return np.abs(s - e) / np.abs(e) * 100.0
