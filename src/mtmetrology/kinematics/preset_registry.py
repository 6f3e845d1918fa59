"""The machine presets shipped with mtmetrology: names, files and the facts a listing shows.

Read straight from the preset files, without validating them into a machine (no
pydantic, no numpy): what ``mtm machine list`` needs, at the cost of reading three small
YAML files.  :meth:`mtmetrology.kinematics.machine.Machine.load` reads the same files in
full; tests/kinematics/test_preset_registry.py checks that both agree.

Examples
--------
>>> "three-axis-xfyz" in list_presets()
True
>>> [s.topology for s in preset_summaries() if s.name == "three-axis-xfyz"]
['WXFYZT']
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources

from mtmetrology.io.documents import parse_document
from mtmetrology.kinematics.topology import parse_topology

__all__ = ["PresetSummary", "list_presets", "preset_summaries", "preset_text"]


@dataclass(frozen=True)
class PresetSummary:
    """What a listing shows of one preset.

    Attributes
    ----------
    name : str
        Preset name (``Machine.load(name)``).
    topology : str
        Topology string, normalised as :func:`~mtmetrology.kinematics.topology.parse_topology`
        writes it.
    error_models : tuple of str
        Names of the preset's error models, in file order.
    description : str
        The preset's description, on one line.
    """

    name: str
    topology: str
    error_models: tuple[str, ...]
    description: str


def list_presets() -> list[str]:
    """Names of the machine presets shipped with mtmetrology."""
    files = resources.files("mtmetrology.kinematics").joinpath("presets")
    return sorted(p.name[: -len(".yaml")] for p in files.iterdir() if p.name.endswith(".yaml"))


def preset_text(name: str) -> str:
    """The machine file of a preset, as shipped (comments included).

    Written to a file, it is a machine file that ``Machine.load(path)`` reads as the
    preset: the starting point for a user's own travels, offsets or error models.

    Parameters
    ----------
    name : str
        A preset name (:func:`list_presets`).

    Returns
    -------
    str
        The YAML text.

    Raises
    ------
    MachineFileError
        ``name`` is not a preset.
    """
    if name not in list_presets():
        from mtmetrology.kinematics.config import MachineFileError  # pydantic: only to refuse

        raise MachineFileError(f"{name}: not a preset (presets: {', '.join(list_presets())})")
    return _preset_file(name).read_text(encoding="utf-8")


def preset_summaries() -> list[PresetSummary]:
    """Name, topology, error models and description of every preset, in name order."""
    out = []
    for name in list_presets():
        doc = parse_document(preset_text(name), f"preset {name}.yaml")
        out.append(
            PresetSummary(
                name=name,
                topology=parse_topology(doc["topology"]).string,
                error_models=tuple(doc.get("error_models") or ()),
                description=" ".join(str(doc.get("description") or "").split()),
            )
        )
    return out


def _preset_file(name: str):
    return resources.files("mtmetrology.kinematics").joinpath("presets", f"{name}.yaml")
