"""The file formats shipped with the package (``mtm formats``) are the documentation's."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from mtmetrology.cli import build_app
from mtmetrology.errors import InputError
from mtmetrology.io.formats import describe_format, file_formats, formats_text

DOC = Path(__file__).resolve().parents[2] / "docs" / "file-formats.md"
runner = CliRunner()


def test_the_documentation_page_is_the_shipped_text():
    """docs/file-formats.md is a copy of src/mtmetrology/io/formats.md (edit the latter and
    copy it over): what an installed package prints is what the documentation shows."""
    assert DOC.read_text(encoding="utf-8") == formats_text()


def test_every_section_is_a_named_format():
    """Each ``## `` heading carries its name; the names are distinct."""
    text = formats_text()
    headings = re.findall(r"^## (.+)$", text, re.MULTILINE)
    known = file_formats()
    assert [f.title for f in known] == headings
    assert len({f.name for f in known}) == len(known)
    assert all("<!-- format:" not in f.text for f in known)


def test_the_listing_names_each_format_with_its_title():
    result = runner.invoke(build_app(), ["formats"])
    assert result.exit_code == 0
    rows = [line.split(None, 1) for line in result.output.splitlines()]
    assert rows == [[f.name, f.title] for f in file_formats()]


def test_a_format_prints_its_section():
    result = runner.invoke(build_app(), ["formats", "parameter-set"])
    assert result.exit_code == 0
    assert result.output == describe_format("parameter-set").text
    assert result.output.startswith("## Parameter set (JSON or YAML)\n")
    assert '"kind": "parameter-set"' in result.output
    assert "## SAMBA artefact" not in result.output  # the next section is not part of it


def test_an_unknown_name_is_refused_with_the_names():
    with pytest.raises(InputError, match="machine, parameter-set"):
        describe_format("nope")
    result = runner.invoke(build_app(), ["formats", "nope"])
    assert result.exit_code == 2


def test_json_for_programs_keeps_full_precision():
    """The ``precision`` section's claim on a real document: ``mtm uncertainty run --json``
    states u of GUM H.1 with more than the two significant digits the console prints
    (JCGM 100 7.2.6 is for people), and ``mtm formats precision`` says so."""
    root = Path(__file__).resolve().parents[2]
    model = root / "examples" / "gum-h1-end-gauge.yaml"
    result = runner.invoke(build_app(), ["uncertainty", "run", str(model), "--json"])
    assert result.exit_code == 0
    [out] = json.loads(result.output)["outputs"]
    digits = repr(out["u"]).replace(".", "").lstrip("0")
    assert len(digits) > 2 and out["u"] != float(f"{out['u']:.2g}")
    section = runner.invoke(build_app(), ["formats", "precision"])
    assert section.exit_code == 0
    assert section.output == describe_format("precision").text
    assert section.output.startswith("## Precision of machine-readable outputs\n")
