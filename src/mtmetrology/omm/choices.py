"""Limits of the on-machine measurement workflows that the command line shows in its help,
in a module that imports nothing of the engines: ``mtm repeatability fit --help`` states the
fewest targets per coefficient without loading numpy or the least-squares core.

:func:`mtmetrology.omm.repeatability_model.fit_repeatability_model` says how each is used.
"""

from __future__ import annotations

__all__ = ["MIN_TARGETS_PER_COEFFICIENT"]

#: Fewest fitting targets per coefficient a model is fitted with unless asked: with 36
#: coefficients on 38 targets the held-out errors of cov(X,Y) reached 5 200 % (issue 18).
MIN_TARGETS_PER_COEFFICIENT = 3.0
