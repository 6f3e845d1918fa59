"""How many indexations and measurements a SAMBA strategy has, and how long it takes.

Alami Mchichi (2018), eq. 5.14 (measurements), §5.5.2 (strategy code xB.kn) and the
durations of Table 5.5 (digest 004 §3.10).

References
----------
Alami Mchichi, N. (2018). *Étalonnage des machines-outils à cinq axes : configuration
optimisée des artefacts et de la séquence de mesure de la méthode SAMBA en vue d'une
estimation efficace des erreurs géométriques*. PhD thesis, École Polytechnique de
Montréal.
"""

from __future__ import annotations

import math

from mtmetrology.errors import InputError

__all__ = [
    "COUNT_RULES",
    "MINUTES_PER_MEASUREMENT",
    "SOURCE_RULES",
    "count_rule_for",
    "estimate_test_duration_h",
    "indexation_count",
    "measurement_count",
]

#: Minutes per ball measurement, from seed 004's reported durations (digest 004 §3.10).
MINUTES_PER_MEASUREMENT = 1.36
#: ``"source"`` (the default) picks the reading of the source for the model; the other two
#: are the readings themselves (:func:`indexation_count`).
COUNT_RULES = ("source", "indexations", "measurements")
#: The reading of "k × unknowns/3" that reproduces the source's counts, by the number of
#: error parameters of the model (digest 004 §3.10): 1B.2n = 14 and 1B.3n = 21 indexations
#: for 13 parameters; 4B.5n = 38 indexations, 163 measurements, 3.7 h for 84, whose Table 5.3
#: durations (1.6 h at k = 2 … 7.6 h at k = 10, 4 balls) follow the same reading.  Another
#: model gets the text's own words, "the minimum number of measurements is unknowns/3".
SOURCE_RULES = {13: "indexations", 84: "measurements"}


def count_rule_for(rule: str, n_params: int) -> tuple[str, str]:
    """The reading that runs for ``rule`` and a model of ``n_params``, and why.

    Parameters
    ----------
    rule : {"source", "indexations", "measurements"}
    n_params : int
        Machine error parameters of the model.

    Returns
    -------
    (str, str)
        ``"indexations"`` or ``"measurements"``, and the reason (reported).

    Examples
    --------
    >>> count_rule_for("source", 84)[0], count_rule_for("source", 13)[0]
    ('measurements', 'indexations')
    """
    if rule not in COUNT_RULES:
        raise InputError(f"count rule {rule!r}: choose one of {', '.join(COUNT_RULES)}")
    if rule != "source":
        return rule, "asked for"
    if n_params in SOURCE_RULES:
        return SOURCE_RULES[n_params], (
            f"the source's reading for the {n_params}-parameter model (Alami Mchichi 2018)"
        )
    return "measurements", "the source's text: minimum measurements = unknowns/3"


def measurement_count(n_indexations: int, n_balls: int, tools: int = 1) -> int:
    """Total measurements ``M_T`` of a SAMBA programme (seed 004 eq. 5.14).

    ``M_T = M·n + 2·bar(0°) + 2·bar(90°) + m_0°·n + 3·tools``.

    >>> measurement_count(21, 1), measurement_count(14, 1), measurement_count(38, 4)
    (29, 22, 163)
    """
    return n_indexations * n_balls + 4 + n_balls + 3 * tools


def indexation_count(
    k: float, n_params: int, n_balls: int, *, rule: str = "source", tool: bool = True
) -> int:
    """Number of (B, C) indexations M of a strategy ``xB.kn`` (seed 004 §5.5.2).

    Parameters
    ----------
    k : float
        Multiple of the minimum (2, 3, 4, 5, 10 in the source).
    n_params : int
        Machine error parameters of the model.
    n_balls : int
        Master balls.
    rule : {"source", "indexations", "measurements"}
        How ``k × unknowns/3`` is read (``"source"``: as the source does for the model,
        :func:`count_rule_for`), the unknowns being ``U = n_params + 3·n_balls +
        3`` (tool). ``"indexations"``: ``M = k·⌈U/3⌉`` indexations — reproduces 1B.2n = 14
        and 1B.3n = 21 (13 parameters). ``"measurements"``: ``M_T ≈ k·U/3`` measurements
        in total, ``M = ⌊(k·U/3 − fixed)/n⌋`` — reproduces 4B.5n = 38 (84 parameters).
        The source uses both readings (digest 004 §7 item 5).
    tool : bool
        Whether the tool offset is among the unknowns.

    Examples
    --------
    >>> indexation_count(3, 13, 1), indexation_count(2, 13, 1)
    (21, 14)
    >>> indexation_count(5, 84, 4), indexation_count(5, 84, 4, rule="indexations")
    (38, 165)
    """
    rule = count_rule_for(rule, n_params)[0]
    if not (k > 0 and math.isfinite(k)):
        raise InputError(f"k must be a positive number, got {k}")
    unknowns = n_params + 3 * n_balls + (3 if tool else 0)
    if rule == "indexations":
        return math.ceil(k * math.ceil(unknowns / 3) - 1e-9)
    fixed = measurement_count(0, n_balls)
    return max(math.floor((k * unknowns / 3 - fixed) / n_balls + 1e-9), 1)


def estimate_test_duration_h(
    n_measurements: int,
    n_indexations: int = 0,
    *,
    minutes_per_measurement: float = MINUTES_PER_MEASUREMENT,
    minutes_per_indexation: float = 0.0,
) -> float:
    """Estimated test duration, hours: ``T ≈ a·M_T + b·M``.

    ``a`` = 1.36 min per ball measurement fits every duration of seed 004 Table 5.5 and
    Ch. 6 within 7 % (digest 004 §3.10); ``b`` (per indexation) is 0 unless the user has
    timed the rotary moves.

    >>> round(estimate_test_duration_h(163), 2), round(estimate_test_duration_h(29), 2)
    (3.69, 0.66)
    """
    return (
        minutes_per_measurement * n_measurements + minutes_per_indexation * n_indexations
    ) / 60.0
