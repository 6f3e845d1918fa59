"""MkDocs hook: pages generated from the code, so they cannot drift from it.

- ``<!-- mtm:cli-reference -->`` becomes the reference of every ``mtm`` command, from the
  Typer application itself (help texts, arguments, options and defaults); the help texts
  are escaped, so the page shows them as ``--help`` prints them (``[,i,j,k][,end]`` is not
  a Markdown reference link, ``sense_<axis>`` not an HTML tag);
- ``<!-- mtm:conventions PRESET MODEL -->`` becomes the table of that error model's
  parameters with their unit, what a positive value does and where it is referred to
  (:func:`mtmetrology.kinematics.conventions.describe_parameters`, the text that
  ``mtm machine show`` prints).

A ``<!-- from: ... -->`` marker right after a quoted number (tests/docs/doccheck.py compares the
number with a run of the page) is removed from the page: it is for the test, not the reader,
and so is the ``from="FILE"`` of a fence that shows lines of a file the page wrote
(superfences would not render a fence with an attribute it does not know).
"""

from __future__ import annotations

import re

# Markers stand alone on their line (a marker quoted in a sentence is left alone).
CLI_MARKER = re.compile(r"^<!-- mtm:cli-reference -->$", re.MULTILINE)
CONVENTIONS = re.compile(r"^<!-- mtm:conventions (\S+) (\S+) -->$", re.MULTILINE)
# a fenced block is matched first and kept: a marker shown in a code example stays
FROM_MARKER = re.compile(r"(^```.*?^```)|(?<=\d)<!-- from: .+? -->", re.MULTILINE | re.DOTALL)
FENCE_FROM = re.compile(r'^(```[\w-]*[^\n]*?) from="[^"]*"', re.MULTILINE)
# The Markdown that Typer's generator adds around the help texts (left as it is): headings,
# section labels, the fences of the usage blocks, and the "* `name`: " of each list item.
STRUCTURE = re.compile(r"^(#+ `[^`]*`|\*\*\w+\*\*:|```\w*)$")
ITEM = re.compile(r"^(\* `[^`]*`)(: )?(.*)$")
# Python-Markdown's backslash escapes; "<" and "&" become entities (no escape exists).
SPECIAL = re.compile(r"([\\`*_{}\[\]()#+\-.!>])")


def escape_markdown(text: str) -> str:
    """Text that Markdown renders as it is: ``[a][b]``, ``x_<axis>``, ``*`` stay literal."""
    text = text.replace("&", "&amp;").replace("<", "&lt;")
    return SPECIAL.sub(r"\\\1", text)


def _escape_help_texts(generated: str) -> str:
    """Escape the help texts in Typer's Markdown, not the Markdown Typer wrote around them."""
    lines, in_fence = [], False
    for line in generated.splitlines():
        if line.startswith("```"):
            in_fence = not in_fence
            lines.append(line)
        elif in_fence or STRUCTURE.match(line) or not line.strip():
            lines.append(line)
        elif item := ITEM.match(line):
            lines.append(item.group(1) + (item.group(2) or "") + escape_markdown(item.group(3)))
        else:
            lines.append(escape_markdown(line))
    return "\n".join(lines) + "\n"


def _cli_reference() -> str:
    import typer
    from typer.cli import get_docs_for_click
    from typer.main import get_command

    from mtmetrology.cli import app

    command = get_command(app)
    text = _escape_help_texts(
        get_docs_for_click(obj=command, ctx=typer.Context(command), name="mtm")
    )
    # the page has its own title: every generated heading goes one level down
    return re.sub(r"^(#+) ", r"#\1 ", text, flags=re.MULTILINE)


def _conventions(match: re.Match) -> str:
    from mtmetrology.kinematics.conventions import describe_parameters
    from mtmetrology.kinematics.machine import Machine

    machine = Machine.load(match.group(1), match.group(2))
    rows = [
        "| parameter | unit | a positive value | referred to |",
        "|---|---|---|---|",
    ]
    for c in describe_parameters(machine):
        cells = (f"`{c.name}`", c.unit, c.positive, c.reference)
        rows.append("| " + " | ".join(s.replace("|", "\\|") for s in cells) + " |")
    return "\n".join(rows)


def on_page_markdown(markdown: str, page, config, files) -> str:
    if CLI_MARKER.search(markdown):
        markdown = CLI_MARKER.sub(lambda _: _cli_reference(), markdown)
    markdown = FROM_MARKER.sub(lambda m: m.group(1) or "", markdown)
    markdown = FENCE_FROM.sub(r"\1", markdown)
    return CONVENTIONS.sub(_conventions, markdown)
