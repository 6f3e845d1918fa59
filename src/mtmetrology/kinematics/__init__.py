"""Kinematic engine: one model for any serial machine topology.

- :mod:`~mtmetrology.kinematics.topology` — topology strings (``WCBXFZYST`` ...);
- :mod:`~mtmetrology.kinematics.parameters` — ISO 230-1 error names, units, catalogue;
- :mod:`~mtmetrology.kinematics.basis` — monomial, Legendre, Chebyshev error-motion bases;
- :mod:`~mtmetrology.kinematics.chain` — forward kinematics and analytic Jacobians;
- :mod:`~mtmetrology.kinematics.machine` — machine definitions, presets, inverse kinematics;
- :mod:`~mtmetrology.kinematics.conventions` — what each parameter means: sign, reference point;
- :mod:`~mtmetrology.kinematics.parameter_set` — parameter values with covariance (files).

The names below load on first use (PEP 562): importing one module of the engine (the
preset registry for ``mtm machine list``) does not import the others, nor pydantic.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from mtmetrology._lazy import lazy_exports

#: Public name -> module that defines it.
_EXPORTS = {
    "Basis": "mtmetrology.kinematics.basis",
    "AxisGeometry": "mtmetrology.kinematics.chain",
    "ChainEvaluation": "mtmetrology.kinematics.chain",
    "KinematicChain": "mtmetrology.kinematics.chain",
    "MachineFileError": "mtmetrology.kinematics.config",
    "ParameterConvention": "mtmetrology.kinematics.conventions",
    "describe_parameter": "mtmetrology.kinematics.conventions",
    "describe_parameters": "mtmetrology.kinematics.conventions",
    "machine_description": "mtmetrology.kinematics.conventions",
    "Machine": "mtmetrology.kinematics.machine",
    "list_presets": "mtmetrology.kinematics.preset_registry",
    "ErrorParameter": "mtmetrology.kinematics.parameters",
    "ParameterNameError": "mtmetrology.kinematics.parameters",
    "catalogue": "mtmetrology.kinematics.parameters",
    "parse_parameter": "mtmetrology.kinematics.parameters",
    "Topology": "mtmetrology.kinematics.topology",
    "TopologyError": "mtmetrology.kinematics.topology",
    "parse_topology": "mtmetrology.kinematics.topology",
}

if TYPE_CHECKING:
    from mtmetrology.kinematics.basis import Basis
    from mtmetrology.kinematics.chain import AxisGeometry, ChainEvaluation, KinematicChain
    from mtmetrology.kinematics.config import MachineFileError
    from mtmetrology.kinematics.conventions import (
        ParameterConvention,
        describe_parameter,
        describe_parameters,
        machine_description,
    )
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.kinematics.parameters import (
        ErrorParameter,
        ParameterNameError,
        catalogue,
        parse_parameter,
    )
    from mtmetrology.kinematics.preset_registry import list_presets
    from mtmetrology.kinematics.topology import Topology, TopologyError, parse_topology

__all__ = [
    "AxisGeometry",
    "Basis",
    "ChainEvaluation",
    "ErrorParameter",
    "KinematicChain",
    "Machine",
    "MachineFileError",
    "ParameterConvention",
    "ParameterNameError",
    "Topology",
    "TopologyError",
    "catalogue",
    "describe_parameter",
    "describe_parameters",
    "list_presets",
    "machine_description",
    "parse_parameter",
    "parse_topology",
]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
