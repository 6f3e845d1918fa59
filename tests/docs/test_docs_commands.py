"""The documentation's commands run and its numbers are the program's.

Every page under ``docs/`` (and ``README.md``) runs by the convention of
:mod:`doccheck` (docs/contributing.md): files written, commands run, the output shown
after a command compared with what it prints, python blocks executed and every number
marked ``<!-- from: ... -->`` in the prose compared with the run, at the quoted precision.

Each page runs in a fresh temporary folder, holding a copy of the repository's
``examples/`` folder (input files a tutorial may name as ``examples/...``), its blocks in
order.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from doccheck import (
    MARKER,
    agree,
    bench_median,
    blocks,
    commands,
    compare_output,
    marker_value,
    quoted_before,
    run_page,
)

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
EXAMPLES = ROOT / "examples"


def pages_that_run() -> list[Path]:
    pages = [*sorted(DOCS.rglob("*.md")), ROOT / "README.md"]
    return [p for p in pages if _runs(p.read_text(encoding="utf-8"))]


def _runs(text: str) -> bool:
    """A page with commands, python blocks or marked numbers."""
    return MARKER.search(text) is not None or any(
        lang in ("console", "python") for lang, _, _ in blocks(text)
    )


def _run(page: Path, text: str, folder: Path, monkeypatch):
    shutil.copytree(EXAMPLES, folder / "examples")
    monkeypatch.chdir(folder)
    monkeypatch.setenv("COLUMNS", "100")
    return run_page(str(page.relative_to(ROOT)), text, folder)


@pytest.mark.parametrize("page", pages_that_run(), ids=lambda p: str(p.relative_to(ROOT)))
def test_page_runs_and_quotes_the_program(page: Path, tmp_path: Path, monkeypatch) -> None:
    run = _run(page, page.read_text(encoding="utf-8"), tmp_path, monkeypatch)
    assert run.commands + run.python_blocks + run.markers > 0
    assert run.problems == [], "\n".join(run.problems)


def test_a_changed_number_fails_the_page(tmp_path: Path, monkeypatch) -> None:
    """A default that moves a quoted number fails: the GUM H.1 page with its u_c changed
    from 32 to 33 nm in a shown table and its marked 3.8 nm changed to 8 nm (the page's
    former text) reports both, naming the numbers."""
    page = DOCS / "tutorials" / "uncertainty.md"
    text = page.read_text(encoding="utf-8")
    shown = "│ l      │ 50000839 │ 32 │ 93 │"
    quoted = "by 3.8<!-- from:"
    assert text.count(shown) == 1 and text.count(quoted) == 1
    text = text.replace(shown, shown.replace("32", "33")).replace(quoted, "by 8<!-- from:")
    run = _run(page, text, tmp_path, monkeypatch)
    assert len(run.problems) == 2, run.problems
    assert "50000839 │ 33 │ 93" in run.problems[0]
    assert "quoted 8 but the run gives 3.81" in run.problems[1]


def test_a_drifted_python_result_fails_the_page(tmp_path: Path, monkeypatch) -> None:
    """A number marked against the page's python namespace (``py EXPR``) is checked too:
    the CMM page with the kinematic model's held-out RMS length error quoted as 0.96 µm
    instead of the run's 0.86 µm reports exactly that marker, with the run's value."""
    page = DOCS / "tutorials" / "cmm.md"
    text = page.read_text(encoding="utf-8")
    quoted = 'uncompensated, 0.86<!-- from: py result.table[1]["rms_error_um"] -->'
    assert text.count(quoted) == 1
    text = text.replace(quoted, quoted.replace("0.86", "0.96"))
    run = _run(page, text, tmp_path, monkeypatch)
    assert len(run.problems) == 1, run.problems
    assert run.problems[0].startswith("docs/tutorials/cmm.md:"), run.problems
    assert "quoted 0.96 but the run gives 0.858" in run.problems[0], run.problems


def test_python_markers_read_the_page_namespace() -> None:
    """``py EXPR [UNIT]``: the expression in the page's namespace, converted from the
    internal unit when the last word is a display unit, left as is otherwise."""
    namespace = {"x": 0.00146, "b": 1.0, "rows": [{"coverage": 0.978}]}
    assert marker_value("py x µm", Path("."), "", namespace) == pytest.approx(1.46)
    assert marker_value("py x + b", Path("."), "", namespace) == pytest.approx(1.00146)
    assert marker_value('py rows[0]["coverage"] %', Path("."), "", namespace) == 97.8
    with pytest.raises(NameError):
        marker_value("py missing", Path("."), "", namespace)


def test_agreement_at_the_quoted_precision() -> None:
    """Half a unit in the last digit of each: a coarser print of the same value agrees, a
    moved value does not."""
    assert agree("1.08", "1.1") and agree("1.1", "1.08") and agree("17", 17.35)
    assert agree("8.86", 8.8649) and not agree("8.86", 8.8651)
    assert not agree("1.08", "1.2") and not agree("8", 3.81) and not agree("20.1", 21.9)
    assert agree("3.54e+03", 3544.0) and not agree("3.54e+03", 3560.0)
    assert not agree("33", "32") and agree("32", "32") and agree("0.5", 0.5)
    assert agree("−0.02", -0.0204) and not agree("-0.02", 0.02)


def test_shown_output_is_compared_line_by_line() -> None:
    printed = "head\nresidual: largest 9.47 µm, rms 6.1 µm\ntail 3\n"
    assert compare_output(["...", "residual: largest 9.5 µm, rms 6.06 µm"], printed) == []
    [out_of_order] = compare_output(["tail 3", "head"], printed)
    assert out_of_order.startswith("shown 'head' is not printed")
    [problem] = compare_output(["residual: largest 8.16 µm, rms 6.06 µm"], printed)
    assert "8.16" in problem and "9.47" in problem
    assert compare_output(["residual: largest 9.47 µm, ..."], printed) == []
    assert compare_output(["residual: smallest 9.47 µm, ..."], printed) != []


def test_the_convention_finds_files_commands_and_markers() -> None:
    """The parser itself: a titled file, a continued command, an expected failure, the
    shown lines, the number a marker refers to."""
    body = (
        "$ mtm fit sphere \\\n    pts.csv --json\n{...}\n$ mtm fit sphere missing.csv\nerror: x\n"
    )
    assert commands(body) == [
        (["mtm", "fit", "sphere", "pts.csv", "--json"], False, ["{...}"]),
        (["mtm", "fit", "sphere", "missing.csv"], True, ["error: x"]),
    ]
    text = '```csv title="pts.csv"\nx,y,z\n```\n\n```console\n$ mtm machine list\n```\n'
    assert list(blocks(text)) == [
        ("csv", "pts.csv", "x,y,z\n"),
        ("console", None, "$ mtm machine list\n"),
    ]
    assert quoted_before("line 1\nE_XX1 is u = 8.8") == "8.8"
    assert quoted_before("u = −0.25") == "−0.25"
    assert quoted_before("u = 8.8 µm") is None and quoted_before("T00") is None


def test_a_shown_file_and_a_stated_exit_code_are_checked(tmp_path: Path, monkeypatch) -> None:
    """A ``from="FILE"`` fence is compared with the file the page wrote (a moved number is
    reported); ``(exit code N)`` after a command makes any other exit code fail."""
    monkeypatch.chdir(tmp_path)
    page = '```csv title="a.csv"\nx,u\n1.25,0.5\n```\n\n```text from="a.csv"\nx,u\n1.3,0.5\n```\n'
    assert run_page("p.md", page, tmp_path).problems == []
    [moved] = run_page("p.md", page.replace("1.3,0.5", "1.4,0.5"), tmp_path).problems
    assert moved.startswith("p.md:6: a.csv: shown '1.4,0.5'"), moved
    assert run_page("p.md", "```console\n$ mtm formats\n```\n", tmp_path).problems == []
    with pytest.raises(AssertionError, match=r"\$ mtm formats"):
        run_page("p.md", "```console\n$ mtm formats\n(exit code 4)\n```\n", tmp_path)


def test_bench_times_come_from_the_results_table() -> None:
    """``bench SECTION "CONTENDER"``: the median column of the first row whose contender
    starts so, in that section only."""
    results = (
        "## a\n\n| contender | kind | min (s) | median (s) |\n|---|---|---:|---:|\n"
        "| ours: fast | ours | 1.0 | 1.25 |\n| loop | loop | 9.0 | 9.5 |\n\n"
        "## b\n\n| ours: fast | ours | 2.0 | 2.5 |\n"
    )
    assert bench_median(results, "a", "ours") == 1.25
    assert bench_median(results, "b", "ours: fast") == 2.5
    assert bench_median(results, "a", "loop") == 9.5
    with pytest.raises(LookupError):
        bench_median(results, "a", "missing")
