"""SAMBA set-ups: master balls, a scale bar, and the probing sequence of a strategy.

The sequence follows Alami Mchichi (2018), eq. 5.14, in its default strategy: every
master ball at B = C = 0; the scale bar at (B, C) = (0°, 0°) and (0°, 90°); one ball
re-probed at spindle indexations S = 90°, 180°, 270° to separate the tool offset from the
spindle offsets; then every master ball at each (B, C) pair.
Total M_T = M·n + 2·bar_placements + n + 3 (Alami Mchichi (2018), eq. 5.14 and
Table 5.5: 22, 29 and 163 measurements for 1 ball at 14 and 21 configurations and 4 balls
at 38).

References
----------
Alami Mchichi, N. (2018). *Étalonnage des machines-outils à cinq axes : configuration
optimisée des artefacts et de la séquence de mesure de la méthode SAMBA en vue d'une
estimation efficace des erreurs géométriques*. PhD thesis, École Polytechnique de Montréal.

The indications are the nominal readings (inverse kinematics of the given machine and
errors) that put the stylus centre on each ball centre.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.kinematics.machine import Machine

__all__ = ["SambaSetup", "probing_sequence"]


@dataclass(frozen=True)
class SambaSetup:
    """Balls of a SAMBA artefact in the workpiece frame (mm).

    Attributes
    ----------
    balls : mapping of str to (3,) array
        Master-ball centres.
    scale_bar : mapping of str to (3,) array
        The two scale-bar ball centres (ids are the bar's end names).
    spindle_ball : str, optional
        Ball re-probed at the spindle indexations; the first master ball by default.
    """

    balls: Mapping[str, Sequence[float]]
    scale_bar: Mapping[str, Sequence[float]] = field(default_factory=dict)
    spindle_ball: str | None = None

    @property
    def scale_bar_length(self) -> float:
        a, b = (np.asarray(v, dtype=float) for v in self.scale_bar.values())
        return float(np.linalg.norm(a - b))


def probing_sequence(
    machine: Machine,
    setup: SambaSetup,
    pairs_deg: Sequence[tuple[float, float]],
    *,
    params: np.ndarray | None = None,
    senses: np.ndarray | None = None,
    bar_pairs_deg: Sequence[tuple[float, float]] = ((0.0, 0.0), (0.0, 90.0)),
    spindle_deg: Sequence[float] = (90.0, 180.0, 270.0),
) -> tuple[list[str], np.ndarray]:
    """Ball ids and ball-centre indications of a SAMBA strategy, in probing order.

    Parameters
    ----------
    machine : Machine
        A five-axis machine with rotary axes B and C (and spindle S if indexed).
    setup : SambaSetup
    pairs_deg : sequence of (B, C)
        Rotary indexations, degrees, at which every master ball is probed.
    params : ndarray, optional
        Error parameters of the machine (internal units) used to simulate the readings.
    senses : ndarray, shape (n, n_axes), optional
        Senses of motion, needed only when ``params`` has non-zero reversal terms.
    bar_pairs_deg : sequence of (B, C)
        Indexations at which the scale bar is probed.
    spindle_deg : sequence of float
        Spindle indexations for the tool/spindle separation (needs an S axis).

    Returns
    -------
    balls : list of str
    readings : ndarray, shape (n, n_axes), internal units
    """
    if not {"B", "C"} <= set(machine.axis_names):
        raise InputError(f"{machine.name}: a SAMBA sequence needs rotary axes B and C")
    items: list[tuple[str, np.ndarray, float, float, float]] = []
    first = setup.spindle_ball or next(iter(setup.balls))
    for bid, c in setup.balls.items():
        items.append((bid, np.asarray(c, dtype=float), 0.0, 0.0, 0.0))
    for b, cdeg in bar_pairs_deg:
        for bid, c in setup.scale_bar.items():
            items.append((bid, np.asarray(c, dtype=float), b, cdeg, 0.0))
    if "S" in machine.axis_names:
        for s in spindle_deg:
            items.append((first, np.asarray(setup.balls[first], dtype=float), 0.0, 0.0, s))
    for b, cdeg in pairs_deg:
        for bid, c in setup.balls.items():
            items.append((bid, np.asarray(c, dtype=float), b, cdeg, 0.0))
    ids = [it[0] for it in items]
    targets = np.array([it[1] for it in items])
    start = {a: np.zeros(len(items)) for a in machine.axis_names}
    start["B"] = np.array([it[2] for it in items])
    start["C"] = np.array([it[3] for it in items])
    if "S" in machine.axis_names:
        start["S"] = np.array([it[4] for it in items])
    guess = machine.readings_from_customary(start)
    readings = machine.inverse(targets, guess, params, senses=senses)
    return ids, readings
