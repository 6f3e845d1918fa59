"""The named choices of calibration planning, in a module that imports nothing of the
engines: the command line lists them in its options (``mtm samba plan --criterion``,
``mtm samba compare-plans --criterion``) without loading numpy.

:mod:`mtmetrology.design.criteria` says what each criterion computes.
"""

from __future__ import annotations

__all__ = ["CRITERIA", "SCALED_CRITERIA"]

#: Criteria understood by the design routines.
CRITERIA = ("D", "A", "E", "O1", "O2", "O3", "O4", "O5")
#: Criteria evaluated on the per-design column-scaled information matrix.
SCALED_CRITERIA = ("O1", "O2", "O3", "O4", "O5")
