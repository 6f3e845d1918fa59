"""The descriptions of the file formats, shipped with the package (``mtm formats``).

``formats.md`` beside this module is the one source: ``mtm formats NAME`` prints its
sections and docs/file-formats.md is the same text (tests/io/test_formats.py holds them
equal), so an installed package describes its formats without the documentation. Each
format is a ``## `` section whose heading is followed by a ``<!-- format: NAME -->`` line.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from importlib.resources import files

from mtmetrology.errors import InputError

__all__ = ["FileFormat", "describe_format", "file_formats", "formats_text"]

_SECTION = re.compile(r"^## (?P<title>.+)\n\n<!-- format: (?P<name>[\w-]+) -->\n", re.MULTILINE)


@dataclass(frozen=True)
class FileFormat:
    """One format: its ``name`` (what ``mtm formats NAME`` takes), ``title`` (the heading,
    its one-line description) and ``text`` (the section in Markdown, without the marker)."""

    name: str
    title: str
    text: str


def formats_text() -> str:
    """The whole description (Markdown), as shipped in the package."""
    return files("mtmetrology.io").joinpath("formats.md").read_text(encoding="utf-8")


def file_formats() -> list[FileFormat]:
    """Every format described, in the order of the description."""
    text = formats_text()
    heads = list(_SECTION.finditer(text))
    out = []
    for i, head in enumerate(heads):
        end = heads[i + 1].start() if i + 1 < len(heads) else len(text)
        body = text[head.end() : end].strip("\n")
        out.append(FileFormat(head["name"], head["title"], f"## {head['title']}\n\n{body}\n"))
    return out


def describe_format(name: str) -> FileFormat:
    """The format called ``name``.

    Raises
    ------
    InputError
        No format has that name (the message lists the names).
    """
    known = file_formats()
    for fmt in known:
        if fmt.name == name:
            return fmt
    raise InputError(
        f"no file format {name!r}; the formats are: {', '.join(f.name for f in known)}"
    )
