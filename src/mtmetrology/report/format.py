"""Numbers as a report prints them: values with their uncertainty, plain cells.

A value is printed to the decimal of its standard uncertainty's second significant
digit (JCGM 100:2008, 7.2.6), the uncertainty with two significant digits; a number
without an uncertainty keeps enough significant digits to be read back (``%.10g``
trimmed), so a table never shows ``5.00008e+07`` for an end-gauge length.
"""

from __future__ import annotations

import math
import numbers

__all__ = ["decimals_for", "format_cell", "format_uncertainty", "format_value"]


def decimals_for(u: float) -> int:
    """Decimals that show ``u`` with two significant digits (JCGM 100:2008, 7.2.6).

    Examples
    --------
    >>> decimals_for(31.7), decimals_for(0.0012), decimals_for(250.0)
    (0, 4, 0)
    """
    if not (math.isfinite(u) and u > 0):
        return 6
    return max(0, 1 - math.floor(math.log10(u)))


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
        return f"{u:.2g}"
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
    """
    if u is None or not (math.isfinite(u) and u > 0):
        return format_cell(value)
    return f"{value:.{decimals_for(u)}f}"


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
