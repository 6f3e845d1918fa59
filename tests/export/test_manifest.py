"""The output directory of an export (issue 29): one run's files, listed in the manifest;
--force removes exactly those; anything else in the directory is never touched."""

from __future__ import annotations

import json

import pytest

from mtmetrology.errors import InputError
from mtmetrology.export.manifest import MANIFEST, commit_output, plan_output


def _names(d):
    return sorted(p.name for p in d.iterdir())


def test_a_run_replaces_exactly_the_previous_runs_files(tmp_path):
    out = tmp_path / "out"
    plan = plan_output(out, ["x.comp", "y.comp", "check.json"], force=False)
    assert plan.create and plan.previous == ()
    commit_output(plan, "linuxcnc", "mtm export linuxcnc ...")
    for name in plan.files:
        (out / name).write_text(name)
    manifest = json.loads((out / MANIFEST).read_text())
    assert manifest["files"] == ["check.json", "x.comp", "y.comp"]
    assert manifest["format"] == "linuxcnc" and manifest["kind"] == "mtm-export-manifest"

    with pytest.raises(InputError, match="--force replaces them"):
        plan_output(out, ["x.comp"], force=False)
    again = plan_output(out, ["x.comp", "check.json"], force=True)
    assert sorted(again.previous) == ["check.json", "x.comp", "y.comp"]
    commit_output(again, "linuxcnc")
    assert _names(out) == [MANIFEST]  # the old files gone before the new are written
    assert json.loads((out / MANIFEST).read_text())["files"] == ["check.json", "x.comp"]


def test_a_run_stopped_half_way_is_cleared_by_the_next(tmp_path):
    """The manifest is written before its files: files it lists that never came are
    skipped, those that did are removed."""
    out = tmp_path / "out"
    commit_output(plan_output(out, ["x.comp", "y.comp"], force=False), "linuxcnc")
    (out / "x.comp").write_text("1")  # y.comp never written
    plan = plan_output(out, ["z.comp"], force=True)
    assert plan.previous == ("x.comp",)
    commit_output(plan, "linuxcnc")
    assert _names(out) == [MANIFEST]


@pytest.mark.parametrize("force", [False, True])
def test_foreign_entries_are_refused_and_left_alone(tmp_path, force):
    out = tmp_path / "out"
    commit_output(plan_output(out, ["x.comp"], force=False), "linuxcnc")
    (out / "x.comp").write_text("1")
    (out / "sub").mkdir()
    with pytest.raises(InputError, match=r"holds 'sub', not written by an export"):
        plan_output(out, ["x.comp"], force=force)
    assert _names(out) == sorted([MANIFEST, "sub", "x.comp"])


@pytest.mark.parametrize(
    ("manifest", "message"),
    [
        ("not json", "not a readable export manifest"),
        (json.dumps({"kind": "other"}), "kind: not an mtm-export-manifest"),
        (json.dumps({"kind": "mtm-export-manifest", "files": "x.comp"}), "files: must be a list"),
        (json.dumps({"kind": "mtm-export-manifest", "files": ["/etc/x"]}), r"files\[0\]: '/etc/x'"),
        (json.dumps({"kind": "mtm-export-manifest", "files": [".."]}), r"files\[0\]: '\.\.'"),
    ],
)
def test_a_manifest_that_is_not_ours_is_refused(tmp_path, manifest, message):
    (tmp_path / MANIFEST).write_text(manifest)
    with pytest.raises(InputError, match=message):
        plan_output(tmp_path, ["x.comp"], force=True)
    assert _names(tmp_path) == [MANIFEST]


def test_a_file_is_not_a_directory_and_a_missing_parent_is_not_created(tmp_path):
    (tmp_path / "f").write_text("")
    with pytest.raises(InputError, match="is not a directory"):
        plan_output(tmp_path / "f", [], force=False)
    with pytest.raises(InputError, match="does not exist"):
        plan_output(tmp_path / "a" / "b", [], force=False)
