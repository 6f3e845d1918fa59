"""Numbers as a metrologist reads them: values with their uncertainty, plain cells.

One rule for the reports, the console and every application (a leaf beside
:mod:`mtmetrology.units`: it imports nothing else of the package); JSON keeps full precision.

A value is printed to the decimal of its standard uncertainty's second significant
digit (JCGM 100:2008, 7.2.6), the uncertainty with two significant digits; a number
without an uncertainty keeps enough significant digits to be read back (``%.10g``
trimmed), so a table never shows ``5.00008e+07`` for an end-gauge length.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence

from mtmetrology.units import convert, display_unit, display_unit_of

__all__ = [
    "SHARE_DEFINITION",
    "budget_cells",
    "budget_columns",
    "decimals_for",
    "format_cell",
    "format_share",
    "format_uncertainty",
    "format_value",
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
    >>> format_uncertainty(1.2e-6), format_uncertainty(0.0)
    ('1.2e-06', '0')
    """
    if u is None:
        return "—"
    if not math.isfinite(u):
        return str(u)
    if u == 0:
        return "0"
    if not 1e-4 <= abs(u) < 1e7:  # fixed-point would print many zeros
        return f"{u:.1e}"  # 9.96e-05 -> 1.0e-04 (".2g" drops the second digit)
    return f"{u:.{decimals_for(u)}f}"


def format_value(value: float, u: float | None = None) -> str:
    """A value rounded to the second significant digit of its uncertainty.

    Examples
    --------
    >>> format_value(50000838.62, 31.7)
    '50000839'
    >>> format_value(-104.5912, 0.0734)
    '-104.591'
    >>> format_value(305.2105)
    '305.2105'
    >>> format_value(1.15e-05, 1.2e-06), format_value(0.0, 5.8e-07), format_value(3e-9, 1.2e-6)
    ('1.15e-05', '0', '0')
    """
    if u is None or not (math.isfinite(u) and u > 0):
        return format_cell(value)
    if 1e-4 <= u < 1e7 or not math.isfinite(value) or 1e-3 <= abs(value) < 1e7:
        return f"{value:.{decimals_for(u)}f}"
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
        return f"{v:.10g}"
    return str(value)


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
    for i, b in enumerate(rows):
        if b.u == 0:
            zero.append(b.input)
            continue
        du = display_unit_of(b.unit, b.estimate) if b.unit else b.unit
        u = float(convert(b.u, b.unit, du)) if du != b.unit else b.u
        est = float(convert(b.estimate, b.unit, du)) if du != b.unit else b.estimate
        contribution = b.contribution
        c = b.sensitivity
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
                f"{c + 0.0:.4g}{c_unit}",  # + 0.0 turns -0 into 0
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
