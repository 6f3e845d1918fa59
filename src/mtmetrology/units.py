"""Units at the edge: parse unit strings and convert to and from internal units.

Inside mtmetrology every quantity is in mm (length), rad (angle) or is
dimensionless (scale errors, squareness slopes: 75 µm/m is 75e-6).  Files, reports
and the command line use the customary ISO 230-1 units (µm, µrad, µm/m, degrees for
rotary axis positions).  This module is the only place that knows conversion
factors; nothing else multiplies by 1e-3.

A unit is parsed into a :class:`Unit`: a *dimension* (``"length"``, ``"angle"``,
``"ratio"``, ``"temperature"``, ...) and a *factor* to the internal unit of that
dimension.  Compound units such as ``µm/m``, ``mm/rad``, ``µm/deg`` or ``/°C`` are
supported as quotients of two simple units.

Examples
--------
>>> to_internal(75.0, "µm/m")
7.5e-05
>>> from_internal(0.0125, "µm")
12.5
>>> parse_unit("deg").dimension
'angle'
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from mtmetrology.errors import InputError

if TYPE_CHECKING:  # values may be arrays; converting needs no numpy (mtm history show)
    import numpy as np

__all__ = [
    "Unit",
    "UnitError",
    "convert",
    "display_unit",
    "display_unit_of",
    "from_internal",
    "internal_unit",
    "parse_unit",
    "to_internal",
]


class UnitError(InputError):
    """A unit string that does not parse, or a conversion between dimensions."""


@dataclass(frozen=True)
class Unit:
    """A parsed unit: its dimension and the factor that converts to internal units.

    ``value_internal = value * factor`` (temperatures in °C are treated as
    differences and have factor 1; kelvin is accepted only as a difference).
    """

    symbol: str
    dimension: str
    factor: float


# Simple units: symbol -> (dimension, factor to the internal unit of that dimension).
_SIMPLE: dict[str, tuple[str, float]] = {
    # length, internal mm
    "m": ("length", 1e3),
    "mm": ("length", 1.0),
    "um": ("length", 1e-3),
    "µm": ("length", 1e-3),
    "μm": ("length", 1e-3),
    "nm": ("length", 1e-6),
    "in": ("length", 25.4),
    # angle, internal rad
    "rad": ("angle", 1.0),
    "mrad": ("angle", 1e-3),
    "urad": ("angle", 1e-6),
    "µrad": ("angle", 1e-6),
    "μrad": ("angle", 1e-6),
    "deg": ("angle", math.pi / 180.0),
    "°": ("angle", math.pi / 180.0),
    "arcsec": ("angle", math.pi / 180.0 / 3600.0),
    '"': ("angle", math.pi / 180.0 / 3600.0),
    # dimensionless
    "1": ("ratio", 1.0),
    "": ("ratio", 1.0),
    "ppm": ("ratio", 1e-6),
    "%": ("ratio", 1e-2),
    # temperature (differences), internal °C
    "°C": ("temperature", 1.0),
    "degC": ("temperature", 1.0),
    "K": ("temperature", 1.0),
    # time, internal s
    "s": ("time", 1.0),
    "ms": ("time", 1e-3),
    "min": ("time", 60.0),
    "h": ("time", 3600.0),
    # pressure, internal Pa
    "Pa": ("pressure", 1.0),
    "hPa": ("pressure", 100.0),
    "kPa": ("pressure", 1000.0),
}


def _quotient_dimension(num: str, den: str) -> str:
    if num == den:
        return "ratio"
    if num == "ratio":
        return f"1/{den}"
    return f"{num}/{den}"


_SUPERSCRIPTS = {"²": 2, "³": 3}


def _split_power(den: str, symbol: str) -> tuple[str, int]:
    """Split ``"m^2"`` or ``"m²"`` into (``"m"``, 2)."""
    if den and den[-1] in _SUPERSCRIPTS:
        return den[:-1], _SUPERSCRIPTS[den[-1]]
    if "^" in den:
        base, _, exp = den.partition("^")
        if not exp.isdigit() or int(exp) < 1:
            raise UnitError(f"unit {symbol!r}: the power {exp!r} is not a positive integer")
        return base, int(exp)
    return den, 1


def parse_unit(symbol: str) -> Unit:
    """Parse a unit string such as ``"µm"``, ``"µm/m"``, ``"deg"`` or ``"/°C"``.

    Parameters
    ----------
    symbol : str
        The unit as written in a file or on the command line.  ``u`` is accepted
        for ``µ``; surrounding whitespace is ignored.

    Returns
    -------
    Unit

    Raises
    ------
    UnitError
        If the string is not a known simple unit or a quotient of two.
    """
    if not isinstance(symbol, str):
        raise UnitError(f"unit must be a string, got {type(symbol).__name__}")
    text = symbol.strip().replace(" ", "")
    if text in _SIMPLE:
        dim, factor = _SIMPLE[text]
        return Unit(text, dim, factor)
    if "/" in text:
        num, _, den = text.partition("/")
        if "/" in den:
            raise UnitError(f"unit {symbol!r}: at most one '/' is allowed")
        den, power = _split_power(den, symbol)
        num_dim, num_f = _SIMPLE.get(num, (None, None)) if num else ("ratio", 1.0)
        den_dim, den_f = _SIMPLE.get(den, (None, None))
        if num_dim is None or den_dim is None or num_f is None or den_f is None:
            bad = num if num_dim is None else den
            raise UnitError(f"unit {symbol!r}: unknown unit {bad!r}")
        if power == 1:
            return Unit(text, _quotient_dimension(num_dim, den_dim), num_f / den_f)
        return Unit(text, f"{num_dim}/{den_dim}^{power}", num_f / den_f**power)
    raise UnitError(
        f"unknown unit {symbol!r}; expected one of {sorted(k for k in _SIMPLE if k)} "
        "or a quotient such as 'µm/m'"
    )


def to_internal(value: float | np.ndarray, unit: str | Unit) -> float | np.ndarray:
    """Convert ``value`` given in ``unit`` to internal units (mm, rad, 1)."""
    u = unit if isinstance(unit, Unit) else parse_unit(unit)
    return value * u.factor  # a float, or an array elementwise


def from_internal(value: float | np.ndarray, unit: str | Unit) -> float | np.ndarray:
    """Convert ``value`` in internal units to ``unit``."""
    u = unit if isinstance(unit, Unit) else parse_unit(unit)
    return value / u.factor  # a float, or an array elementwise


def convert(value: float | np.ndarray, from_unit: str, to_unit: str) -> float | np.ndarray:
    """Convert between two units of the same dimension.

    Raises
    ------
    UnitError
        If the dimensions differ (e.g. µm to µrad).
    """
    a, b = parse_unit(from_unit), parse_unit(to_unit)
    if a.dimension != b.dimension:
        raise UnitError(
            f"cannot convert {from_unit!r} ({a.dimension}) to {to_unit!r} ({b.dimension})"
        )
    return from_internal(to_internal(value, a), b)


# Customary display (ISO 230-1) and internal symbols of a numerator / a denominator.
_DISPLAY_NUM = {"length": "µm", "angle": "µrad"}
_DISPLAY_DEN = {"length": "m", "angle": "rad"}
_INTERNAL = {"length": "mm", "angle": "rad"}


def _parts(symbol: str) -> tuple[str, str, int] | None:
    """(numerator, denominator, power) of a unit string; None for a simple unit."""
    text = symbol.strip().replace(" ", "")
    if text in _SIMPLE or "/" not in text:
        return None
    num, _, den = text.partition("/")
    den, power = _split_power(den, symbol)
    return num, den, power


def _rewrite(symbol: str, num_map: dict, den_map: dict) -> str:
    parse_unit(symbol)  # refuse what does not parse
    parts = _parts(symbol)
    if parts is None:
        return num_map.get(parse_unit(symbol).dimension, symbol.strip())
    num, den, power = parts
    num_dim = parse_unit(num).dimension if num else "ratio"
    den_dim = parse_unit(den).dimension
    if den_dim not in den_map or (num and num_dim not in num_map):
        return symbol.strip()
    top = num_map[num_dim] if num else ""
    return f"{top}/{den_map[den_dim]}" + (f"^{power}" if power > 1 else "")


#: A length this large (mm) is a position, shown in mm; an angle this large (rad) an axis
#: reading, shown in degrees.  Smaller ones are errors, shown in µm and µrad.
POSITION_MM = 1.0
READING_RAD = 1e-2


def display_unit_of(symbol: str, value: float) -> str:
    """The display unit of a value stored in ``symbol``: positions and axis readings in
    mm and degrees, errors in the customary units of :func:`display_unit`.

    An input of a budget may be a machine error (E_A0B = −9.6 µrad) or an axis reading
    (X = 91.662 67 mm, B = −42°); a plain length or angle of at least :data:`POSITION_MM`
    mm or :data:`READING_RAD` rad is the second kind (a geometric error that large is no
    longer small, and ISO 230-1 error motions are of the order of micrometres).

    Examples
    --------
    >>> display_unit_of("mm", 91.66267), display_unit_of("mm", 0.004)
    ('mm', 'µm')
    >>> display_unit_of("rad", -0.733), display_unit_of("rad", 9.6e-6)
    ('°', 'µrad')
    >>> display_unit_of("mm/mm", 5.0)
    'µm/m'
    """
    plain = symbol.strip()
    if plain == "mm" and abs(value) >= POSITION_MM:
        return "mm"
    if plain == "rad" and abs(value) >= READING_RAD:
        return "°"
    return display_unit(symbol)


def internal_unit(symbol: str) -> str:
    """The internal unit (mm, rad, their quotients) of the dimension of ``symbol``.

    Values in ``symbol`` become values in this unit through :func:`to_internal`.

    Examples
    --------
    >>> internal_unit("µrad"), internal_unit("µm/m"), internal_unit("µm/rad^2")
    ('rad', 'mm/mm', 'mm/rad^2')
    """
    return _rewrite(symbol, _INTERNAL, _INTERNAL)


def display_unit(symbol: str) -> str:
    """The customary display unit (ISO 230-1) of a quantity stored in ``symbol``.

    Lengths are shown in µm, angles in µrad, ratios of a length or angle to a length
    in µm/m or µrad/m (per m^d for a coefficient of degree d), to an angle per rad.
    Other units (a plain ``1``, °C, s, a unit such as nm that a model file chose) are
    shown as they are.

    Examples
    --------
    >>> display_unit("mm"), display_unit("rad"), display_unit("mm/mm"), display_unit("1")
    ('µm', 'µrad', 'µm/m', '1')
    >>> display_unit("mm/mm^2"), display_unit("rad/rad"), display_unit("nm"), display_unit("mg")
    ('µm/m^2', 'µrad/rad', 'nm', 'mg')
    """
    try:
        internal = parse_unit(symbol).factor == 1.0
    except UnitError:  # a unit this module does not know (g, mg, V ...): shown as given
        return symbol.strip()
    if not internal:  # the file's own choice (nm, µm, deg ...)
        return symbol.strip()
    return _rewrite(symbol, _DISPLAY_NUM, _DISPLAY_DEN)
