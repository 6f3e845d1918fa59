"""Help texts read cleanly at 80 columns (issue 18 §3: ``mtm samba calibrate --help`` was
wrapped twice, file formats broken mid-sentence)."""

from __future__ import annotations

import pytest
import typer
from typer.testing import CliRunner

from mtmetrology.cli import build_app
from mtmetrology.cli._common import HELP_WIDTH

runner = CliRunner()


def _commands():
    root = typer.main.get_command(build_app())

    def walk(cmd, path):
        yield path, cmd
        for name, sub in getattr(cmd, "commands", {}).items():
            yield from walk(sub, [*path, name])

    return list(walk(root, []))


def test_every_help_is_prose_on_one_line_or_verbatim_within_the_width():
    """A prose paragraph reaches the terminal as one line (the terminal wraps it once); a
    verbatim block (indented lines, tables, YAML) fits 80 columns as written."""
    for path, cmd in _commands():
        for para in (cmd.help or "").split("\n\n"):
            lines = para.split("\n")
            if len(lines) > 1:
                assert para.startswith("\b") or any(ln.startswith(" ") for ln in lines), path
                too_wide = [ln for ln in lines if len(ln) > HELP_WIDTH]
                assert not too_wide, (path, too_wide)


@pytest.mark.parametrize("command", [["samba", "calibrate"], ["repeatability", "fit"]])
def test_help_at_80_columns_has_no_line_broken_twice(command):
    """Rendered at COLUMNS=80, each description line is the terminal's own wrap: a prose
    line ends short only at its paragraph's end (a double wrap left 'that put' alone)."""
    result = runner.invoke(build_app(), [*command, "--help"], env={"COLUMNS": "80"})
    assert result.exit_code == 0
    lines = result.output.splitlines()
    assert max(len(ln) for ln in lines) <= 80
    description = lines[: next(i for i, ln in enumerate(lines) if ln.startswith("╭"))]
    paragraphs, current = [], []
    for ln in [*description, ""]:
        if ln.strip():
            current.append(ln.rstrip())
        elif current:
            paragraphs.append(current)
            current = []
    for para in paragraphs[1:]:  # after the usage line
        if para[0].startswith("   "):  # a verbatim block: its lines are as written
            continue
        assert all(len(ln) >= 60 for ln in para[:-1]), para
