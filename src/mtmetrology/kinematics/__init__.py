"""Kinematic engine: one model for any serial machine topology.

- :mod:`~mtmetrology.kinematics.topology` — topology strings (``WCBXFZYST`` ...);
- :mod:`~mtmetrology.kinematics.parameters` — ISO 230-1 error names, units, catalogue;
- :mod:`~mtmetrology.kinematics.basis` — monomial, Legendre, Chebyshev error-motion bases;
- :mod:`~mtmetrology.kinematics.chain` — forward kinematics and analytic Jacobians;
- :mod:`~mtmetrology.kinematics.machine` — machine definitions, presets, inverse kinematics;
- :mod:`~mtmetrology.kinematics.conventions` — what each parameter means: sign, reference point;
- :mod:`~mtmetrology.kinematics.parameter_set` — parameter values with covariance (files).
"""

from mtmetrology.kinematics.basis import Basis
from mtmetrology.kinematics.chain import AxisGeometry, ChainEvaluation, KinematicChain
from mtmetrology.kinematics.config import MachineFileError
from mtmetrology.kinematics.conventions import (
    ParameterConvention,
    describe_parameter,
    describe_parameters,
    machine_description,
)
from mtmetrology.kinematics.machine import Machine, list_presets
from mtmetrology.kinematics.parameters import (
    ErrorParameter,
    ParameterNameError,
    catalogue,
    parse_parameter,
)
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
