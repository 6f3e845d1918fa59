"""Numbers as a metrologist reads them: values with their uncertainty, plain cells.

One rule for the reports, the console and every application (a leaf beside
:mod:`mtmetrology.units`: it imports nothing else of the package); JSON keeps full precision.

A value is printed to the decimal of its standard uncertainty's second significant
digit (JCGM 100:2008, 7.2.6), the uncertainty with two significant digits; a number
without an uncertainty keeps enough significant digits to be read back (``%.10g``
trimmed), so a table never shows ``5.00008e+07`` for an end-gauge length.  A number that
rounds to zero is printed ``0`` (never ``-0`` or ``-0.00``).

An uncertainty is never printed after a bare ``±``: :func:`format_result` names it,
``l = 532.0143 mm, u = 2.1 µm`` or ``…, U = 4.1 µm (k = 2)``, the value in its unit and
the uncertainty in its display unit (:func:`mtmetrology.units.display_unit`), k beside
every U (:mod:`mtmetrology.uncertainty.coverage`).  Machine-readable files (JSON, CSV
for programs) keep their precision.
"""

from __future__ import annotations

import math
import numbers
import re
from collections.abc import Sequence

from mtmetrology.units import convert, display_unit, display_unit_of

__all__ = [
    "SHARE_DEFINITION",
    "budget_cells",
    "budget_columns",
    "decimals_for",
    "format_cell",
    "format_coverage",
    "format_fitted",
    "format_k",
    "format_parameters",
    "format_result",
    "format_share",
    "format_signed",
    "format_uncertainty",
    "format_value",
    "overstated_digits",
]

#: What the "share" column and the budget figure show (JCGM 100:2008, 5.2.2).
SHARE_DEFINITION = (
    "share = c_i Σ_j c_j u(x_i, x_j) / u_c²(y), the input's part of u_c² with its "
    "covariances split evenly: the shares sum to 100 %, and are negative where "
    "correlations cancel part of u_c²"
)


def _last_place(u: float) -> int:
    """Decimals of the second significant digit of u, after rounding (negative above 10)."""
    d = 1 - math.floor(math.log10(u))
    if round(u, d) >= 10.0 ** (2 - d):  # 9.96 rounds to 10: two digits are one decade up
        d -= 1
    return d


def decimals_for(u: float) -> int:
    """Decimals that show ``u`` with two significant digits (JCGM 100:2008, 7.2.6).

    Examples
    --------
    >>> decimals_for(31.7), decimals_for(0.0012), decimals_for(250.0), decimals_for(0.996)
    (0, 4, 0, 1)
    """
    if not (math.isfinite(u) and u > 0):
        return 6
    return max(0, _last_place(u))


def format_uncertainty(u: float | None) -> str:
    """A standard or expanded uncertainty with two significant digits.

    Examples
    --------
    >>> format_uncertainty(31.72), format_uncertainty(0.001234), format_uncertainty(None)
    ('32', '0.0012', '—')
    >>> format_uncertainty(1.2e-6), format_uncertainty(0.0), format_uncertainty(9579.0)
    ('1.2e-06', '0', '9600')
    """
    if u is None:
        return "—"
    if not math.isfinite(u):
        return str(u)
    if u == 0:
        return "0"
    if not 1e-4 <= abs(u) < 1e7:  # fixed-point would print many zeros
        return f"{u:.1e}"  # 9.96e-05 -> 1.0e-04 (".2g" drops the second digit)
    return f"{round(u, _last_place(u)):.{decimals_for(u)}f}"  # 9579 -> 9600


def format_value(value: float, u: float | None = None) -> str:
    """A value rounded to the second significant digit of its uncertainty.

    Examples
    --------
    >>> format_value(50000838.62, 31.7), format_value(123456.0, 9579.0)
    ('50000839', '123500')
    >>> format_value(-104.5912, 0.0734)
    '-104.591'
    >>> format_value(305.2105)
    '305.2105'
    >>> format_value(1.15e-05, 1.2e-06), format_value(0.0, 5.8e-07), format_value(3e-9, 1.2e-6)
    ('1.15e-05', '0', '0')
    >>> format_value(-0.004, 0.31), format_value(-0.03, 25.0)
    ('0.00', '0')
    """
    if u is None or not (math.isfinite(u) and u > 0):
        return format_cell(value)
    if 1e-4 <= u < 1e7 or not math.isfinite(value) or 1e-3 <= abs(value) < 1e7:
        if math.isfinite(value) and _last_place(u) < 0:  # u >= 100: tens or more
            value = round(value, _last_place(u))
        return _no_negative_zero(f"{value:.{decimals_for(u)}f}")
    # a small value of a small u: scientific as format_uncertainty, to the place of u
    digits = math.floor(math.log10(abs(value))) + _last_place(u) if value else -1
    return f"{value:.{digits}e}" if digits >= 0 else "0"


def format_cell(value: object) -> str:
    """One table cell: strings as given, None as a dash, numbers readably.

    Examples
    --------
    >>> [format_cell(v) for v in ("E_X0C", None, True, 7, 0.1 + 0.2, 1.5e-9, float("inf"))]
    ['E_X0C', '—', 'yes', '7', '0.3', '1.5e-09', 'inf']
    """
    if value is None:
        return "—"
    if isinstance(value, str):
        return value
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        v = float(value)
        if not math.isfinite(v):
            return str(v)
        return _no_negative_zero(f"{v:.10g}")
    return str(value)


def _no_negative_zero(text: str) -> str:
    """``-0.00`` -> ``0.00``: a number that rounds to zero has no sign."""
    if text.startswith("-") and not any(c in "123456789" for c in text.split("e")[0]):
        return text[1:]
    return text


def format_fitted(value: float, unit: str, rms_um: float) -> str:
    """A fitted parameter or form error, which states no uncertainty, rounded to the second
    significant digit of the rms of the fit's residuals (in the value's unit).

    The residual rms bounds the standard uncertainty of a least-squares element's size and
    position from above (their u is about rms·sqrt(p/n)), so the digits shown are no more
    than JCGM 100:2008, 7.2.6 would allow.  A value whose unit is not a length (a direction
    cosine, an angle) keeps six decimals.

    Examples
    --------
    >>> format_fitted(10.00059524, "mm", 2.325), format_fitted(8.186795993, "µm", 2.325)
    ('10.0006', '8.2')
    >>> format_fitted(-0.7071067811, "", 2.325)
    '-0.707107'
    """
    try:
        scale = float(convert(rms_um, "µm", unit)) if rms_um > 0 else None
    except ValueError:  # not a length: no residual scale
        return format_signed(value, 6)
    return format_value(value, scale)


def format_parameters(
    names: Sequence[str], values, u, units: Sequence[str], *, limit: int = 12
) -> list[str]:
    """``E_X0C = -104.59 µm, u = 0.73 µm`` for each parameter (customary units), the first
    ``limit`` and a line that counts the rest: what a ``repr`` shows.

    Examples
    --------
    >>> format_parameters(["E_X0C", "E_BBb"], [-104.5912, -0.01], [0.734, 3.1], ["µm", "µrad"])
    ['E_X0C = -104.59 µm, u = 0.73 µm', 'E_BBb = 0.0 µrad, u = 3.1 µrad']
    """
    lines = [
        format_result(float(values[i]), None if u is None else float(u[i]), units[i], name=n)
        for i, n in enumerate(names[:limit])
    ]
    if len(names) > limit:
        lines.append(f"… {len(names) - limit} more")
    return lines


def format_signed(value: float, digits: int = 2) -> str:
    """A number without an uncertainty (a correlation, a ratio) to ``digits`` decimals,
    ``0.00`` for ``-0.001``.

    Examples
    --------
    >>> format_signed(-0.001), format_signed(-0.456), format_signed(1.0, 1)
    ('0.00', '-0.46', '1.0')
    """
    return _no_negative_zero(f"{value:.{digits}f}")


def format_k(k: float) -> str:
    """A coverage factor: ``2``, ``1.96``, ``2.92`` (three significant digits, no ``2.00``).

    Examples
    --------
    >>> format_k(2.0), format_k(1.959963984540054), format_k(2.9207816)
    ('2', '1.96', '2.92')
    """
    return f"{k:.3g}"


def format_coverage(k: float, p: float | None = None) -> str:
    """``k = 2`` or ``k = 2, p ≈ 95.45 %``: what stands beside an expanded uncertainty.

    Examples
    --------
    >>> format_coverage(2.0), format_coverage(1.959964, 0.95)
    ('k = 2', 'k = 1.96, p ≈ 95 %')
    """
    text = f"k = {format_k(k)}"
    return text if p is None else f"{text}, p ≈ {100.0 * p:.4g} %"


def format_result(
    value: float,
    u: float | None,
    unit: str,
    *,
    name: str | None = None,
    u_unit: str | None = None,
    k: float | None = None,
    p: float | None = None,
) -> str:
    """A value with its uncertainty named: ``l = 532.0143 mm, u = 2.1 µm`` or, with k,
    ``l = 532.0143 mm, U = 4.1 µm (k = 2)``.

    The uncertainty has two significant digits and the value is rounded to the same
    decimal place (JCGM 100:2008, 7.2.6); a bare ``±`` is never written, so the reader
    knows a standard uncertainty u from an expanded one U = k u (JCGM 100:2008, 7.2.2
    and 7.2.4).

    Parameters
    ----------
    value : float
        In ``unit``.
    u : float or None
        The standard uncertainty, in ``u_unit``.
    unit : str
        The value's unit (``""`` for a number).
    name : str, optional
        Printed as ``name = value``.
    u_unit : str, optional
        The uncertainty's unit (default ``unit``); it must convert to ``unit``.
    k : float, optional
        When given, U = k u is stated with k beside it (and u before it).
    p : float, optional
        The coverage probability printed beside k.

    Returns
    -------
    str

    Examples
    --------
    JCGM 100:2008, 7.2.2: m_s = 100.021 47 g with u_c = 0.35 mg

    >>> format_result(100.02147, 0.00035, "g", name="m_s")
    'm_s = 100.02147 g, u = 0.00035 g'
    >>> format_result(532.014299, 2.06, "mm", name="l_x", u_unit="µm", k=2)
    'l_x = 532.0143 mm, u = 2.1 µm, U = 4.1 µm (k = 2)'
    >>> format_result(-0.02, 3.1, "µrad", name="E_BBb")
    'E_BBb = 0.0 µrad, u = 3.1 µrad'
    """
    u_unit = unit if u_unit is None else u_unit
    u_value = None if u is None else (float(convert(u, u_unit, unit)) if u_unit != unit else u)
    text = f"{format_value(value, u_value)}{' ' + unit if unit else ''}"
    if name:
        text = f"{name} = {text}"
    if u is None:
        return f"{text} (no uncertainty)"
    suffix = f" {u_unit}" if u_unit else ""
    text += f", u = {format_uncertainty(u)}{suffix}"
    if k is not None:
        text += f", U = {format_uncertainty(k * u)}{suffix} ({format_coverage(k, p)})"
    return text


def format_share(share: float) -> str:
    """A share of u_c² as a percentage with one decimal (``-0.0 %`` printed ``0.0 %``)."""
    return f"{round(100.0 * share, 1) + 0.0:.1f} %"


def budget_columns(output: str) -> list[str]:
    """Headers of the rows of :func:`budget_cells` for the output named ``output``."""
    return ["input", "estimate", "u(x_i)", "unit", "c_i", f"u_i({output})", "ν_i", "share"]


def budget_cells(rows: Sequence, output_unit: str) -> tuple[list[list[str]], list[int]]:
    """The lines of an uncertainty budget in display units, zero rows folded into one.

    Parameters
    ----------
    rows : sequence of :class:`~mtmetrology.uncertainty.guf.BudgetRow`
        Values in each row's ``unit`` (internal units for the engines' inputs).
    output_unit : str
        The unit of the output (contributions are shown in its display unit).

    Returns
    -------
    lines : list of list of str
        One line per input with u(x_i) > 0 (estimate and u in the input's display unit,
        :func:`mtmetrology.units.display_unit_of`: errors in µm and µrad, positions and
        axis readings in mm and degrees; c_i in display output unit per display
        input unit; u_i(y) in the output's display unit; the share as
        :data:`SHARE_DEFINITION`), then one line naming the inputs with u = 0.
    shown : list of int
        Indices into ``rows`` of the lines shown one by one (the figure draws these).
    """
    out_du = display_unit(output_unit) if output_unit else output_unit
    lines, shown, zero = [], [], []
    # a c_i of rounding size (-2.8e-17: the output does not depend on the input) is 0
    tiny = 1e-9 * max((abs(b.contribution) for b in rows), default=0.0)
    for i, b in enumerate(rows):
        if b.u == 0:
            zero.append(b.input)
            continue
        du = display_unit_of(b.unit, b.estimate) if b.unit else b.unit
        u = float(convert(b.u, b.unit, du)) if du != b.unit else b.u
        est = float(convert(b.estimate, b.unit, du)) if du != b.unit else b.estimate
        contribution = b.contribution if abs(b.contribution) > tiny else 0.0
        c = b.sensitivity if contribution else 0.0
        if out_du != output_unit:
            contribution = float(convert(contribution, output_unit, out_du))
            c = float(convert(c, output_unit, out_du))
        if du != b.unit:
            c = c / float(convert(1.0, b.unit, du))
        # nm per /°C is nm·°C; µm per µm/m is µm/(µm/m)
        per = f"·{du[1:]}" if du.startswith("/") else (f"/({du})" if "/" in du else f"/{du}")
        per = per if du else ""
        c_unit = f" {out_du}{per}" if (out_du or du) and du != out_du else ""
        lines.append(
            [
                b.input,
                format_value(est, u),
                format_uncertainty(u),
                du,
                f"{_no_negative_zero(f'{c:.4g}')}{c_unit}",
                format_uncertainty(contribution),
                "inf" if not math.isfinite(b.dof) else f"{b.dof:.1f}",
                format_share(b.share),
            ]
        )
        shown.append(i)
    if zero:
        label = f"{len(zero)} inputs with u = 0" if len(zero) > 1 else "1 input with u = 0"
        lines.append([f"{label}: {', '.join(zero)}", "—", "0", "", "", "0", "", "0.0 %"])
    return lines, shown


_NUMBER = r"\d+(?:\.\d+)?(?:e[-+]?\d+)?"
_UNIT = r"[^\s,;()]+"
#: ``NAME = VALUE UNIT, u = U UNIT`` as :func:`format_result` writes it.
_WITH_U = re.compile(rf"(?P<v>-?{_NUMBER}) (?P<vu>{_UNIT}), u = (?P<u>{_NUMBER}) (?P<uu>{_UNIT})")
_SMALL_U = re.compile(rf"(?<![\w(])u = (?P<u>{_NUMBER})")
_BIG_U = re.compile(rf"(?<![\w(])U = (?P<u>{_NUMBER})")
_NEGATIVE_ZERO = re.compile(r"(?<![\w.:/-])-0(?:\.0+)?(?![\w.])")
_BARE_PLUS_MINUS = re.compile(r"±\s*\d[\d.]*\s*(?:[µμ]m|mm|nm|[µμ]rad|%)")


def _significant(text: str) -> int:
    """Significant digits of a printed uncertainty (``0.0012`` 2, ``9600`` 2, ``1.2e-06`` 2)."""
    mantissa = text.split("e")[0]
    digits = mantissa.replace(".", "").lstrip("0")
    return len(digits if "." in mantissa else digits.rstrip("0"))


def overstated_digits(text: str) -> list[str]:
    """Lines of ``text`` (console output, a report's text) that break the digits policy.

    The policy (JCGM 100:2008, 7.2.6; this module): u and U with at most two significant
    digits, a value stated with u to no more decimals than u's second significant digit,
    U = … only with ``k = …`` on the same line, no ``-0`` / ``-0.00``, and no ``±`` before
    a quantity (write ``u = `` or ``U = … (k = …)``).

    Returns
    -------
    list of str
        ``what: the line`` for each breach; empty when the text follows the policy.

    Examples
    --------
    >>> overstated_digits("l_x = 532.0143 mm, u = 2.1 µm, U = 4.1 µm (k = 2)")
    []
    >>> [p.split(":")[0] for p in overstated_digits("l_x = 532.014299 mm, u = 2.06 µm")]
    ['value with more decimals than its u allows', 'u with more than two significant digits']
    >>> [p.split(":")[0] for p in overstated_digits("E_BBb -0 µrad; 1.9 ± 0.3 µm; U = 4.1 µm")]
    ['-0 printed', '± without naming u or U', 'U without k on its line']
    """
    problems = []
    for line in text.splitlines():
        found = []
        for m in _WITH_U.finditer(line):
            u = float(m["u"])
            try:
                u = u if m["uu"] == m["vu"] else float(convert(u, m["uu"], m["vu"]))
            except ValueError:  # not a unit pair that converts: nothing to compare
                continue
            value = m["v"].split("e")[0]
            shown = len(value.split(".")[1]) if "." in value else 0
            if u > 0 and "e" not in m["v"] and shown > decimals_for(u):
                found.append("value with more decimals than its u allows")
        if any(_significant(m["u"]) > 2 for m in _SMALL_U.finditer(line)):
            found.append("u with more than two significant digits")
        if any(_significant(m["u"]) > 2 for m in _BIG_U.finditer(line)):
            found.append("U with more than two significant digits")
        if _NEGATIVE_ZERO.search(line):
            found.append("-0 printed")
        if _BARE_PLUS_MINUS.search(line):
            found.append("± without naming u or U")
        if _BIG_U.search(line) and "k = " not in line[_BIG_U.search(line).start() :]:
            found.append("U without k on its line")
        problems += [f"{what}: {line.strip()}" for what in found]
    return problems
