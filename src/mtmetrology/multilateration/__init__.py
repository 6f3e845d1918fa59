"""Sequential multilateration: machine errors from tracking-interferometer lengths.

Workflows (library functions returning one frozen result object each):
:func:`~mtmetrology.multilateration.workflow.simulate_lengths` (lengths of a machine
with known errors) and :func:`~mtmetrology.multilateration.workflow.calibrate_multilateration`
(the machine's error model, stations and dead paths, with covariance).
"""

__all__ = ["files", "problem", "workflow"]
