"""``analyse``: one ISO 230-2 axis test, from its readings to the result document.

One call applies the environmental correction (stated, reversible:
:mod:`mtmetrology.positioning.environment`), evaluates the positioning parameters of the
chosen edition (:mod:`mtmetrology.positioning.parameters`), their uncertainty per
ISO/TR 230-9 (:mod:`mtmetrology.positioning.budget`), the pitch-compensation table and,
with a machine, the ISO 230-1 positioning function of the axis
(:mod:`mtmetrology.positioning.identify`).  Nothing is written: the command line writes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mtmetrology.display import NotebookRepr
from mtmetrology.errors import InputError
from mtmetrology.formatting import format_uncertainty, format_value
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.positioning import environment
from mtmetrology.positioning.budget import Budget, tr230_9_budget
from mtmetrology.positioning.data import PositioningTest
from mtmetrology.positioning.identify import identify_axis
from mtmetrology.positioning.parameters import EDITIONS, evaluate
from mtmetrology.units import from_internal

__all__ = ["KIND", "PositioningResult", "analyse"]

KIND = "iso230-2-positioning"
VERSION = 1
#: Axis parameters shown, in the standard's order, with their symbols.
SYMBOLS = {
    "E_up": "E↑",
    "E_down": "E↓",
    "E": "E",
    "M": "M",
    "B": "B",
    "B_mean": "B̄",
    "R_up": "R↑",
    "R_down": "R↓",
    "R": "R",
    "A_up": "A↑",
    "A_down": "A↓",
    "A": "A",
    "Pa": "P_a",
    "Ps": "P_s",
    "U": "U",
    "U_mean": "Ū",
    "P": "P",
}


@dataclass(frozen=True)
class PositioningResult(NotebookRepr):
    """The ISO 230-2 evaluation of one axis test.

    Attributes
    ----------
    machine : str or None
    axis, edition : str
    targets : ndarray, shape (m,)
        Target positions, mm.
    deviations : ndarray, shape (m, n, 2)
        The corrected deviations, mm (what the parameters are computed from).
    per_target, parameters : dict
        The edition's per-target statistics and axis parameters, µm.
    environment : dict
        The correction applied: refractive index n, assumed index n_0, material
        temperature, expansion coefficient, the factor f, and whether each part was applied.
    budget : Budget
        ISO/TR 230-9 uncertainty of the parameters.
    parameter_set : ParameterSet or None
        ``E_XX`` and ``E_XXb`` identified (with a machine).
    identification : dict or None
    conditions : dict
    source : str
    """

    _renderer_module = "mtmetrology.positioning.report"

    machine: str | None
    axis: str
    edition: str
    targets: np.ndarray
    deviations: np.ndarray
    per_target: dict
    parameters: dict
    environment: dict
    budget: Budget
    parameter_set: ParameterSet | None = None
    identification: dict | None = None
    conditions: dict = field(default_factory=dict)
    source: str = ""

    def pitch_table(self) -> dict:
        """The pitch-compensation table: per target the mean bidirectional deviation x̄_i,
        the reversal B_i and the two directions' means, µm, with the standard uncertainty
        of x̄_i and of each direction's mean (``u_forward_um``, ``u_reverse_um``):
        ``u² = s↑²/n + u_L²`` (the same for ↓; ``s²/(2n) + u_L²`` for x̄_i), s the scatter
        of one reading pooled over the targets (JCGM 100:2008, §4.2.8: five runs give a
        target's own s only 4 degrees of freedom, too few for its mean's u), u_L the
        ISO/TR 230-9 budget at the target's distance from the datum."""
        x = from_internal(self.deviations, "µm")
        n = x.shape[1]
        mean_up, mean_down = x[:, :, 0].mean(axis=1), x[:, :, 1].mean(axis=1)
        var_up = x[:, :, 0].var(axis=1, ddof=1).mean()
        var_down = x[:, :, 1].var(axis=1, ddof=1).mean()
        u_laser = self.budget.u_at_um(self.span)
        u_mean = np.sqrt(0.5 * (var_up + var_down) / (2 * n) + u_laser**2)
        return {
            "position_mm": self.targets.tolist(),
            "mean_um": (0.5 * (mean_up + mean_down)).tolist(),
            "reversal_um": (mean_up - mean_down).tolist(),
            "forward_um": mean_up.tolist(),
            "reverse_um": mean_down.tolist(),
            "u_mean_um": u_mean.tolist(),
            "u_forward_um": np.sqrt(var_up / n + u_laser**2).tolist(),
            "u_reverse_um": np.sqrt(var_down / n + u_laser**2).tolist(),
            "correction": "the control applies −mean (and ∓reversal/2 per direction)",
        }

    @property
    def span(self) -> np.ndarray:
        """Distance of each target from the laser datum, mm."""
        datum = self.conditions.get("datum_mm")
        return np.abs(self.targets - (self.targets[0] if datum is None else datum))

    def to_dict(self) -> dict:
        """The JSON document; with a machine it embeds the identified parameter set (the
        keys of a ``parameter-set``) and says ``category: calibration``, so ``mtm export``
        and ``mtm history add`` read it (without one the history cannot record it)."""
        doc = {
            "kind": KIND,
            "version": VERSION,
            "machine": self.machine,
            "axis": self.axis,
            "edition": self.edition,
            "standard": EDITIONS[self.edition],
            "unit": "µm",
            "conditions": self.conditions,
            "environment": self.environment,
            "iso230_2": {k: float(v) for k, v in self.parameters.items()},
            "per_target": {"position_mm": self.targets.tolist()}
            | {k: np.asarray(v).tolist() for k, v in self.per_target.items()},
            "uncertainty": self.budget.to_dict(),
            "pitch_table": self.pitch_table(),
            "source": self.source,
        }
        if self.parameter_set is not None:
            # the history records a run with its identified parameters as a calibration
            doc["category"] = "calibration"
            pdoc = self.parameter_set.to_document()
            for key in ("model", "parameters", "covariance", "provenance"):
                if key in pdoc:
                    doc[key] = pdoc[key]
            doc["identification"] = self.identification
        return doc

    def summary(self) -> str:
        """Console table: each parameter with U (k stated), µm."""
        u = self.budget.parameter_u()
        k = self.budget.k
        lines = [
            f"{EDITIONS[self.edition]} positioning of axis {self.axis}"
            + (f" ({self.machine})" if self.machine else "")
            + f": {self.targets.size} targets, {self.deviations.shape[1]} runs per direction",
            f"{'parameter':<10} {'value / µm':>12} {'U / µm':>8}  (k = {k:g})",
        ]
        for key in (k for k in SYMBOLS if k in self.parameters):
            value = self.parameters[key]
            uu = u.get(key)
            big_u = None if uu is None else k * uu
            lines.append(
                f"{SYMBOLS.get(key, key):<10} {format_value(float(value), big_u):>12} "
                f"{format_uncertainty(big_u):>8}"
            )
        env = self.environment
        air = "applied" if env["air_applied"] else "as given"
        nde = "applied" if env["nde_applied"] else "as given"
        alpha = from_internal(env["alpha_per_K"], "µm/m")
        lines.append(
            f"environment: n = {env['n_air']:.8f} (air {air}), material "
            f"{env['material_C']:.2f} °C, α = {alpha:.2f} µm/(m·K) (NDE {nde}), "
            f"f − 1 = {from_internal(env['factor'] - 1.0, 'µm/m'):.3f} µm/m"
        )
        if self.parameter_set is not None:
            ps = self.parameter_set
            uu = ps.standard_uncertainty / ps.scales()
            terms = ", ".join(
                f"{n} = {format_value(v, 2 * w)} ± {format_uncertainty(2 * w)} {unit}"
                for n, v, w, unit in zip(
                    ps.names, ps.values / ps.scales(), uu, ps.units, strict=True
                )
            )
            lines.append(f"ISO 230-1 (k = 2): {terms}")
            lines.append(
                f"largest |x̄_i − fit| {self.identification['max_mean_misfit_um']:.2g} µm "
                "(what the function does not follow of the pitch table)"
            )
        return "\n".join(lines)


def _environment(test: PositioningTest) -> tuple[np.ndarray, dict]:
    c = test.conditions
    n_air = environment.refractive_index(
        c.air_temperature_C, c.air_pressure_Pa, c.humidity_percent, c.wavelength_nm
    )
    # readings already compensated by the instrument: the index it assumed is n itself
    n_assumed = n_air if c.air_compensated else 1.0
    alpha = 0.0 if c.nde_applied else c.expansion_material_per_K
    f = environment.correction_factor(n_air, c.material_C, alpha, n_assumed)
    datum = test.targets[0] if c.datum_mm is None else c.datum_mm
    x = environment.correct(test.deviations, test.targets - datum, f)
    return x, {
        "equation": "updated Edlén (Birch & Downs 1994)",
        "n_air": n_air,
        "n_assumed": n_assumed,
        "air_applied": not c.air_compensated,
        "material_C": c.material_C,
        "alpha_per_K": c.expansion_material_per_K,
        "nde_applied": not c.nde_applied,
        "factor": f,
        "datum_mm": float(datum),
        "undo": "x = (x_c − (f − 1)(P_i − datum))/f",
    }


def analyse(
    test: PositioningTest,
    *,
    edition: str = "2014",
    machine: Machine | None = None,
    degrees: list[int] | None = None,
    budget_inputs: dict | None = None,
) -> PositioningResult:
    """Evaluate one ISO 230-2 axis test.

    Parameters
    ----------
    test : PositioningTest
    edition : {"2014", "2006", "1997", "1988", "vdi3441"}
    machine : Machine, optional
        With a machine the axis's ``E_XX`` and ``E_XXb`` are identified (its model basis).
    degrees : list of int, optional
        Degrees of ``E_XX`` (the model's when omitted).
    budget_inputs : dict, optional
        ISO/TR 230-9 inputs overriding the defaults (:func:`tr230_9_budget`).

    Returns
    -------
    PositioningResult

    Raises
    ------
    InputError
        An unknown edition, conditions out of range, a bad axis.
    """
    if edition not in EDITIONS:
        raise InputError(f"--edition: {edition!r} is not one of {', '.join(EDITIONS)}")
    x, env = _environment(test)
    stats = evaluate(from_internal(x, "µm"), edition)
    scalars = {k: v for k, v in stats.items() if np.ndim(v) == 0}
    per_target = {k: v for k, v in stats.items() if np.ndim(v) == 1}
    c = test.conditions
    budget = tr230_9_budget(test.targets, c, n_runs=test.runs, **(budget_inputs or {}))
    pset = ident = None
    if machine is not None:
        pset, ident = identify_axis(
            machine, c.axis, test.targets, x, degrees=degrees, provenance={"file": test.source}
        )
    return PositioningResult(
        machine=None if machine is None else machine.name,
        axis=c.axis,
        edition=edition,
        targets=test.targets,
        deviations=x,
        per_target=per_target,
        parameters=scalars,
        environment=env,
        budget=budget,
        parameter_set=pset,
        identification=ident,
        conditions=c.to_dict(),
        source=test.source,
    )
