"""The input files of the tracker workflows: pose, tools, conditions, true errors.

Each reader takes the path a command was given (None: the documented default) and
returns the object the workflows (:func:`~mtmetrology.tracker.simulate`,
:func:`~mtmetrology.tracker.calibrate`, :func:`~mtmetrology.tracker.verify.verify`,
:func:`~mtmetrology.tracker.placement.plan_placement`) take.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.io.documents import load_document
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.kinematics.tracker import TrackerNoise, TrackerPose
from mtmetrology.tracker.setup import PAPER_POSE, MachineConditions
from mtmetrology.units import to_internal

__all__ = ["DEFAULT_TOOL", "load_conditions", "load_pose", "load_tools", "noise", "true_errors"]

#: The tool when no tools file is given, mm.
DEFAULT_TOOL = (0.0, 0.0, -100.0)


def load_pose(path: str | Path | None) -> TrackerPose:
    """A ``tracker-pose`` document (D, L, H mm; α, β, δ deg); the paper's Study 2 pose when
    ``path`` is None."""
    if path is None:
        return PAPER_POSE
    doc = load_document(path, "tracker pose")
    if not isinstance(doc, dict) or doc.get("kind") != "tracker-pose":
        raise InputError(f"{path}: kind: expected 'tracker-pose'")
    fields = {k: v for k, v in doc.items() if k not in ("kind", "version")}
    return TrackerPose.from_dict(fields, str(path))


def load_tools(path: str | Path | None) -> np.ndarray:
    """The ``tools_mm`` (k, 3) of a ``tracker-tools`` document; :data:`DEFAULT_TOOL` when
    ``path`` is None."""
    if path is None:
        return np.array([DEFAULT_TOOL])
    doc = load_document(path, "tracker tools")
    if not isinstance(doc, dict) or doc.get("kind") != "tracker-tools":
        raise InputError(f"{path}: kind: expected 'tracker-tools'")
    try:
        tools = np.array(doc["tools_mm"], dtype=float)
    except (KeyError, TypeError, ValueError):
        raise InputError(f"{path}: tools_mm: a list of [x, y, z] in mm is required") from None
    if tools.ndim != 2 or tools.shape[1] != 3 or not np.all(np.isfinite(tools)):
        raise InputError(f"{path}: tools_mm: each tool must be three finite numbers (mm)")
    return tools


def load_conditions(path: str | Path | None) -> MachineConditions:
    """A ``tracker-conditions`` document; 20 °C, steel and no further terms when None."""
    if path is None:
        return MachineConditions()
    doc = load_document(path, "tracker conditions")
    if not isinstance(doc, dict) or doc.get("kind") != "tracker-conditions":
        raise InputError(f"{path}: kind: expected 'tracker-conditions'")
    return MachineConditions.from_dict(doc, str(path))


def noise(angle_urad: float) -> TrackerNoise:
    """The tracker's noise from its angular level, µrad (positive)."""
    if not math.isfinite(angle_urad) or angle_urad <= 0:
        raise InputError(f"--angle-urad must be a positive number, got {angle_urad}")
    return TrackerNoise(u_angle=float(to_internal(angle_urad, "µrad")))


def true_errors(machine, path: str | Path | None) -> np.ndarray:
    """The true parameter vector of a simulation (internal units, ``machine`` order): the
    parameters of a parameter-set file, the others zero; zero when ``path`` is None."""
    if path is None:
        return np.zeros(machine.n_params)
    pset = ParameterSet.load(path, machine)
    values = dict(zip(pset.names, pset.values, strict=True))
    unknown = [n for n in values if n not in machine.parameter_names]
    if unknown:
        raise InputError(
            f"{path}: {unknown[0]} is not a parameter of the model {machine.model_name}"
        )
    return np.array([values.get(n, 0.0) for n in machine.parameter_names])
