"""Uncertainty budgets and conformity decisions (ISO 14253-1:2017)."""

from mtmetrology.budgets.conformity import ConformityDecision, Decision, Tolerance, decide

__all__ = ["ConformityDecision", "Decision", "Tolerance", "decide"]
