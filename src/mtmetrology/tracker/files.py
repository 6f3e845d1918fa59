"""The input files of the tracker workflows: pose, tools, conditions, true errors.

Each reader takes the path a command was given (None: the documented default) and
returns the object the workflows (:func:`~mtmetrology.tracker.simulate`,
:func:`~mtmetrology.tracker.calibrate`, :func:`~mtmetrology.tracker.verify.verify`,
:func:`~mtmetrology.tracker.placement.plan_placement`) take.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.io.documents import load_document
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.kinematics.tracker import TrackerNoise, TrackerPose
from mtmetrology.tracker.setup import PAPER_POSE, MachineConditions
from mtmetrology.units import to_internal

__all__ = [
    "DEFAULT_TOOL",
    "POSE_KEYS",
    "POSE_U_KEYS",
    "load_conditions",
    "load_known_pose",
    "load_pose",
    "load_tools",
    "noise",
    "true_errors",
]

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
    known = ("kind", "version", *POSE_KEYS, *POSE_U_KEYS)
    unknown = [k for k in doc if k not in known]
    if unknown:
        raise InputError(
            f"{path}: {unknown[0]}: unknown key (a tracker pose has {', '.join(known[2:])})"
        )
    fields = {k: v for k, v in doc.items() if k in POSE_KEYS}
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


def noise(
    angle_urad: float,
    range_noise: str | None = None,
    angle_spread_urad: float | None = None,
    smr_um: float | None = None,
) -> TrackerNoise:
    """The tracker's noise model from the command's options (the source's values where
    an option is not given: 4 µm + 0.8 µm/m, 3 µrad spread, no SMR term).

    Parameters
    ----------
    angle_urad : float
        ``--angle-urad``: level of each angle reading, µrad (positive).
    range_noise : str, optional
        ``--range-noise A,B``: ``u_r = A + B·r``, A in µm, B in µm/m (standard
        uncertainties, k = 1).
    angle_spread_urad : float, optional
        ``--angle-spread``: standard deviation of the angular level itself, µrad.
    smr_um : float, optional
        ``--smr``: isotropic SMR-centring standard uncertainty, µm.

    Raises
    ------
    InputError
        Naming the option: a value that is not a finite number, negative, or a zero angle
        level.
    """
    if not math.isfinite(angle_urad) or angle_urad <= 0:
        raise InputError(f"--angle-urad must be a positive number, got {angle_urad}")
    default = TrackerNoise()
    kwargs = {"u_angle": float(to_internal(angle_urad, "µrad"))}
    if range_noise is not None:
        parts = str(range_noise).split(",")
        try:
            a, b = (float(v) for v in parts)
        except ValueError:
            a = b = math.nan
        if len(parts) != 2 or not (math.isfinite(a) and math.isfinite(b) and a >= 0 and b >= 0):
            raise InputError(
                f"--range-noise must be A,B: two finite numbers >= 0 (µm, µm/m), "
                f"got {range_noise!r}"
            )
        kwargs["u_range_constant"] = float(to_internal(a, "µm"))
        kwargs["u_range_per_length"] = float(to_internal(b, "µm/m"))
    for option, value, field, unit in (
        ("--angle-spread", angle_spread_urad, "u_angle_spread", "µrad"),
        ("--smr", smr_um, "u_smr", "µm"),
    ):
        if value is None:
            continue
        if not math.isfinite(value) or value < 0:
            raise InputError(f"{option} must be a finite number >= 0 ({unit}), got {value}")
        kwargs[field] = float(to_internal(value, unit))
    return replace(default, **kwargs)


#: The fields of a ``tracker-pose`` document (eq. 22: position along x, y, z; R = Rx Ry Rz).
POSE_KEYS = ("D_mm", "L_mm", "H_mm", "alpha_deg", "beta_deg", "delta_deg")
#: Standard uncertainties of a known pose used as a prior (``tracker-pose`` document).
POSE_U_KEYS = ("u_D_mm", "u_L_mm", "u_H_mm", "u_alpha_deg", "u_beta_deg", "u_delta_deg")


def load_known_pose(path: str | Path | None) -> tuple[TrackerPose | None, np.ndarray | None]:
    """A known pose for ``mtm tracker calibrate --pose``: (pose, covariance or None).

    The ``tracker-pose`` document of :func:`load_pose`; with the six standard uncertainties
    :data:`POSE_U_KEYS` the pose is a prior of that (diagonal) covariance, without them it
    is fixed.  ``(None, None)`` when ``path`` is None (the pose is identified).

    Raises
    ------
    InputError
        Some but not all of the uncertainties, or one that is not a finite number > 0.
    """
    if path is None:
        return None, None
    pose = load_pose(path)
    doc = load_document(path, "tracker pose")
    given = [k for k in POSE_U_KEYS if k in doc]
    if not given:
        return pose, None
    if len(given) != len(POSE_U_KEYS):
        missing = next(k for k in POSE_U_KEYS if k not in doc)
        raise InputError(f"{path}: {missing}: a pose prior needs all of {', '.join(POSE_U_KEYS)}")
    u = []
    for k in POSE_U_KEYS:
        try:
            v = float(doc[k])
        except (TypeError, ValueError):
            v = math.nan
        if not math.isfinite(v) or v <= 0:
            raise InputError(f"{path}: {k} must be a finite number > 0, got {doc[k]!r}")
        u.append(float(to_internal(v, "°")) if k.endswith("_deg") else v)
    return pose, np.diag(np.square(u))


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
