"""The documentation's commands run, so the tutorials never rot.

Convention (docs/contributing.md): in every page under ``docs/``,

- a fenced block with a ``title="NAME"`` attribute (```` ```yaml title="model.yaml" ````)
  is a file the reader creates: it is written to ``NAME`` in the page's working folder;
- a fenced ``console`` block holds commands, one per line starting with ``$ mtm``
  (a trailing backslash continues a line); the lines after a command are its output,
  shown to the reader and not compared, except that an output line starting with
  ``error:`` means the command must fail with exit code 2 and an ``error:`` line on
  stderr.

Each page runs in a fresh temporary folder, holding a copy of the repository's
``examples/`` folder (input files a tutorial may name as ``examples/...``), its blocks in
order; every other command must exit with code 0.
"""

from __future__ import annotations

import re
import shlex
import shutil
from pathlib import Path, PurePosixPath

import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
EXAMPLES = ROOT / "examples"
FENCE = re.compile(r"^```([\w-]*)([^\n]*)\n(.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)
TITLE = re.compile(r'title="([^"]+)"')


def blocks(text: str):
    """(language, title or None, body) of each fenced block of a page, in order."""
    for match in FENCE.finditer(text):
        title = TITLE.search(match.group(2))
        yield match.group(1), (title.group(1) if title else None), match.group(3)


def commands(body: str) -> list[tuple[list[str], bool]]:
    """The ``$ mtm`` commands of a console block and whether each is expected to fail."""
    lines = body.splitlines()
    out, i = [], 0
    while i < len(lines):
        line = lines[i]
        i += 1
        if not line.startswith("$ "):
            continue
        text = line[2:]
        while text.endswith("\\") and i < len(lines):
            text = text[:-1] + " " + lines[i].strip()
            i += 1
        end = next((k for k in range(i, len(lines)) if lines[k].startswith("$ ")), len(lines))
        out.append((shlex.split(text), any(o.startswith("error:") for o in lines[i:end])))
    return out


def pages_with_commands() -> list[Path]:
    return sorted(
        p
        for p in DOCS.rglob("*.md")
        if any(lang == "console" for lang, _, _ in blocks(p.read_text(encoding="utf-8")))
    )


@pytest.mark.parametrize("page", pages_with_commands(), ids=lambda p: str(p.relative_to(DOCS)))
def test_page_commands_run(page: Path, tmp_path: Path, monkeypatch) -> None:
    shutil.copytree(EXAMPLES, tmp_path / "examples")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("COLUMNS", "100")
    runner = CliRunner()
    ran = 0
    for language, title, body in blocks(page.read_text(encoding="utf-8")):
        if title is not None:
            name = PurePosixPath(title)
            assert not name.is_absolute() and ".." not in name.parts, f"{page}: {title}"
            (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
            (tmp_path / name).write_text(body, encoding="utf-8")
        elif language == "console":
            for argv, must_fail in commands(body):
                assert argv[0] == "mtm", f"{page.name}: only mtm commands run: {argv}"
                result = runner.invoke(app, argv[1:])
                shown = f"{page.name}: $ {shlex.join(argv)}\n{result.output}"
                if must_fail:
                    assert result.exit_code == 2, shown
                    assert result.stderr.startswith("error: "), shown
                else:
                    assert result.exit_code == 0, shown
                ran += 1
    assert ran > 0


def test_the_convention_finds_files_and_commands() -> None:
    """The parser itself: a titled file, a continued command, an expected failure."""
    body = (
        "$ mtm fit sphere \\\n    pts.csv --json\n{...}\n$ mtm fit sphere missing.csv\nerror: x\n"
    )
    assert commands(body) == [
        (["mtm", "fit", "sphere", "pts.csv", "--json"], False),
        (["mtm", "fit", "sphere", "missing.csv"], True),
    ]
    text = '```csv title="pts.csv"\nx,y,z\n```\n\n```console\n$ mtm machine list\n```\n'
    assert list(blocks(text)) == [
        ("csv", "pts.csv", "x,y,z\n"),
        ("console", None, "$ mtm machine list\n"),
    ]
