"""The generated command-line reference shows every help text as ``--help`` prints it.

The hook ``docs/hooks/mtm_docs.py`` turns the Typer application into Markdown. Help texts
hold characters that Markdown reads as markup: ``[,i,j,k][,end]`` is a reference link
(``mkdocs build --strict`` stopped on it), ``sense_<axis>`` an HTML tag that the browser
hides. Rendered with the Markdown extensions of ``mkdocs.yml`` and the autorefs extension,
the page must hold no cross-reference and, as text, every help text.
"""

from __future__ import annotations

import importlib.util
import re
from html.parser import HTMLParser
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

markdown = pytest.importorskip("markdown")
autorefs = pytest.importorskip("mkdocs_autorefs")

HOOK = Path(__file__).resolve().parents[2] / "docs" / "hooks" / "mtm_docs.py"


def load_hook():
    spec = importlib.util.spec_from_file_location("mtm_docs", HOOK)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


hook = load_hook()


class _Text(HTMLParser):
    """The text a reader sees (character references resolved) and the tags met."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.parts: list[str] = []
        self.tags: list[str] = []

    def handle_starttag(self, tag, attrs) -> None:
        self.tags.append(tag)

    def handle_data(self, data: str) -> None:
        self.parts.append(data)


def render(text: str) -> tuple[str, list[str]]:
    """Markdown → (visible text with whitespace collapsed, tags), as the site renders it."""
    md = markdown.Markdown(
        extensions=["tables", "attr_list", "fenced_code", autorefs.AutorefsExtension()]
    )
    parser = _Text()
    parser.feed(md.convert(text))
    return " ".join("".join(parser.parts).split()), parser.tags


def squash(text: str) -> str:
    return " ".join(text.split())


# Letters, digits, the characters Markdown reads as markup, HTML's, and single spaces.
PLAIN = st.text(
    alphabet=st.sampled_from("ab1_*[](){}<>&#+-.!`\\|:;'\"=~ "), min_size=1, max_size=40
)


@settings(max_examples=200, deadline=None, derandomize=True)
@given(PLAIN)
def test_escaped_text_renders_as_written(text: str) -> None:
    shown, tags = render(hook.escape_markdown(text))
    assert shown == squash(text)
    assert tags in ([], ["p"])


def test_the_two_defects_of_issue_18() -> None:
    """Unescaped, the reference link and the tag are not text; escaped, they are."""
    text = "point,X,Y,Z,B,C[,i,j,k][,end]; columns sense_<axis> (+1/-1)"
    shown, tags = render(text)
    assert "autoref" in tags and "axis" in tags and shown != text
    assert render(hook.escape_markdown(text)) == (text, ["p"])


def _commands(command, ctx_name="mtm"):
    """Every click command of the application (groups included), depth first."""
    yield ctx_name, command
    for name, sub in getattr(command, "commands", {}).items():
        yield from _commands(sub, f"{ctx_name} {name}")


def test_reference_page_shows_every_help_text() -> None:
    from typer.main import get_command

    from mtmetrology.cli import app

    shown, tags = render(hook._cli_reference())
    assert "autoref" not in tags
    assert not {"axis", "file", "path"} & set(tags)  # placeholders are not HTML
    helps = 0
    for name, command in _commands(get_command(app)):
        assert f"{name} [OPTIONS]" in shown
        texts = [command.help or ""] + [p.help or "" for p in command.params]
        for text in filter(None, texts):
            # click's "\b" marks a paragraph that it does not rewrap; it is not shown
            for paragraph in re.split(r"\n\s*\n|\x08", text):
                if paragraph.strip():
                    assert squash(paragraph) in shown, f"{name}: {paragraph!r}"
                    helps += 1
    assert helps > 100


def test_number_markers_are_removed_from_the_page_but_not_from_code() -> None:
    """``<!-- from: ... -->`` after a quoted number is for the docs test: the hook drops it
    from the prose and leaves a marker shown in a code example as written."""
    code = "```markdown\nu = 8.8<!-- from: x -->\n```\n"
    text = "u = 8.8<!-- from: task.json outputs.0.u µm --> µm\n\n" + code
    out = hook.on_page_markdown(text, None, None, None)
    assert out == "u = 8.8 µm\n\n" + code


def test_a_fence_showing_a_file_renders_as_a_plain_fence() -> None:
    """``from="FILE"`` is for the docs test: the hook drops it so the fence renders."""
    text = '```text from="records.csv"\nball,X\n```\n\n```yaml title="a.yaml"\nx: 1\n```\n'
    out = hook.on_page_markdown(text, None, None, None)
    assert out == '```text\nball,X\n```\n\n```yaml title="a.yaml"\nx: 1\n```\n'
