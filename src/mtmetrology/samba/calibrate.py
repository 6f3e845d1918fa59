"""SAMBA calibration: machine errors, ball centres and tool offset from ball-centre indications.

The identification is the weighted Levenberg–Marquardt of the identification engine
(:class:`~mtmetrology.identification.BallCentreProblem`,
:func:`~mtmetrology.identification.levenberg_marquardt`; Alami Mchichi (2018) §5.3.4 and §6.3.2,
Sepahi Boroujeni (2021),
eqs 5-1…5-6): unknowns are the machine's error parameters, the centres of every probed
ball (nuisance) and, with ``estimate_tool``, the tool-vector correction.  Besides the
parameters the result carries what a calibration engineer reads (Alami Mchichi (2018),
§6.3 and Tables 4.5, 6.2, 6.3):

- the residual vector of every indication, the *unexplained volumetric error*, with the
  mean and maximum of its norm;
- the same norms for the *nominal model*: the set-up unknowns alone fitted with every
  machine error held at zero, i.e. the volumetric error the calibration removes;
- rank, condition numbers and observability indices O1–O5 of the Jacobian;
- the model adequacy (the identification engine's rule,
  :mod:`mtmetrology.identification.adequacy`): when the residuals contradict the model or
  σ (chi-squared p < 0.01) the covariance is scaled by s², and the residual RMS by ball
  and by stylus shows where the model misses.

A rank-deficient problem is refused (:class:`~mtmetrology.errors.RankDeficientError`)
naming the confounded combinations and what measurement would separate them, unless the
minimum-norm solution is asked for; it is then flagged in the result.

References
----------
Alami Mchichi, N. (2018). *Étalonnage des machines-outils à cinq axes : configuration
optimisée des artefacts et de la séquence de mesure de la méthode SAMBA en vue d'une
estimation efficace des erreurs géométriques*. PhD thesis, École Polytechnique de Montréal,
§5.3.4, §6.3.2, Tables 4.4, 4.5, 6.2, 6.3.
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, Ch. 5 (eqs 5-1 to 5-6).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from mtmetrology.errors import ConvergenceError, RankDeficientError
from mtmetrology.identification import (
    BallCentreProblem,
    IdentificationResult,
    levenberg_marquardt,
    residual_patterns,
)
from mtmetrology.kinematics.conventions import describe_parameters
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.samba.artefact import SambaArtefact
from mtmetrology.samba.notebook import SambaNotebookRepr
from mtmetrology.samba.records import SambaRecords
from mtmetrology.units import from_internal

if TYPE_CHECKING:  # it imports this module
    from mtmetrology.samba.uncertainty import SambaUncertainty

__all__ = ["SambaCalibration", "calibrate", "coverage", "separation_advice"]

KIND = "samba-calibration"


def coverage(uncertainty=None, policy=None) -> dict:
    """The one coverage factor of a calibration's parameters: console, JSON and report.

    The policy of :mod:`mtmetrology.uncertainty.coverage` (default k = 2, p = 2 Φ(2) − 1
    = 95.45 %, EA-4/02): U = k u of every parameter.  An uncertainty evaluation run at
    another probability ``p`` (a library call with its own ``p``) states
    ``k = Φ⁻¹((1 + p)/2)`` (JCGM 100:2008, G.1.3) instead, the k its GUF outputs state.

    Parameters
    ----------
    uncertainty : SambaUncertainty, optional
    policy : CoveragePolicy, optional
        The user's (``--k``/``--p``); default :data:`mtmetrology.uncertainty.coverage.DEFAULT`.

    Returns
    -------
    dict
        :meth:`CoveragePolicy.to_dict`: ``k``, ``coverage_probability``, ``stated``, ``rule``.

    References
    ----------
    JCGM 100:2008, 6.2.1 (U = k u) and G.1.3 (Table G.1); EA-4/02 M:2022, 5.1.
    """
    from mtmetrology.uncertainty.coverage import DEFAULT, coverage_policy

    policy = DEFAULT if policy is None else policy
    if uncertainty is not None:
        run = uncertainty.guf if uncertainty.guf is not None else uncertainty.mcm
        if run is not None and not np.isclose(run.p, policy.p, rtol=0, atol=1e-12):
            policy = coverage_policy(p=run.p)
    return policy.to_dict()


#: Converged when the scaled Gauss–Newton step is below a millionth of the input standard
#: uncertainties.  Tighter is below the rounding of the 84-coefficient chain (its
#: residuals carry ~1e-8 σ of rounding, which the undamped step amplifies by 1/s_min).
XTOL = 1e-6


@dataclass(frozen=True, eq=False)
class SambaCalibration(SambaNotebookRepr):
    """Result of :func:`calibrate`.

    Attributes
    ----------
    machine : Machine
        The machine with the identified error model active.
    records : SambaRecords
    artefact : SambaArtefact
    problem : BallCentreProblem
    identification : IdentificationResult
    nominal : IdentificationResult
        The set-up unknowns alone (machine errors held at zero).
    parameters : ParameterSet
        The machine's error parameters with ``(JᵀJ)⁻¹`` of the weighted problem, and the
        identified tool vector when it was estimated.
    uncertainty : SambaUncertainty or None
        The GUF/Monte Carlo evaluation attached by :meth:`with_uncertainty` (its covariance
        is then the parameters' in :meth:`to_dict`).
    """

    machine: Machine
    records: SambaRecords = field(repr=False)
    artefact: SambaArtefact = field(repr=False)
    problem: BallCentreProblem = field(repr=False)
    identification: IdentificationResult = field(repr=False)
    nominal: IdentificationResult = field(repr=False)
    parameters: ParameterSet

    uncertainty: SambaUncertainty | None = field(default=None, repr=False)

    def with_uncertainty(self, uncertainty) -> SambaCalibration:
        """This calibration with its uncertainty evaluation (:func:`evaluate_uncertainty`),
        so that :meth:`to_dict` and the ``repr`` state it."""
        return replace(self, uncertainty=uncertainty)

    def __repr__(self) -> str:
        """Machine, status and the parameters in customary units with u (GUM 7.2.6), from
        the attached uncertainty evaluation when there is one."""
        from mtmetrology.formatting import format_parameters

        doc = self.to_dict()
        p = doc["parameters"]
        lines = format_parameters(
            [e["name"] for e in p],
            [e["value"] for e in p],
            None if "u" not in p[0] else [e["u"] for e in p],
            [e["unit"] for e in p],
        )
        return (
            f"SambaCalibration(machine={self.machine.name!r}, {len(self.records)} indications, "
            f"{self.identification.message}; u from {doc['covariance_source']}:\n  "
            + "\n  ".join(lines)
            + ")"
        )

    @property
    def minimum_norm(self) -> bool:
        return self.identification.minimum_norm

    @property
    def covariance_factor(self) -> float:
        """Factor the adequacy rule scaled the a-priori covariance by (1 when it did not)."""
        a = self.identification.adequacy
        return 1.0 if a is None else a.factor

    def residual_patterns(self) -> dict:
        """RMS of the unexplained volumetric error by ball and by stylus (when the records
        name several), per axis, µm (:func:`~mtmetrology.identification.residual_patterns`)."""
        groups = {"ball": self.records.balls}
        if self.records.tools is not None:
            groups["stylus"] = self.records.tools
        vectors = self.residual_vectors
        return residual_patterns(vectors, groups, weighted=vectors / self.problem.sigma)

    @property
    def residual_vectors(self) -> np.ndarray:
        """(n, 3) unexplained volumetric error of each indication, mm."""
        return _vectors(self.identification, self.problem)

    @property
    def nominal_vectors(self) -> np.ndarray:
        """(n, 3) volumetric error of each indication under the nominal model, mm."""
        return _vectors(self.nominal, self.problem)

    def ball_centres(self) -> dict[str, np.ndarray]:
        """Identified ball centres in the workpiece frame, mm."""
        _, centres, _ = self.problem.split(self.identification.estimate)
        return {b: centres[i] for i, b in enumerate(self.problem.ball_ids)}

    @property
    def tool(self) -> np.ndarray:
        """Identified tool (stylus-centre) vector, mm (the nominal one unless estimated);
        (n_tools, 3) in the order of :meth:`tool_ids` when the records name several."""
        _, _, dtool = self.problem.split(self.identification.estimate)
        tools = self.problem.tools
        return (tools[0] if len(tools) == 1 else tools) + dtool

    def tool_ids(self) -> list[str]:
        """Ids of the tools of the records (artefact order), ``[]`` without a tool column."""
        if self.records.tools is None:
            return []
        return [t.id for t in self.artefact.tools if t.id in set(self.records.tools)]

    def priors(self) -> list[dict]:
        """Prior knowledge entered as pseudo-observations: ``[{name, value, unit, u}]`` of
        each tool-vector component (the prior's value and standard uncertainty, mm);
        empty without a prior."""
        prob = self.problem
        if prob.tool_prior is None:
            return []
        return [
            {"name": f"tool {c}", "value": float(v), "unit": "mm", "u": float(s)}
            for c, v, s in zip("xyz", prob.tool_prior_value, prob.tool_prior, strict=True)
        ]

    def propagation_factors(self) -> list[dict]:
        """Uncertainty propagation factor of each error parameter: ``[{name, unit, u, upf,
        upf_unit}]``.

        ``u_i = sqrt(diag((JᵀWJ)⁻¹))_i`` of the weighted identification (probing σ and the
        scale bar's u; ball centres and tool marginalised) in the parameter's customary
        unit, and ``UPF_i = u_i / σ`` with σ the probing noise in µm (Alami Mchichi (2018),
        eq. 6.14; Olarra et al. 2018): the unit of the parameter per µm of probing noise,
        the same figure the design of the same set-up predicts (exact when the bar's u is
        proportional to σ). None for a minimum-norm solution, where u is not defined.

        References
        ----------
        Alami Mchichi, N. (2018), eq. 6.14 and Table 6.2.
        """
        sigma_um = float(from_internal(self.problem.sigma, "µm"))
        u_int = self.identification.standard_uncertainty[self.parameter_indices()]
        out = []
        for name, unit, u in zip(
            self.machine.parameter_names, self.machine.parameter_units, u_int, strict=True
        ):
            uc = None if self.minimum_norm else float(from_internal(u, unit))
            out.append(
                {
                    "name": name,
                    "unit": unit,
                    "u": uc,
                    "upf": None if uc is None else uc / sigma_um,
                    "upf_unit": f"{unit}/µm",
                }
            )
        return out

    def parameter_indices(self) -> np.ndarray:
        """Positions of the machine's error parameters among the unknowns."""
        names = self.identification.names
        return np.array([names.index(n) for n in self.machine.parameter_names], dtype=int)

    def to_dict(self, uncertainty=None, input_covariance: str = "", policy=None) -> dict:
        """The RESULT document: a parameter set ``mtm predict --params`` reads as it is,
        plus the calibration's own keys (customary units: µm, µrad, µm/m, mm, degrees).

        Parameters
        ----------
        uncertainty : SambaUncertainty, optional
            When given, its covariance (GUF, or MCM when the GUF is not validated) is the
            parameter covariance, and its GUF/MCM outputs and validation are included.
        input_covariance : str
            How the indication covariance was stated (reported).
        policy : CoveragePolicy, optional
            The coverage factor of U = k u (default k = 2; :func:`coverage`).
        """
        uncertainty = self.uncertainty if uncertainty is None else uncertainty
        pset = self.parameters
        source = "identification: (JᵀJ)⁻¹ of the weighted problem"
        if uncertainty is not None:
            f = self.machine.parameter_scales
            pset = ParameterSet(
                pset.names,
                pset.values,
                pset.units,
                uncertainty.covariance * np.outer(f, f),
                pset.provenance,
                machine=pset.machine,
                model=pset.model,
                tool=pset.tool,
            )
            source = "mcm" if uncertainty.guf is None or not _validated(uncertainty) else "guf"
        doc = pset.to_document()
        doc["kind"] = KIND
        doc["covariance_source"] = source
        ident = self.identification
        diag = ident.diagnostics
        n = self.problem.readings.shape[0]
        customary = self.machine.readings_to_customary(self.problem.readings)
        axes = self.machine.axis_names
        res = from_internal(self.residual_vectors, "µm")
        norms = np.linalg.norm(res, axis=1)
        nominal = np.linalg.norm(from_internal(self.nominal_vectors, "µm"), axis=1)
        doc["coverage"] = coverage(uncertainty, policy)
        doc["conventions"] = [c.to_dict() for c in describe_parameters(self.machine)]
        doc["identification"] = {
            "status": ident.status,
            "success": ident.success,
            "message": ident.message,
            "iterations": ident.nit,
            "minimum_norm": ident.minimum_norm,
            "unknowns": len(ident.names),
            "rank": diag.rank,
            "condition_scaled": _finite(diag.condition_scaled),
            "condition_raw": _finite(diag.condition_raw),
            "observability": diag.observability,
            "confounded": [list(g) for g in diag.confounded()],
            "variance_factor": ident.variance_factor,
            "dof": ident.dof,
        }
        doc["records"] = {
            "source": self.records.source,
            "form": self.records.form,
            "indications": n,
            "campaigns": self.records.n_campaigns,
            "sigma_um": float(from_internal(self.problem.sigma, "µm")),
            "input_covariance": input_covariance,
        }
        doc["propagation_factors"] = self.propagation_factors()
        doc["balls"] = [
            {"id": b, "centre_mm": [float(v) for v in c]} for b, c in self.ball_centres().items()
        ]
        if self.tool_ids():
            doc["tools"] = [
                {"id": t, "vector_mm": [float(v) for v in vec]}
                for t, vec in zip(self.tool_ids(), np.atleast_2d(self.tool), strict=True)
            ]
            doc["tool_mm"] = doc["tools"][0]["vector_mm"]
        else:
            doc["tool_mm"] = [float(v) for v in self.tool]
        doc["tool_estimated"] = self.problem.estimate_tool
        doc["priors"] = self.priors()
        doc["residuals"] = [
            {
                "indication": k + 1,
                "line": int(self.records.lines[k]),
                "ball": self.records.balls[k],
                **{f"{a}": float(customary[k, i]) for i, a in enumerate(axes) if a in "BCS"},
                "dx_um": float(res[k, 0]),
                "dy_um": float(res[k, 1]),
                "dz_um": float(res[k, 2]),
                "norm_um": float(norms[k]),
            }
            for k in range(n)
        ]
        doc["volumetric_error"] = {
            "unexplained": {"mean_um": float(norms.mean()), "max_um": float(norms.max())},
            "nominal_model": {"mean_um": float(nominal.mean()), "max_um": float(nominal.max())},
        }
        doc["residual_patterns"] = self.residual_patterns()
        if ident.adequacy is not None:
            doc["adequacy"] = ident.adequacy.to_dict()
        if uncertainty is not None:
            doc["uncertainty"] = uncertainty.to_dict()
        return doc


def _validated(uncertainty) -> bool:
    return uncertainty.validation is None or uncertainty.validation.passed


def _finite(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def _vectors(result: IdentificationResult, problem: BallCentreProblem) -> np.ndarray:
    n = problem.readings.shape[0]
    return result.residuals[: 3 * n].reshape(n, 3) * problem.sigma


#: (names that mark a confounding, what to add) — most specific first.
_ADVICE = (
    (("tool x", "tool y"), "spindle indexing (one ball re-probed at S = 90, 180, 270°)"),
    (("tool z",), "indexations that tilt the tool against the table (B ≠ 0)"),
    (("E_AY", "E_BY", "E_BZ", "E_CY"), "a second stylus length (one stylus cannot tell them)"),
    (("E_XX1", "E_YY1", "E_ZZ1"), "the scale bar (both balls probed, at two indexations)"),
    (
        ("E_ZC", "E_ZB", "E_CB", "E_CC", "E_BBb", "E_CCb"),
        "(B, C) indexations off any straight line c = k·b, approached from both senses",
    ),
)


def separation_advice(groups) -> str:
    """What to add to the test to separate confounded groups (Alami Mchichi (2018) Table
    4.4); groups no SAMBA measurement separates (e.g. E_Y0C ~ E_Y0S, Sepahi
    Boroujeni (2021) Ch. 3) are said to be so.

    Examples
    --------
    >>> separation_advice([("E_X0S", "tool x")])
    'add spindle indexing (one ball re-probed at S = 90, 180, 270°)'
    >>> separation_advice([("E_Y0C", "E_Y0S")])
    'no probing of balls separates E_Y0C ~ E_Y0S'
    """
    hints: list[str] = []
    inseparable: list[str] = []
    for group in groups:
        text = " ".join(group)
        hint = next((h for marks, h in _ADVICE if any(m in text for m in marks)), None)
        if hint is None:
            inseparable.append(" ~ ".join(group))
        elif hint not in hints:
            hints.append(hint)
    parts = ["add " + " or ".join(hints)] if hints else []
    if inseparable:
        parts.append(f"no probing of balls separates {'; '.join(inseparable)}")
    return "; ".join(parts)


def _tools(records: SambaRecords, artefact: SambaArtefact) -> dict:
    """``tools``/``tool_index`` of the problem when the records name a tool per indication."""
    return {} if records.tools is None else artefact.stylus_unknowns(records.tools)


def calibrate(
    machine: Machine,
    records: SambaRecords,
    artefact: SambaArtefact,
    *,
    sigma: float,
    estimate_tool: bool = False,
    tool_prior=None,
    minimum_norm: bool = False,
    adequacy: str = "scale",
) -> SambaCalibration:
    """Identify a machine's errors from SAMBA records.

    Parameters
    ----------
    machine : Machine
        Machine with the error model to identify active.
    records : SambaRecords
        Indications (see :func:`mtmetrology.samba.read_records`).
    artefact : SambaArtefact
        Balls and scale bar (length and u).
    sigma : float
        Standard uncertainty of one indication coordinate, mm: the weight of the
        indications against the scale bar.
    estimate_tool : bool
        Add the tool-vector correction to the unknowns (needs spindle indexing).
    tool_prior : float or (3,) floats, optional
        Standard uncertainty (mm) of each tool-vector component about the machine's
        nominal tool vector (one value, or x, y, z): weighted pseudo-observations
        ``(t − t0)/u_t`` (Alami Mchichi (2018) §5.3.4 takes the tool length as known with
        u = 1 mm).  Needs ``estimate_tool``.
    minimum_norm : bool
        Solve a rank-deficient problem by its minimum-norm solution (flagged) instead of
        refusing it.
    adequacy : {"scale", "a-priori"}
        The identification engine's model-adequacy rule: when the residuals contradict the
        model or σ (chi-squared p < 0.01) the covariance is scaled by s² (``"scale"``) or
        kept (``"a-priori"``).

    Returns
    -------
    SambaCalibration

    Raises
    ------
    RankDeficientError
        Naming the confounded combinations and what to add; ``confounded`` lists them.
    InputError
        If a tool prior is given without ``estimate_tool`` or with a u that is not positive.
    ConvergenceError
        If the Levenberg–Marquardt iteration stops without converging.

    Notes
    -----
    Residuals ``r_k = p(q_k; θ, t) − d_i(k)`` (3 rows per indication, weight 1/σ) and
    ``r_L = ‖d_a − d_b‖ − L`` (weight 1/u_L), with a tool prior ``r_t = t − t0`` (weight
    1/u_t, the prior's value t0 an uncertain input); Gauss–Newton with column scaling on the
    project's least-squares core (Sepahi Boroujeni (2021), eqs 5-4 to 5-6).
    """
    tools = _tools(records, artefact)
    problem = BallCentreProblem(
        machine,
        records.readings,
        records.balls,
        senses=records.senses,
        scale_bars=artefact.scale_bars(),
        estimate_tool=estimate_tool,
        sigma=sigma,
        tool_prior=tool_prior,
        **tools,
    )
    report = [*machine.parameter_names, *(n for n in problem.names if n.startswith("tool"))]
    try:
        result = levenberg_marquardt(
            problem, xtol=XTOL, report_names=report, minimum_norm=minimum_norm
        )
    except RankDeficientError as err:
        groups = [g for g in err.confounded if set(g) & set(report)] or list(err.confounded)
        listed = "; ".join(" ~ ".join(g) for g in groups)
        raise RankDeficientError(
            f"{records.source}: the test cannot separate {listed}: {separation_advice(groups)}; "
            "or drop one parameter of each group (--params-only), or ask for the "
            "minimum-norm solution (--min-norm)",
            confounded=tuple(groups),
        ) from None
    if not result.success:
        raise ConvergenceError(
            f"{records.source}: the identification did not converge ({result.message}); "
            "look for gross errors in the records (a wrong ball id, a reading of another "
            "probing)"
        )
    result = result.with_adequacy(adequacy)
    nominal_problem = BallCentreProblem(
        machine.with_parameters([]),
        records.readings,
        records.balls,
        scale_bars=artefact.scale_bars(),
        estimate_tool=estimate_tool,
        sigma=sigma,
        tool_prior=tool_prior,
        **tools,
    )
    nominal = levenberg_marquardt(nominal_problem, minimum_norm=True)
    provenance = {
        "method": "SAMBA (Alami Mchichi 2018; Sepahi Boroujeni 2021)",
        "records": records.source,
        "minimum_norm": result.minimum_norm,
    }
    pset = result.parameter_set(machine, provenance)
    if estimate_tool and "tools" not in tools:  # what the calibration identifies, compensation uses
        _, _, dtool = problem.split(result.estimate)
        pset = replace(pset, tool=machine.tool + dtool)
    return SambaCalibration(
        machine=machine,
        records=records,
        artefact=artefact,
        problem=problem,
        identification=result,
        nominal=nominal,
        parameters=pset,
    )
