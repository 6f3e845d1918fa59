"""Compensation in the control: one neutral model, the tables real controls read, and the
error that remains after the control interpolates them.

- :mod:`~mtmetrology.export.model` — :class:`CompensationModel`: ISO 230-1 error functions
  tabulated over their axes with the covariance of the tabulated values;
- :mod:`~mtmetrology.export.control` — the controls' interpolation and the residual check;
- writers and readers: :mod:`~mtmetrology.export.linuxcnc`, :mod:`~mtmetrology.export.fanuc`,
  :mod:`~mtmetrology.export.siemens`, :mod:`~mtmetrology.export.isg`,
  :mod:`~mtmetrology.export.etalon` (Etalon exchange format for ISG),
  :mod:`~mtmetrology.export.grid` (volumetric grid CSV);
- :mod:`~mtmetrology.export.workflow` — :func:`export_compensation`, the ``mtm export``
  workflow, and the pitch advisor.
"""

from mtmetrology.export.model import CompensationModel, ErrorTable, compensation_model

__all__ = ["CompensationModel", "ErrorTable", "compensation_model"]
