"""mtmetrology: machine-tool and CMM metrology.

Kinematic error models of any serial machine, identification of those errors from
artefact measurements, GUM / Monte Carlo uncertainty, and geometric elements.
Internal units are mm, rad and dimensionless; see :mod:`mtmetrology.units`.

The objects a user meets first are importable from the package itself::

    from mtmetrology import Machine, ParameterSet, InputSet, InputQuantity, Normal, guf

They load on first use (PEP 562), so ``import mtmetrology`` stays cheap; each lives in
its engine (the table ``_API`` names it) and is documented there.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from mtmetrology._lazy import lazy_exports

__version__ = "0.1.0"

#: Public name -> module that defines it.
_API = {
    # kinematics
    "Machine": "mtmetrology.kinematics.machine",
    "ParameterSet": "mtmetrology.kinematics.parameter_set",
    "list_presets": "mtmetrology.kinematics.preset_registry",
    # uncertainty (GUM, JCGM 101/102)
    "InputQuantity": "mtmetrology.uncertainty.inputs",
    "InputSet": "mtmetrology.uncertainty.inputs",
    "Normal": "mtmetrology.uncertainty.distributions",
    "Rectangular": "mtmetrology.uncertainty.distributions",
    "StudentT": "mtmetrology.uncertainty.distributions",
    "Triangular": "mtmetrology.uncertainty.distributions",
    "guf": "mtmetrology.uncertainty.guf",
    "monte_carlo": "mtmetrology.uncertainty.mcm",
    "validate_guf": "mtmetrology.uncertainty.validation",
    "load_model": "mtmetrology.uncertainty.modelfile",
    # identification
    "levenberg_marquardt": "mtmetrology.identification.solver",
    "IdentificationModel": "mtmetrology.identification.uncertainty",
    "identification_guf": "mtmetrology.identification.uncertainty",
    "identification_mcm": "mtmetrology.identification.uncertainty",
    # fitting
    "fit_circle": "mtmetrology.fitting.least_squares",
    "fit_cylinder": "mtmetrology.fitting.least_squares",
    "fit_line": "mtmetrology.fitting.least_squares",
    "fit_plane": "mtmetrology.fitting.least_squares",
    "fit_sphere": "mtmetrology.fitting.least_squares",
    # units, errors, reports
    "to_internal": "mtmetrology.units",
    "from_internal": "mtmetrology.units",
    "InputError": "mtmetrology.errors",
    "MtmetrologyError": "mtmetrology.errors",
    "Report": "mtmetrology.report.document",
}

__all__ = [
    "IdentificationModel",
    "InputError",
    "InputQuantity",
    "InputSet",
    "Machine",
    "MtmetrologyError",
    "Normal",
    "ParameterSet",
    "Rectangular",
    "Report",
    "StudentT",
    "Triangular",
    "fit_circle",
    "fit_cylinder",
    "fit_line",
    "fit_plane",
    "fit_sphere",
    "from_internal",
    "guf",
    "identification_guf",
    "identification_mcm",
    "levenberg_marquardt",
    "list_presets",
    "load_model",
    "monte_carlo",
    "to_internal",
    "validate_guf",
]

if TYPE_CHECKING:
    from mtmetrology.errors import InputError, MtmetrologyError
    from mtmetrology.fitting.least_squares import (
        fit_circle,
        fit_cylinder,
        fit_line,
        fit_plane,
        fit_sphere,
    )
    from mtmetrology.identification.solver import levenberg_marquardt
    from mtmetrology.identification.uncertainty import (
        IdentificationModel,
        identification_guf,
        identification_mcm,
    )
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.kinematics.parameter_set import ParameterSet
    from mtmetrology.kinematics.preset_registry import list_presets
    from mtmetrology.report.document import Report
    from mtmetrology.uncertainty.distributions import Normal, Rectangular, StudentT, Triangular
    from mtmetrology.uncertainty.guf import guf
    from mtmetrology.uncertainty.inputs import InputQuantity, InputSet
    from mtmetrology.uncertainty.mcm import monte_carlo
    from mtmetrology.uncertainty.modelfile import load_model
    from mtmetrology.uncertainty.validation import validate_guf
    from mtmetrology.units import from_internal, to_internal


__getattr__, __dir__ = lazy_exports(__name__, _API)
