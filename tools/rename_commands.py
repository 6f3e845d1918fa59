"""Rewrite the old verb-first ``mtm`` spellings to the noun-first ones (issue 31).

Run from the repository root: ``python tools/rename_commands.py [PATH ...]`` (default: docs,
README.md, examples, src, tests, bench). Rewrites ``calibrate samba`` (words separated by any
whitespace, a line break included) and ``"calibrate", "samba"`` (argument lists) by the
table of :data:`mtmetrology.cli.ALIASES`; Python names (``calibrate_samba``) are left alone.
It is idempotent: a second run changes nothing.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))
from mtmetrology.cli import ALIASES

#: Files that state the old spellings on purpose.
KEEP = {"src/mtmetrology/cli/__init__.py", "docs/cli.md", "tools/rename_commands.py",
        "tests/cli/test_cli_grammar.py"}  # fmt: skip
SUFFIXES = {".md", ".py", ".sh", ".txt", ".yaml", ".yml", ".html", ".j2", ".ipynb", ".toml"}


def rules() -> list[tuple[re.Pattern, str]]:
    out = []
    # longest old subcommand first: "ballplate-budget" before "ballplate"
    pairs = sorted(
        ((g, s, n) for g, subs in ALIASES.items() for s, n in subs.items()),
        key=lambda t: -len(t[1]),
    )
    for group, sub, new in pairs:
        noun, verb = new.split()
        end = r"(?![\w-])"
        out.append(
            (re.compile(rf"(?<![\w-]){group}(\s+){re.escape(sub)}{end}"), rf"{noun}\1{verb}")
        )
        for q in ('"', "'"):
            out.append(
                (
                    re.compile(rf"{q}{group}{q},(\s*){q}{re.escape(sub)}{q}"),
                    rf"{q}{noun}{q},\1{q}{verb}{q}",
                )
            )
    return out


def rewrite(text: str) -> str:
    for pattern, replacement in rules():
        text = pattern.sub(replacement, text)
    return text


def main(paths: list[str]) -> None:
    listed = subprocess.run(
        ["git", "ls-files", *paths], capture_output=True, text=True, check=True
    ).stdout.split()
    for name in listed:
        path = Path(name)
        if name in KEEP or path.suffix not in SUFFIXES:
            continue
        text = path.read_text(encoding="utf-8")
        new = rewrite(text)
        if new != text:
            path.write_text(new, encoding="utf-8")
            print(name)


if __name__ == "__main__":
    main(sys.argv[1:] or ["docs", "README.md", "examples", "src", "tests", "bench"])
