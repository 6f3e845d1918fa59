"""Strict readers of YAML and JSON documents (machine files, parameter sets, artefacts ...).

The standard loaders keep the last of two equal keys, so a second ``tool_mm`` silently
replaces the first; they also follow arbitrarily deep nesting into a RecursionError.
These loaders refuse both, with an error naming the file and the line:

- duplicate keys in a mapping (YAML and JSON);
- nesting deeper than :data:`MAX_DEPTH` (no user file of mtmetrology needs more than ~6);
- files larger than :data:`MAX_BYTES` for documents (records go through the CSV reader);
- YAML anchors and aliases (a "billion laughs" document expands exponentially; no user
  file needs them), and YAML tags beyond the safe core schema.

JSON is read with the standard parser: NaN and Infinity literals are refused
(a non-finite value is never a valid quantity in these files).

Examples
--------
>>> parse_document("a: 1\\nb: [1, 2]\\n", "inline.yaml")
{'a': 1, 'b': [1, 2]}
>>> try:
...     parse_document("a: 1\\na: 2\\n", "inline.yaml")
... except InputFileError as err:
...     print(err)
inline.yaml, line 2: key 'a' appears twice in the same mapping (first at line 1)
"""

from __future__ import annotations

import json
from pathlib import Path

import yaml

from mtmetrology.io.files import InputFileError

__all__ = ["MAX_BYTES", "MAX_DEPTH", "load_document", "parse_document"]

MAX_DEPTH = 32
MAX_BYTES = 64 * 1024 * 1024


class _StrictLoader(yaml.SafeLoader):
    """SafeLoader that refuses duplicate keys, aliases and deep nesting."""

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):
            event = self.peek_event()
            raise InputFileError(
                f"{self.name}, line {event.start_mark.line + 1}: YAML aliases ('*name') are "
                "not accepted; write the value out"
            )
        depth = getattr(self, "_depth", 0) + 1
        if depth > MAX_DEPTH:
            mark = self.peek_event().start_mark
            raise InputFileError(
                f"{self.name}, line {mark.line + 1}: nesting deeper than {MAX_DEPTH} levels"
            )
        self._depth = depth
        try:
            return super().compose_node(parent, index)
        finally:
            self._depth = depth - 1

    def construct_mapping(self, node, deep=False):
        seen: dict = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            try:
                first = seen.get(key)
            except TypeError:
                raise InputFileError(
                    f"{self.name}, line {key_node.start_mark.line + 1}: a mapping key must be "
                    "a scalar"
                ) from None
            if first is not None:
                raise InputFileError(
                    f"{self.name}, line {key_node.start_mark.line + 1}: key {key!r} appears "
                    f"twice in the same mapping (first at line {first})"
                )
            seen[key] = key_node.start_mark.line + 1
        return super().construct_mapping(node, deep=deep)


def _no_duplicates(source: str):
    def hook(pairs):
        out = {}
        for key, value in pairs:
            if key in out:
                raise InputFileError(f"{source}: key {key!r} appears twice in the same object")
            out[key] = value
        return out

    return hook


def _refuse_constant(source: str):
    def hook(name):
        raise InputFileError(f"{source}: {name} is not a number; non-finite values are refused")

    return hook


def _json_depth(text: str) -> int:
    depth = deepest = 0
    in_string = escaped = False
    for ch in text:
        if in_string:
            if escaped:
                escaped = False
            elif ch == "\\":
                escaped = True
            elif ch == '"':
                in_string = False
        elif ch == '"':
            in_string = True
        elif ch in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif ch in "]}":
            depth -= 1
    return deepest


def parse_document(text: str, source: str = "<document>", *, json_format: bool | None = None):
    """Parse YAML or JSON text strictly.

    Parameters
    ----------
    text : str
        The document.
    source : str
        Name used in error messages (usually the file path); a name ending in ``.json``
        selects JSON unless ``json_format`` says otherwise.
    json_format : bool, optional
        Force JSON (True) or YAML (False).

    Returns
    -------
    object
        The parsed document (mappings, lists, scalars).

    Raises
    ------
    InputFileError
        Syntax errors, duplicate keys, aliases, excessive nesting or non-finite JSON numbers,
        naming the source and, where known, the line.
    """
    use_json = source.lower().endswith(".json") if json_format is None else json_format
    if use_json:
        if _json_depth(text) > MAX_DEPTH:
            raise InputFileError(f"{source}: nesting deeper than {MAX_DEPTH} levels")
        try:
            return json.loads(
                text,
                object_pairs_hook=_no_duplicates(source),
                parse_constant=_refuse_constant(source),
            )
        except json.JSONDecodeError as err:
            raise InputFileError(
                f"{source}, line {err.lineno}: not valid JSON: {err.msg}"
            ) from None
    loader = _StrictLoader(text)
    loader.name = source
    try:
        return loader.get_single_data()
    except yaml.MarkedYAMLError as err:
        mark = err.problem_mark or err.context_mark
        where = f", line {mark.line + 1}" if mark is not None else ""
        raise InputFileError(f"{source}{where}: not valid YAML: {err.problem}") from None
    except yaml.YAMLError as err:
        raise InputFileError(f"{source}: not valid YAML: {err}") from None
    finally:
        loader.dispose()


def load_document(path: str | Path, what: str = "document"):
    """Read a YAML or JSON file strictly (JSON when the name ends in ``.json``).

    Parameters
    ----------
    path : path-like
    what : str
        What the file should be, for messages (``"machine definition"``).

    Raises
    ------
    InputFileError
        Missing or unreadable file, a directory, a file too large, or any
        :func:`parse_document` error.
    """
    p = Path(path)
    if p.is_dir():
        raise InputFileError(f"{p}: is a directory, not a {what} file")
    if not p.is_file():
        raise InputFileError(f"{p}: file not found (expected a {what})")
    size = p.stat().st_size
    if size > MAX_BYTES:
        raise InputFileError(f"{p}: {size} bytes is too large for a {what} ({MAX_BYTES} at most)")
    try:
        text = p.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as err:
        raise InputFileError(f"{p}: not UTF-8 text (byte {err.start})") from None
    return parse_document(text, str(p))
