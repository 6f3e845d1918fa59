"""Measurement-uncertainty budgets of a measured characteristic without a calibrated workpiece.

:mod:`~mtmetrology.budgets.iso15530` combines the contributions of ISO 15530-3 (substitution
with a calibrated workpiece: u_cal, u_p, u_w and the bias b) under the 2004, 2011 and
paper-003 rules; :mod:`~mtmetrology.budgets.volumetric_map` replaces the calibrated part's
bias by the one a volumetric error map predicts (VDI/VDE 2617-11, seed 003).  Decisions
against a tolerance use :func:`mtmetrology.uncertainty.conformity.decide` (ISO 14253-1).
"""

__all__ = ["iso15530", "volumetric_map"]
