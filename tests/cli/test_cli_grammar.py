"""One command grammar (issue 31, docs/cli.md): ``mtm <noun> <action>``; the old
verb-first spellings are hidden aliases that print the new one and otherwise behave
identically."""

from __future__ import annotations

import importlib.metadata
import re
import subprocess
import sys
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from mtmetrology.cli import (
    ALIASES,
    NOUNS,
    QUANTITIES,
    SUMMARIES,
    TOP_LEVEL_VERBS,
    VERBS,
    build_app,
)

DOC = Path(__file__).resolve().parents[2] / "docs" / "cli.md"
OLD = [(group, sub, new) for group, subs in ALIASES.items() for sub, new in subs.items()]


runner = CliRunner()  # stdout and stderr apart (Click >= 8.2)


def _tree():
    return typer.main.get_command(build_app())


def test_every_group_is_a_noun_and_every_subcommand_an_action():
    """The visible tree: a group is a declared noun (or a top-level verb acting on files:
    ``mtm export <control>``), its subcommands declared verbs or quantities; a command
    without subcommands at the top is a top-level verb."""
    root = _tree()
    visible = {n: c for n, c in root.commands.items() if not c.hidden}
    assert set(visible) == set(SUMMARIES)
    for name, command in visible.items():
        if not hasattr(command, "commands"):
            assert name in TOP_LEVEL_VERBS, name
            continue
        if name in TOP_LEVEL_VERBS:  # mtm export fanuc: the verb acts on a control's files
            continue
        assert name in NOUNS, name
        for sub, subcommand in command.commands.items():
            assert not hasattr(subcommand, "commands"), (name, sub)  # two words at most
            assert sub in VERBS | QUANTITIES, f"mtm {name} {sub}"


def test_no_verb_is_a_group_and_the_old_groups_are_hidden():
    root = _tree()
    assert not (NOUNS & (VERBS - {"budget"}))  # 'budget' is a noun and cmm's action
    for old in ALIASES:
        assert old not in NOUNS
        assert root.commands[old].hidden
    listing = runner.invoke(build_app(listing=True), ["--help"]).stdout
    assert not {old for old in ALIASES if re.search(rf"│ {old} ", listing)}


@pytest.mark.parametrize(("group", "sub", "new"), OLD, ids=[f"{g} {s}" for g, s, _ in OLD])
def test_an_old_spelling_is_the_new_command_with_a_note(group, sub, new):
    """``mtm calibrate samba --help`` prints the new command's help and one note naming
    it on stderr; the exit code is the new command's."""
    old_run = runner.invoke(build_app(group), [group, sub, "--help"], env={"COLUMNS": "100"})
    new_run = runner.invoke(build_app(new.split()[0]), [*new.split(), "--help"],
                            env={"COLUMNS": "100"})  # fmt: skip
    assert old_run.exit_code == new_run.exit_code == 0
    assert old_run.stderr.splitlines() == [f"note: `mtm {group} {sub}` is now `mtm {new}`"]
    assert new_run.stderr == ""
    # the same help, but for the spelling in the usage line (and its padding)
    old_words = old_run.stdout.replace(f"mtm {group} {sub}", f"mtm {new}").split()
    assert old_words == new_run.stdout.split()


@pytest.mark.parametrize(
    ("old", "new", "code"),
    [
        (["verify", "length"], ["length", "verify"], 2),  # no readings: a usage error
        (["calibrate", "samba", "missing.csv", "--machine", "five-axis-wcbxfzyst",
          "--artefact", "missing.yaml", "-o", "out.json"],
         ["samba", "calibrate", "missing.csv", "--machine", "five-axis-wcbxfzyst",
          "--artefact", "missing.yaml", "-o", "out.json"], 2),
    ],
)  # fmt: skip
def test_an_old_spelling_fails_as_the_new_one(old, new, code, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    old_run = runner.invoke(build_app(old[0]), old)
    new_run = runner.invoke(build_app(new[0]), new)
    assert old_run.exit_code == new_run.exit_code == code
    note = f"note: `mtm {old[0]} {old[1]}` is now `mtm {new[0]} {new[1]}`"
    assert old_run.stderr.splitlines()[0] == note
    assert old_run.stderr.splitlines()[1:] == [
        line.replace(f"mtm {new[0]} {new[1]}", f"mtm {old[0]} {old[1]}")
        for line in new_run.stderr.splitlines()
    ]


def test_an_old_spelling_runs_identically(tmp_path, monkeypatch):
    """A real run: ``mtm simulate length`` and ``mtm length simulate`` write the same
    readings (same seed) and exit 0."""
    monkeypatch.chdir(tmp_path)
    common = ["--machine", "five-axis-wcbxfzyst", "--end-a", "0,0,0", "--end-b", "100,0,0",
              "--pairs", "3", "--seed", "7", "--noise-um", "0.5"]  # fmt: skip
    old_run = runner.invoke(build_app("simulate"), ["simulate", "length", *common, "-o", "a.csv"])
    new_run = runner.invoke(build_app("length"), ["length", "simulate", *common, "-o", "b.csv"])
    assert old_run.exit_code == new_run.exit_code == 0, old_run.output
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()
    note = "note: `mtm simulate length` is now `mtm length simulate`"
    assert old_run.stderr.splitlines()[0] == note
    assert old_run.stderr.splitlines()[1:] == [
        line.replace("b.csv", "a.csv") for line in new_run.stderr.splitlines()
    ]


def test_the_ball_plate_calibration_is_one_command():
    """``mtm calibrate ballplate`` is ``mtm cmm calibrate``, which holds both options sets:
    model selection (--model auto, --candidates) and the styli as unknowns
    (--qualification, --length)."""
    root = _tree()
    new = root.commands["cmm"].commands["calibrate"]
    old = root.commands["calibrate"].commands["ballplate"]
    assert old.callback.__wrapped__ is new.callback.__wrapped__
    options = {o for p in new.params for o in p.opts}
    assert {"--candidates", "--degrees", "--qualification", "--length", "--history"} <= options


def test_the_grammar_page_lists_every_command_and_every_old_spelling():
    """docs/cli.md holds the whole visible tree and the old-to-new table."""
    text = DOC.read_text(encoding="utf-8")
    root = _tree()
    for name, command in root.commands.items():
        if command.hidden:
            continue
        for sub in getattr(command, "commands", {}) or [None]:
            spelled = f"mtm {name}" + (f" {sub}" if sub else "")
            assert f"`{spelled}" in text, spelled
    for group, sub, new in OLD:
        assert f"| `mtm {group} {sub}` | `mtm {new}` |" in text


def test_version_prints_the_installed_version():
    run = subprocess.run(
        [sys.executable, "-m", "mtmetrology", "--version"], capture_output=True, text=True
    )
    assert run.returncode == 0
    assert run.stdout == f"mtmetrology {importlib.metadata.version('mtmetrology')}\n"


def test_the_rename_script_rewrites_old_spellings_once():
    """tools/rename_commands.py (for scripts and branches written before the change):
    words across a line break and argument lists are rewritten, Python names are not,
    and a second pass changes nothing."""
    import importlib.util

    path = Path(__file__).resolve().parents[2] / "tools" / "rename_commands.py"
    spec = importlib.util.spec_from_file_location("rename_commands", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    text = (
        "$ mtm calibrate ballplate-budget b.yaml\n`mtm calibrate\nballplate` and "
        'calibrate_samba(); app(["design", "compare", "--k", "2"]); mtm verify lengths r.csv'
    )
    new = module.rewrite(text)
    assert new == (
        "$ mtm cmm budget b.yaml\n`mtm cmm\ncalibrate` and "
        'calibrate_samba(); app(["samba", "compare-plans", "--k", "2"]); mtm length predict r.csv'
    )
    assert module.rewrite(new) == new
