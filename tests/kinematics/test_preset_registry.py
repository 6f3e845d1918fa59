"""The preset registry (read from the files, no machine built) agrees with Machine.load."""

from __future__ import annotations

import pytest

from mtmetrology.kinematics.config import MachineFileError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.preset_registry import list_presets, preset_summaries, preset_text


@pytest.mark.parametrize("summary", preset_summaries(), ids=lambda s: s.name)
def test_summary_equals_the_loaded_machine(summary):
    m = Machine.load(summary.name)
    assert summary.topology == m.topology.string
    assert summary.error_models == tuple(m.spec.error_models)
    assert summary.description == " ".join(m.spec.description.split())


def test_summaries_cover_every_preset_in_name_order():
    assert [s.name for s in preset_summaries()] == list_presets() == sorted(list_presets())


def test_unknown_preset_is_refused_naming_the_presets():
    with pytest.raises(MachineFileError) as err:
        preset_text("no-such-machine")
    assert str(err.value).startswith("no-such-machine: not a preset (presets: ")
    assert all(name in str(err.value) for name in list_presets())
