"""Atomic outputs and output checks (mtmetrology.io.files)."""

from __future__ import annotations

import os

import pytest

from mtmetrology.errors import InputError
from mtmetrology.io import atomic_write, check_output, sweep_temporaries


def _names(directory):
    return sorted(p.name for p in directory.iterdir())


def test_atomic_write_replaces_only_on_success(tmp_path):
    target = tmp_path / "out.csv"
    target.write_text("old\n")
    with pytest.raises(RuntimeError), atomic_write(target) as fh:
        fh.write("half a result")
        raise RuntimeError("stopped")
    assert target.read_text() == "old\n" and _names(tmp_path) == ["out.csv"]
    with pytest.raises(KeyboardInterrupt), atomic_write(target, "wb") as fh:
        fh.write(b"half")
        raise KeyboardInterrupt
    assert target.read_text() == "old\n" and _names(tmp_path) == ["out.csv"]
    with atomic_write(target) as fh:
        fh.write("new\n")
    assert target.read_text() == "new\n" and _names(tmp_path) == ["out.csv"]


def test_atomic_write_into_a_missing_directory_is_refused(tmp_path):
    with pytest.raises(InputError, match="does not exist"), atomic_write(tmp_path / "no" / "x"):
        pass
    assert not (tmp_path / "no").exists()


def test_check_output_refuses_before_any_work(tmp_path):
    source = tmp_path / "in.csv"
    source.write_text("x\n1\n")
    with pytest.raises(InputError, match="would overwrite the input"):
        check_output(source, [source])
    with pytest.raises(InputError, match="would overwrite the input"):
        check_output(tmp_path / "." / "in.csv", [source])
    with pytest.raises(InputError, match="is a directory"):
        check_output(tmp_path, [source])
    with pytest.raises(InputError, match="does not exist"):
        check_output(tmp_path / "missing" / "out.csv", [source])
    assert check_output(tmp_path / "out.csv", [source]) == tmp_path / "out.csv"


def test_check_output_refuses_a_read_only_target(tmp_path):
    target = tmp_path / "ro.csv"
    target.write_text("x\n")
    target.chmod(0o444)
    with pytest.raises(InputError, match="read-only"):
        check_output(target)


def test_sweep_removes_only_temporaries_of_dead_processes(tmp_path):
    target = tmp_path / "out.csv"
    dead = 2**22 + 12345  # above pid_max defaults: no such process
    stale = tmp_path / f".out.csv.{dead}.0a1b2c3d.tmp"
    live = tmp_path / f".out.csv.{os.getpid()}.0a1b2c3d.tmp"
    other = tmp_path / f".other.csv.{dead}.0a1b2c3d.tmp"
    for p in (stale, live, other):
        p.write_text("partial")
    assert sweep_temporaries(target) == [stale]
    assert _names(tmp_path) == sorted([live.name, other.name])
