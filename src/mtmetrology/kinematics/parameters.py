"""ISO 230-1 error parameters: names, kinds, units, and the catalogue of a topology.

Names are written in ASCII as in ARCHITECTURE.md:

- location errors (position-independent): ``E_X0C``, ``E_A0B``, ``E_X0S`` —
  error direction, ``0``, axis.  The ISO forms ``E_A(0Z)B`` and ``E_X0(C1)`` are
  accepted and normalised (the reference axis in parentheses is dropped; C1 is S).
- error-motion coefficients: ``E_XX1``, ``E_YZ2``, ``E_BC0`` — error direction, moving
  axis, degree of the basis function.
- reversal (backlash) terms: ``E_BBb`` — error direction, moving axis, ``b``; the term
  is multiplied by the sense of motion (+1/−1) used to reach the position.

Error directions ``X Y Z`` are translations (internal mm; files µm); ``A B C`` are
rotations about X, Y, Z (internal rad; files µrad).  Coefficient units follow from the
basis (see :func:`coefficient_unit`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from mtmetrology.errors import InputError
from mtmetrology.kinematics.topology import LINEAR_AXES, Topology

__all__ = [
    "COMPONENTS",
    "ErrorParameter",
    "ParameterNameError",
    "catalogue",
    "coefficient_unit",
    "normalise_name",
    "parse_parameter",
]

COMPONENTS = "XYZABC"

_LOCATION = re.compile(r"^E_([XYZABC])0([XYZABCS])$")
_MOTION = re.compile(r"^E_([XYZABC])([XYZABCS])(\d+)$")
_REVERSAL = re.compile(r"^E_([XYZABC])([XYZABCS])b$")


class ParameterNameError(InputError):
    """A parameter name that is not an ISO 230-1 error name of the machine."""


@dataclass(frozen=True)
class ErrorParameter:
    """One error parameter of a kinematic model.

    Attributes
    ----------
    name : str
        ISO 230-1 ASCII name, e.g. ``"E_X0C"``, ``"E_XX1"``, ``"E_BBb"``.
    kind : {"location", "motion", "reversal"}
    axis : str
        The axis the error belongs to (for motions: the moving axis).
    component : int
        0..5 for X, Y, Z (translations) and A, B, C (rotations).
    degree : int or None
        Degree of the basis function (motion coefficients only).
    """

    name: str
    kind: str
    axis: str
    component: int
    degree: int | None = None

    @property
    def is_rotation(self) -> bool:
        return self.component >= 3


#: Highest degree of an error-motion polynomial (the sources use <= 3; beyond a dozen the
#: monomials of a metre-long travel overflow and the catalogue stops being bounded).
MAX_DEGREE = 12


def normalise_name(name: str) -> str:
    """Normalise ISO spellings: ``E_A(0Z)B`` -> ``E_A0B``, ``E_X0(C1)`` -> ``E_X0S``."""
    s = name.strip()
    s = re.sub(r"\(0[XYZABC]\)", "0", s)
    s = s.replace("(C1)", "S")
    s = re.sub(r"^(E_[XYZABC]0)C1$", r"\1S", s)
    return s


def parse_parameter(name: str) -> ErrorParameter:
    """Parse an ISO 230-1 error name.

    Raises
    ------
    ParameterNameError
        If the name is not of the form ``E_X0C``, ``E_XX1`` or ``E_BBb``.
    """
    s = normalise_name(name)
    if m := _LOCATION.match(s):
        return ErrorParameter(s, "location", m.group(2), COMPONENTS.index(m.group(1)))
    if m := _MOTION.match(s):
        if len(m.group(3)) > 2 or int(m.group(3)) > MAX_DEGREE:
            raise ParameterNameError(
                f"{name!r}: degree {m.group(3)} is beyond the highest error-motion degree "
                f"supported ({MAX_DEGREE})"
            )
        return ErrorParameter(
            s, "motion", m.group(2), COMPONENTS.index(m.group(1)), int(m.group(3))
        )
    if m := _REVERSAL.match(s):
        return ErrorParameter(s, "reversal", m.group(2), COMPONENTS.index(m.group(1)))
    raise ParameterNameError(
        f"{name!r} is not an ISO 230-1 error name: expected a location error such as "
        "'E_X0C', an error-motion coefficient such as 'E_XX1', or a reversal term such as 'E_BBb'"
    )


def coefficient_unit(param: ErrorParameter, *, normalised: bool) -> str:
    """Customary (file) unit of a parameter.

    Location and reversal terms are in µm or µrad.  A motion coefficient of degree d
    multiplies ``φ_d``: on a normalised travel φ is dimensionless and the coefficient has
    the unit of the error; for a raw monomial it is ``µm/m^d`` (linear axis) or
    ``µm/rad^d`` (rotary axis), e.g. ``E_XX1`` in µm/m and ``E_BB1`` in µrad/rad.
    """
    err = "µrad" if param.is_rotation else "µm"
    if param.kind != "motion" or normalised or param.degree == 0:
        return err
    pos = "m" if param.axis in LINEAR_AXES else "rad"
    return f"{err}/{pos}" if param.degree == 1 else f"{err}/{pos}^{param.degree}"


def catalogue(topology: Topology, max_degree: int = 3) -> list[ErrorParameter]:
    """Every candidate error parameter of a topology.

    For each axis: 6 location errors (``E_X0k`` … ``E_C0k``), 6 error-motion components
    with degrees 0..``max_degree`` (``E_Xk0`` … ``E_Ckd``), and 6 reversal terms
    (``E_Xkb`` …).  Many are not identifiable together; the identifiability analysis,
    not this list, says which.

    Examples
    --------
    >>> from mtmetrology.kinematics.topology import parse_topology
    >>> len(catalogue(parse_topology("WXFYZT"), max_degree=3))
    108
    """
    out: list[ErrorParameter] = []
    for axis in topology.axes:
        for c, comp in enumerate(COMPONENTS):
            out.append(ErrorParameter(f"E_{comp}0{axis}", "location", axis, c))
        for c, comp in enumerate(COMPONENTS):
            for d in range(max_degree + 1):
                out.append(ErrorParameter(f"E_{comp}{axis}{d}", "motion", axis, c, d))
        for c, comp in enumerate(COMPONENTS):
            out.append(ErrorParameter(f"E_{comp}{axis}b", "reversal", axis, c))
    return out
