"""A measurement model evaluated by the GUF, Monte Carlo or both, the GUF validated.

The workflow of ``mtm uncertainty run``, as one library call a notebook makes the same
way: :func:`evaluate_model` propagates the inputs of a loaded model file
(:func:`mtmetrology.uncertainty.modelfile.load_model`) by the law of propagation of
uncertainty (JCGM 100:2008, 5.1–5.2; :func:`~mtmetrology.uncertainty.guf.guf`), by the
Monte Carlo method (JCGM 101:2008, 7; :func:`~mtmetrology.uncertainty.mcm.monte_carlo`),
or both, and when both ran validates the GUF against the Monte Carlo result (JCGM
101:2008, 8). The :class:`ModelEvaluation` it returns is the ``uncertainty-result``
document (:func:`~mtmetrology.uncertainty.outputs.result_document`), the console summary
and the report section.

References
----------
JCGM 100:2008, *Evaluation of measurement data — Guide to the expression of uncertainty
in measurement*; JCGM 101:2008, *Supplement 1 — Propagation of distributions using a
Monte Carlo method*, 7.9 (adaptive procedure) and 8 (validation of the GUF).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from mtmetrology.display import NotebookRepr
from mtmetrology.errors import ConvergenceError, InputError

if TYPE_CHECKING:
    from mtmetrology.uncertainty.guf import GUFResult
    from mtmetrology.uncertainty.mcm import MCMResult
    from mtmetrology.uncertainty.modelfile import MeasurementModel
    from mtmetrology.uncertainty.validation import ValidationReport

__all__ = ["MAX_DIGITS", "MAX_VALUES", "METHODS", "ModelEvaluation", "evaluate_model"]

#: The methods of evaluation: the GUF, the Monte Carlo method, or both with validation.
METHODS = ("guf", "mcm", "both")
#: Most Monte Carlo values kept for the coverage intervals (trials × outputs): 400 MB.
MAX_VALUES = 50_000_000
#: Most significant digits an adaptive run may be asked for (JCGM 101:2008, 7.9.2 uses
#: 1 or 2; each further digit costs 100 times the trials).
MAX_DIGITS = 3


@dataclass(frozen=True, eq=False)
class ModelEvaluation(NotebookRepr):
    """A measurement model evaluated by :func:`evaluate_model`.

    Attributes
    ----------
    model : str or None
        The model's name (its file's ``name``).
    source : str or None
        The file it was read from, as given.
    output_names, output_units : tuple of str
        The outputs, in the model's order and units.
    guf : GUFResult or None
        The GUF result, when the GUF ran.
    mcm : MCMResult or None
        The Monte Carlo result, when it ran.
    validation : ValidationReport or None
        The GUF validated by the Monte Carlo result, when both ran.
    """

    model: str | None
    source: str | None
    output_names: tuple[str, ...]
    output_units: tuple[str, ...]
    guf: GUFResult | None
    mcm: MCMResult | None
    validation: ValidationReport | None

    def to_dict(self) -> dict:
        """The ``uncertainty-result`` document (:func:`result_document`)."""
        from mtmetrology.uncertainty.outputs import result_document

        return result_document(
            self.guf, self.mcm, self.validation, model=self.model, source=self.source
        )


def evaluate_model(
    loaded: MeasurementModel,
    method: str = "guf",
    *,
    digits: int = 2,
    p: float = 0.95,
    trials: int | None = None,
    adaptive: bool = False,
    seed=None,
    executor=None,
    source: str | None = None,
    progress=None,
) -> ModelEvaluation:
    """Evaluate a loaded measurement model by the GUF, Monte Carlo, or both.

    Parameters
    ----------
    loaded : MeasurementModel
        A model file read by :func:`~mtmetrology.uncertainty.modelfile.load_model`.
    method : {"guf", "mcm", "both"}
        ``"both"`` also validates the GUF against the Monte Carlo result (JCGM 101, 8).
    digits : int
        Significant digits of the numerical tolerance of an adaptive run and of the
        validation (JCGM 101:2008, 7.9.2), 1 to :data:`MAX_DIGITS`.
    p : float
        Coverage probability.
    trials : int, optional
        A fixed number of Monte Carlo trials (else ``adaptive`` or JCGM 101's 10⁶).
    adaptive : bool
        The adaptive procedure of JCGM 101:2008, 7.9.
    seed, executor
        As in :func:`~mtmetrology.uncertainty.mcm.monte_carlo`.
    source : str, optional
        The file the model came from, recorded in the document.
    progress : callable, optional
        ``progress(done, total)`` as the Monte Carlo trials are evaluated (total None in
        an adaptive run), for a progress display.

    Returns
    -------
    ModelEvaluation

    Raises
    ------
    InputError
        An unknown ``method``, ``p`` outside (0, 1), ``trials`` or ``adaptive`` with the GUF
        alone, both given, or ``digits`` out of range.
    ResourceLimitError
        More Monte Carlo values than :data:`MAX_VALUES` would be kept.
    ConvergenceError
        The adaptive Monte Carlo did not reach its tolerance within the trials allowed.
    """
    from mtmetrology.errors import ResourceLimitError
    from mtmetrology.uncertainty.guf import guf
    from mtmetrology.uncertainty.mcm import monte_carlo
    from mtmetrology.uncertainty.validation import validate_results

    if method not in METHODS:
        raise InputError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    if not 0.0 < p < 1.0:
        raise InputError(f"p (the coverage probability) must lie in (0, 1), got {p}")
    if method == "guf" and (trials is not None or adaptive):
        raise InputError("trials and adaptive apply to the Monte Carlo method (mcm or both)")
    if trials is not None and adaptive:
        raise InputError("give either a number of trials or adaptive, not both")
    if not 1 <= digits <= MAX_DIGITS:
        raise InputError(f"digits must be 1 to {MAX_DIGITS} significant digits, got {digits}")
    n_outputs = len(loaded.output_names)
    if trials is not None and not 2 <= trials <= MAX_VALUES // n_outputs:
        raise ResourceLimitError(
            f"trials {trials}: give 2 to {MAX_VALUES // n_outputs} trials for "
            f"{n_outputs} output(s) (every value is kept for the coverage intervals)"
        )
    g = r = validation = None
    if method in ("guf", "both"):
        g = guf(loaded.model, loaded.inputs, p=p)
    if method in ("mcm", "both"):
        r = monte_carlo(
            loaded.model,
            loaded.inputs,
            trials=trials,
            adaptive=adaptive,
            digits=digits,
            p=p,
            seed=seed,
            executor=executor,
            max_trials=min(10_000_000, MAX_VALUES // n_outputs),
            progress=progress,
        )
        if r.converged is False:
            raise ConvergenceError(
                f"adaptive Monte Carlo did not reach the tolerance of "
                f"{digits} significant digit(s) within {r.trials} trials; ask for fewer "
                "digits or run a fixed number of trials"
            )
    if g is not None and r is not None:
        validation = validate_results(g, r, digits=digits)
    return ModelEvaluation(
        model=loaded.name,
        source=source,
        output_names=tuple(loaded.output_names),
        output_units=tuple(loaded.output_units or ()),
        guf=g,
        mcm=r,
        validation=validation,
    )
