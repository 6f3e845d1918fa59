"""Run a documentation page and compare the numbers it quotes with the numbers of the run.

The convention (docs/contributing.md) for every page under ``docs/`` and ``README.md``:

- a fenced block with a ``title="NAME"`` attribute is a file the reader creates: it is
  written to ``NAME`` in the page's working folder;
- a fenced ``console`` block holds commands, one per line starting with ``$ mtm`` (a
  trailing backslash continues a line); every other command must exit with code 0, except
  that an output line starting with ``error:`` means the command must fail with exit
  code 2 and an ``error:`` line on stderr, and a shown line ``(exit code N)`` that it must
  end with code N (``mtm export check`` ends with 4 when the check does not confirm);
- the lines shown after a command are **compared** with what it prints: each shown line
  must be printed, in order (a line ``...`` skips any number of lines, a line ending in
  ``...`` is a prefix), with the same text and the same numbers at the precision quoted;
- a fenced block with a ``from="FILE"`` attribute shows lines of a file the page's
  commands wrote: they are compared with the file as shown output is;
- a fenced ``python`` block without a title runs, in one namespace per page, in the
  page's folder after the blocks before it; a block whose first line starts with
  ``# not run`` is a fragment and is skipped;
- a number in the prose followed directly by ``<!-- from: SOURCE -->`` is compared with the number
  of the run at the point of the marker, at the quoted precision. ``SOURCE`` is
  ``FILE TERM [± TERM ...] [UNIT]``: a JSON file of the working folder, dotted paths into
  it (``outputs.0.u``) or numbers added or subtracted, and the display unit to convert
  the internal value (mm, rad, a fraction) to (``µm``, ``µrad``, ``%``); or ``$ REGEX``:
  the first group of the regular expression in the output of the last command run;
  ``py EXPR [UNIT]``: a Python expression evaluated in the page's namespace (after the
  python blocks before the marker), converted from the internal unit when given; or
  ``bench SECTION "CONTENDER" [UNIT]``: the median time (s, or converted to ``min``, ``h``)
  of that contender in that section of ``bench/RESULTS.md`` (a time is quoted from the
  benchmarks, never from a page's run).

Two numbers agree at the quoted precision when they differ by at most half a unit in the
last quoted digit of each (``1.08`` and ``1.1`` agree; ``1.08`` and ``1.2`` do not), so a
change of formatting that keeps the value passes and a change of value fails.
"""

from __future__ import annotations

import json
import re
import shlex
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath

from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.units import convert, from_internal

RESULTS = Path(__file__).resolve().parents[2] / "bench" / "RESULTS.md"

FENCE = re.compile(r"^```([\w-]*)([^\n]*)\n(.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)
TITLE = re.compile(r'title="([^"]+)"')
SHOWS = re.compile(r'from="([^"]+)"')
EXIT_CODE = re.compile(r"^\(exit code (\d+)\)$")
MARKER = re.compile(r"<!-- from: (.+?) -->")
# A number as a person reads it: sign (ASCII or Unicode minus), digits, decimals, exponent;
# not part of a name (E_XX1, T00, u_c²) nor continued by letters or digits.
NUMBER = re.compile(r"(?<![\w.\-−+])[-−+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?(?!\w|\.\w)")
BOX_ONLY = re.compile(r"^[\s━─┏┓┗┛┳┻╇┡┩┠┨┯┷┼│┃╭╮╰╯═║╔╗╚╝╠╣╦╩╬┌┐└┘├┤┬┴]*$")


def blocks(text: str):
    """(language, title or None, body) of each fenced block of a page, in order."""
    for match in FENCE.finditer(text):
        title = TITLE.search(match.group(2))
        yield match.group(1), (title.group(1) if title else None), match.group(3)


def commands(body: str) -> list[tuple[list[str], bool, list[str]]]:
    """The ``$ mtm`` commands of a console block, whether each is expected to fail, and
    the output lines shown after it."""
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
        shown = lines[i:end]
        out.append((shlex.split(text), any(o.startswith("error:") for o in shown), shown))
    return out


def resolution(token: str) -> float:
    """One unit in the last digit of a printed number: ``1.08`` → 0.01, ``3.5e+03`` → 100."""
    mantissa, _, exponent = token.lower().partition("e")
    decimals = len(mantissa.partition(".")[2])
    return 10.0 ** (int(exponent or 0) - decimals)


def parse_number(token: str) -> float:
    return float(token.replace("−", "-"))


def agree(quoted: str, actual: str | float) -> bool:
    """Whether a quoted number and the run's number agree at the precision of both.

    ``actual`` is a printed token or a float of full precision. Each printed number stands
    for the interval of half a unit in its last digit about it: a full-precision number
    agrees when it lies in the quoted number's interval (|q − a| ≤ res(q)/2, rounding
    half either way), a printed one when the two intervals overlap
    (|q − a| < (res(q) + res(a))/2): ``1.08`` and ``1.1`` agree, ``32`` and ``33`` do not.
    """
    q = parse_number(quoted)
    slack = 1e-12 * max(abs(q), 1.0)
    if isinstance(actual, str):
        a = parse_number(actual)
        return abs(q - a) < 0.5 * (resolution(quoted) + resolution(actual)) - slack
    return abs(q - float(actual)) <= 0.5 * resolution(quoted) + slack


def skeleton(line: str) -> str:
    """A line with its numbers replaced by ``#`` and its runs of blanks by one space."""
    return " ".join(NUMBER.sub("#", line).split())


def _line_matches(shown: str, printed: str) -> bool:
    """Whether ``printed`` is the ``shown`` line: the same text (blanks collapsed; a
    ``...`` inside the shown line stands for any text) and the same numbers."""
    segments = [s.strip() for s in re.split(r"\.\.\.|…", " ".join(shown.split()))]
    pattern = ".*?".join(
        "".join(
            f"({NUMBER.pattern})" if k % 2 else re.escape(piece)
            for k, piece in enumerate(_split_numbers(segment))
        )
        for segment in segments
    )
    match = re.fullmatch(pattern, " ".join(printed.split()))
    if match is None:
        return False
    quoted = [n for segment in segments for n in NUMBER.findall(segment)]
    return all(agree(q, a) for q, a in zip(quoted, match.groups(), strict=True))


def _split_numbers(text: str) -> list[str]:
    """``text`` as [text, number, text, number, ..., text]."""
    pieces, at = [], 0
    for match in NUMBER.finditer(text):
        pieces += [text[at : match.start()], match.group()]
        at = match.end()
    return [*pieces, text[at:]]


def compare_output(shown: list[str], printed: str) -> list[str]:
    """The shown lines not printed, in order, with their text and numbers; empty if all are.

    A shown ``...`` line skips printed lines (it is also implied before the first shown
    line and between any two: a shown line may be found further down); lines of table
    borders only are not compared.
    """
    printed_lines = [p for p in printed.splitlines() if p.strip()]
    problems, at = [], 0
    for line in shown:
        if not line.strip() or line.strip() in ("...", "…") or BOX_ONLY.match(line):
            continue
        found = next(
            (k for k in range(at, len(printed_lines)) if _line_matches(line, printed_lines[k])),
            None,
        )
        if found is None:
            near = [p for p in printed_lines if skeleton(p)[:12] == skeleton(line)[:12]]
            problems.append(
                f"shown {line.strip()!r} is not printed in this order"
                + (f" (printed {near[0].strip()!r})" if near else "")
            )
        else:
            at = found + 1
    return problems


def _walk(document, path: str):
    value = document
    for key in path.split("."):
        value = value[int(key)] if isinstance(value, list) else value[key]
    return value


def marker_value(
    source: str, folder: Path, last_output: str, namespace: dict | None = None
) -> float | str:
    """The run's number named by a marker's ``SOURCE`` (see the module docstring)."""
    if source.startswith("py "):
        if namespace is None:
            raise LookupError(f"{source!r}: no python namespace")
        expression, _, unit = source[3:].rpartition(" ")
        if not _is_unit(unit):  # the last word is part of the expression
            expression, unit = source[3:], ""
        value = float(eval(expression, namespace))  # the page's own code, as exec'd above
        return float(from_internal(value, unit)) if unit else value
    if source.startswith("bench "):
        section, contender, *unit = shlex.split(source)[1:]
        seconds = bench_median(RESULTS.read_text(encoding="utf-8"), section, contender)
        return float(convert(seconds, "s", unit[0])) if unit else seconds
    if source.startswith("$ "):
        match = re.search(source[2:], last_output)
        if match is None:
            raise LookupError(f"/{source[2:]}/ not found in the last command's output")
        return match.group(1)
    file, *terms = source.split()
    document = json.loads((folder / file).read_text(encoding="utf-8"))

    def term(token: str) -> float:
        return float(token) if NUMBER.fullmatch(token) else float(_walk(document, token))

    value = term(terms[0])
    terms = terms[1:]
    while terms[:1] in (["-"], ["+"]):
        value += term(terms[1]) * (1 if terms[0] == "+" else -1)
        terms = terms[2:]
    return float(from_internal(value, terms[0])) if terms else value


def _is_unit(word: str) -> bool:
    """Whether ``word`` is a display unit :func:`from_internal` converts to."""
    try:
        from_internal(1.0, word)
    except (ValueError, KeyError, TypeError):
        return False
    return True


def bench_median(results: str, section: str, contender: str) -> float:
    """The median time (s) of ``contender`` (the start of its name) in the table of
    ``## section`` of bench/RESULTS.md (columns contender, kind, min, median, ...)."""
    match = re.search(rf"^## {re.escape(section)}\n(.*?)(?=^## |\Z)", results, re.M | re.S)
    if match is None:
        raise LookupError(f"no section {section!r} in bench/RESULTS.md")
    for line in match.group(1).splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) >= 4 and cells[0].startswith(contender):
            return float(cells[3])
    raise LookupError(f"no contender {contender!r} in section {section!r} of bench/RESULTS.md")


def quoted_before(prose: str) -> str | None:
    """The number a marker refers to: the one that ends right where the marker starts."""
    match = re.search(f"(?:{NUMBER.pattern})$", prose)
    return match.group() if match else None


@dataclass
class PageRun:
    """What running a page found: its problems and how many checks it made."""

    problems: list[str] = field(default_factory=list)
    commands: int = 0
    compared_lines: int = 0
    markers: int = 0
    python_blocks: int = 0


def run_page(name: str, text: str, folder: Path) -> PageRun:
    """Run the page ``text`` in ``folder`` (the current directory must be ``folder``) and
    check its commands, shown outputs, python blocks and markers, in page order."""
    runner, run, namespace, last_output = CliRunner(), PageRun(), {}, ""
    fences = [(m.start(), m.end(), m) for m in FENCE.finditer(text)]
    events = [(s, "block", m) for s, _, m in fences]
    events += [
        (m.start(), "marker", m)
        for m in MARKER.finditer(text)
        if not any(s <= m.start() < e for s, e, _ in fences)
    ]
    for position, kind, match in sorted(events, key=lambda e: e[0]):
        if kind == "marker":
            run.markers += 1
            quoted = quoted_before(text[:position])
            where = f"{name}:{text.count(chr(10), 0, position) + 1}"
            try:
                actual = marker_value(match.group(1), folder, last_output, namespace)
            except (LookupError, OSError, ValueError, IndexError, KeyError, NameError) as exc:
                run.problems.append(f"{where}: marker {match.group(1)!r}: {exc!r}")
                continue
            if quoted is None:
                run.problems.append(f"{where}: marker {match.group(1)!r} not right after a number")
            elif not agree(quoted, actual):
                run.problems.append(
                    f"{where}: quoted {quoted} but the run gives {actual} ({match.group(1)})"
                )
            continue
        language, title, body = match.group(1), TITLE.search(match.group(2)), match.group(3)
        shows = SHOWS.search(match.group(2))
        if shows is not None:
            where = f"{name}:{text.count(chr(10), 0, position) + 1}: {shows.group(1)}"
            try:
                written = (folder / shows.group(1)).read_text(encoding="utf-8")
            except OSError as exc:
                run.problems.append(f"{where}: {exc!r}")
                continue
            shown = body.splitlines()
            run.compared_lines += sum(1 for s in shown if s.strip() not in ("", "...", "…"))
            run.problems += [f"{where}: {p}" for p in compare_output(shown, written)]
        elif title is not None:
            target = PurePosixPath(title.group(1))
            assert not target.is_absolute() and ".." not in target.parts, f"{name}: {target}"
            (folder / target).parent.mkdir(parents=True, exist_ok=True)
            (folder / target).write_text(body, encoding="utf-8")
        elif language == "python" and not body.startswith("# not run"):
            run.python_blocks += 1
            line = text.count("\n", 0, position) + 2
            exec(compile("\n" * (line - 1) + body, name, "exec"), namespace)
        elif language == "console":
            for argv, must_fail, shown in commands(body):
                assert argv[0] == "mtm", f"{name}: only mtm commands run: {argv}"
                result = runner.invoke(app, argv[1:])
                last_output = result.output
                context = f"{name}: $ {shlex.join(argv)}\n{result.output}"
                stated = [int(m.group(1)) for s in shown if (m := EXIT_CODE.match(s.strip()))]
                shown = [s for s in shown if not EXIT_CODE.match(s.strip())]
                if must_fail:
                    assert result.exit_code == 2, context
                    assert result.stderr.startswith("error: "), context
                else:
                    assert result.exit_code == (stated or [0])[0], context
                run.commands += 1
                compared = [s for s in shown if s.strip() and s.strip() not in ("...", "…")]
                run.compared_lines += len(compared)
                run.problems += [
                    f"{name}: $ {shlex.join(argv)}: {p}"
                    for p in compare_output(shown, result.output)
                ]
    return run


__all__ = [
    "PageRun",
    "agree",
    "blocks",
    "commands",
    "compare_output",
    "marker_value",
    "quoted_before",
    "resolution",
    "run_page",
    "skeleton",
]
