"""Physical plausibility of inputs: the checks every reader of a file kind shares.

A value can be a valid number and still not be what the user meant: a temperature in
kelvin, a length in metres where mm are read, a position 5 m outside the machine, the same
file given twice.  The computation then returns a number that looks like a result.  Each
check here refuses such a value at the door with one line naming where it came from
(file, line, field or option) and what was expected -- the readers of the file kinds and the
workflows call them, never their own copies:

- :func:`checked_number`: a finite number (optionally above a minimum);
- :func:`check_temperatures`: within :data:`TEMPERATURE_RANGE` (°C): −50 to 100 °C holds
  every workshop and laboratory; 293 is a temperature in kelvin, 2000 a typing slip;
- :func:`check_positive`: a length (or diameter, or step) that must be > 0;
- :func:`check_uncertainty`: a standard uncertainty, finite and >= 0;
- :func:`check_within`: values inside an interval (a travel), with a margin;
- :func:`check_expansion_coefficient`: |α| <= :data:`EXPANSION_MAX` (1/K): every solid
  of a machine or workpiece is far below it; 11.5 is µm/(m·K) read as 1/K;
- :func:`check_scale`: a stated length against the length the machine measures for it:
  a ratio beyond :data:`SCALE_FACTOR` is a unit slip (µm, mm, m), not a machine error;
- :func:`distinct_files`: several input files of one kind, none given twice (by content).

Every refusal is an :class:`~mtmetrology.errors.InputError` (exit 2).
"""

from __future__ import annotations

import hashlib
import math
import os
from collections.abc import Callable, Iterable

import numpy as np

from mtmetrology.errors import InputError

__all__ = [
    "EXPANSION_MAX",
    "SCALE_FACTOR",
    "TEMPERATURE_RANGE",
    "check_expansion_coefficient",
    "check_positive",
    "check_scale",
    "check_temperatures",
    "check_uncertainty",
    "check_within",
    "checked_number",
    "distinct_files",
]

#: The plausible range of a temperature of a machine, workpiece or artefact (°C).
TEMPERATURE_RANGE = (-50.0, 100.0)
#: A stated length more than this factor from the measured one is a unit slip: √10 is half
#: of one decade on a log scale, far beyond any machine error (a scale error of 10 % is
#: 10⁵ µm/m) and well short of the 10³ of a µm/mm/m slip.
SCALE_FACTOR = math.sqrt(10.0)

#: Largest plausible magnitude of a linear expansion coefficient, 1/K: polymers reach about
#: 2e-4, metals 3e-5, invar and ceramics 1e-6.
EXPANSION_MAX = 5e-4

Where = str | Callable[[int], str]


def _at(where: Where, index: int) -> str:
    return where(index) if callable(where) else where


def checked_number(value: float | None, name: str, *, minimum: float | None = None) -> float | None:
    """``value`` as a finite float (None stays None); ``name`` (the option) in the refusal.

    Raises
    ------
    InputError
        Not a number, not finite, or below ``minimum``.

    Examples
    --------
    >>> checked_number("2.5", "--u-cal")
    2.5
    """
    if value is None:
        return None
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name}: expected a number, got {value!r}") from None
    if not math.isfinite(x):
        raise InputError(f"{name}: expected a finite number, got {value!r}")
    if minimum is not None and x < minimum:
        raise InputError(f"{name}: must be >= {minimum:g}, got {value!r}")
    return x


def check_temperatures(values, where: Where) -> np.ndarray:
    """Temperatures (°C) inside :data:`TEMPERATURE_RANGE`, as a float array.

    Parameters
    ----------
    values : array_like
        One or many temperatures, °C.
    where : str or callable
        The place named in the refusal, or a function of the flat index of the first bad
        value giving it (``"meas.csv, line 7: T_X"``).

    Raises
    ------
    InputError
        A value that is not finite or lies outside the range (kelvin for °C, a slip).

    Examples
    --------
    >>> check_temperatures([20.1, 19.8], "--temperature").tolist()
    [20.1, 19.8]
    """
    t = np.asarray(values, dtype=float)
    low, high = TEMPERATURE_RANGE
    bad = np.flatnonzero(~((t >= low) & (t <= high)))
    if bad.size:
        v = t.ravel()[bad[0]]
        hint = " (kelvin? temperatures are read in °C)" if 223.0 <= v <= 373.15 else ""
        raise InputError(
            f"{_at(where, int(bad[0]))}: {v:g} °C is outside the plausible {low:g} to "
            f"{high:g} °C{hint}"
        )
    return t


def check_expansion_coefficient(values, where: Where) -> np.ndarray:
    """Expansion coefficients (1/K) of magnitude <= :data:`EXPANSION_MAX`, as an array.

    Raises
    ------
    InputError
        A value that is not finite or is larger (µm/(m·K) given where 1/K is read).

    Examples
    --------
    >>> check_expansion_coefficient([11.5e-6, 23e-6], "cte_per_K").tolist()
    [1.15e-05, 2.3e-05]
    """
    a = np.asarray(values, dtype=float)
    bad = np.flatnonzero(~(np.abs(a) <= EXPANSION_MAX))
    if bad.size:
        raise InputError(
            f"{_at(where, int(bad[0]))}: {a.ravel()[bad[0]]:g} 1/K is not an expansion "
            f"coefficient (at most {EXPANSION_MAX:g} 1/K; µm/(m·K) given as 1/K?)"
        )
    return a


def check_positive(value, where: str, unit: str = "mm") -> float:
    """A finite value > 0 (a length, diameter, pitch), as float.

    Raises
    ------
    InputError
        Not a finite number > 0.

    Examples
    --------
    >>> check_positive(282.0, "--reference-mm")
    282.0
    """
    x = checked_number(value, where)
    if not x > 0:
        raise InputError(f"{where}: must be > 0 {unit}, got {x:g}")
    return x


def check_uncertainty(value, where: str, unit: str = "") -> float:
    """A standard uncertainty: finite and >= 0, as float.

    Raises
    ------
    InputError
        Not a finite number >= 0.
    """
    x = checked_number(value, where)
    if x < 0:
        raise InputError(
            f"{where}: an uncertainty must be >= 0{' ' + unit if unit else ''}, got {x:g}"
        )
    return x


def check_within(
    values,
    low: float,
    high: float,
    where: Where,
    *,
    margin: float = 0.0,
    what: str = "travel",
    unit: str = "mm",
) -> None:
    """Refuse values outside ``[low − margin, high + margin]``.

    Parameters
    ----------
    values : array_like
    low, high : float
        The interval (an axis travel).
    where : str or callable
        As for :func:`check_temperatures` (a callable gets the flat index of the value).
    margin : float
        Allowed overrun beyond each end (a stylus, a reflector offset), same unit.
    what : str
        The interval's name in the refusal.

    Raises
    ------
    InputError
        A value outside, or not finite.
    """
    v = np.asarray(values, dtype=float)
    slack = margin + 1e-9 * max(1.0, abs(low), abs(high))
    bad = np.flatnonzero(~((v >= low - slack) & (v <= high + slack)))
    if bad.size:
        x = v.ravel()[bad[0]]
        beyond = f" by more than {margin:g} {unit}" if margin > 0 else ""
        raise InputError(
            f"{_at(where, int(bad[0]))} = {x:g} {unit} lies outside the {what} "
            f"[{low:g}, {high:g}] {unit}{beyond}"
        )


def check_scale(
    value: float,
    measured: float,
    where: str,
    unit: str = "mm",
    against: str = "the distance the machine measures between its ends",
) -> None:
    """Refuse a stated length more than :data:`SCALE_FACTOR` from the length measured for
    it (a length in metres or µm where mm are read; a wrong artefact).

    Parameters
    ----------
    value : float
        The stated (calibrated, nominal) length, > 0.
    measured : float
        What the machine reads for it, nominally (> 0).
    where : str
        The file and field, or the option, of ``value``.
    unit : str
        Unit of both.
    against : str
        What ``measured`` is, in the refusal.

    Raises
    ------
    InputError
        The two differ by more than the factor.

    Examples
    --------
    >>> check_scale(305.21, 305.2, "artefact.yaml: scale_bar.length_mm")
    >>> check_scale(0.30521, 305.2, "artefact.yaml: scale_bar.length_mm")
    Traceback (most recent call last):
    ...
    mtmetrology.errors.InputError: artefact.yaml: scale_bar.length_mm: 0.30521 mm, but ...
    """
    if not (value > 0 and measured > 0):
        return
    ratio = measured / value
    if not 1.0 / SCALE_FACTOR <= ratio <= SCALE_FACTOR:
        times = f"{ratio:.2g} times more" if ratio > 1 else f"{1 / ratio:.2g} times less"
        raise InputError(
            f"{where}: {value:g} {unit}, but {against} is {measured:.6g} {unit} "
            f"({times}); is the length in {unit}?"
        )


def _digest(path: str | os.PathLike) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def distinct_files(paths: Iterable[str | os.PathLike], what: str = "input files") -> None:
    """Refuse the same content given twice among ``paths`` (a repeated argument, a copy):
    repeated results would count as independent ones (u = 0 between them).

    Raises
    ------
    InputError
        Two paths with the same content (SHA-256), both named.
    """
    seen: dict[str, str] = {}
    for p in paths:
        try:
            key = _digest(p)
        except OSError:
            continue  # a missing or unreadable file: its reader names it
        if key in seen:
            same = (
                "is given twice" if os.fspath(p) == seen[key] else f"has the content of {seen[key]}"
            )
            raise InputError(
                f"{os.fspath(p)}: {same}; the {what} must be distinct (a repeated one would "
                "count as an independent result)"
            )
        seen[key] = os.fspath(p)
