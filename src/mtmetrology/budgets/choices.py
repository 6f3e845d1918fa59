"""The named choices of the task budgets, in a module that imports nothing of the engines:
the command line lists them in its options (``mtm budget iso15530 --policy``, ``mtm budget
volumetric-map --feature``) without loading numpy, the fitting or the uncertainty engine.

The budgets themselves, :mod:`mtmetrology.budgets.iso15530` and
:mod:`mtmetrology.budgets.volumetric_map`, say what each choice does.
"""

from __future__ import annotations

from enum import StrEnum

__all__ = ["FEATURE_KINDS", "Policy", "RepeatabilityMethod"]


class Policy(StrEnum):
    """How the bias b enters the expanded uncertainty (see
    :mod:`mtmetrology.budgets.iso15530`)."""

    ISO_2004 = "2004"
    ISO_2011 = "2011"
    PAPER_003 = "paper003"


class RepeatabilityMethod(StrEnum):
    """u_p as one sample standard deviation or as the largest over series."""

    SAMPLE = "sample"
    MAX_OVER_SERIES = "max-over-series"


#: Features of :func:`mtmetrology.budgets.volumetric_map.volumetric_map_budget`.
FEATURE_KINDS = ("circle", "plane", "sphere", "cylinder", "length", "position")
