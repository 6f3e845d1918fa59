"""The pooling test: do task uncertainties hold when point sets of several poses are mixed?

Sepahi Boroujeni (2021), §6.5 ("pooling test"), probed a calibrated precision sphere in
10 sets of 25 points, each set at its own B, C indexation. To stress the uncertainty
statement, k = 1 … 10 sets are pooled and 25 points drawn at random from the pool, 200
times per k; each draw is compensated and its diameter and sphericity get a full-
covariance GUF interval y ± U (:func:`mtmetrology.omm.task.task_uncertainty`), and the
coverage probability of eq. 6-16 against the calibrated value is averaged per k
(:func:`mtmetrology.omm.reference.coverage_probability`). An error that is constant
within a pose but differs between poses (probe lobing seen from a new orientation,
hysteresis, a pose-dependent offset the budget does not hold) leaves k = 1 untouched and
shows as soon as two poses are mixed: in the thesis the sphericity coverage fell from
100 % at k = 1 to 9 % at k = 2, while the diameter held 100 % up to k = 3 and 95 % at
k = 7.

A draw whose sphere cannot be fitted is a failed fit, not a measurement: its points are
(nearly) coplanar — e.g. 25 points drawn from the equators of poses that share the C
axis — so the fit raises (:class:`~mtmetrology.fitting.validation.FitError`), or the
least-squares sphere of its compensated points does not converge (the iteration limit,
a rank-deficient step: :class:`mtmetrology.optimize.Status` ≤ 0), or y or U is not
finite. Such a draw would state a diameter millimetres off with U of metres; it is
excluded from the coverage and the means of its k, counted, and named in the result
(:class:`FailedFit`: k, draw, the pooled sets, the reason).

References
----------
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, §6.4 (eq. 6-16) and §6.5.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.fitting.batch import fit_spheres
from mtmetrology.fitting.composite import CombinedFeature
from mtmetrology.fitting.validation import FitError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.omm.reference import ReferenceValue, coverage_probability
from mtmetrology.omm.task import task_uncertainty
from mtmetrology.optimize import STATUS_MESSAGES, Status
from mtmetrology.rng import SeedLike, chunk_generators

__all__ = ["FailedFit", "PoolingResult", "pooling_experiment"]


@dataclass(frozen=True)
class FailedFit:
    """A draw excluded from the pooling test because its fit failed (module notes).

    Attributes
    ----------
    k : int
        Number of pooled sets.
    draw : int
        Draw number within that k, from 1.
    sets : tuple of str
        Names of the pooled sets (their files, or ``set 1`` …).
    reason : str
        What failed: the fit's error or its solver status.
    """

    k: int
    draw: int
    sets: tuple[str, ...]
    reason: str

    def to_dict(self) -> dict:
        return {"k": self.k, "draw": self.draw, "sets": list(self.sets), "reason": self.reason}

    def describe(self) -> str:
        """One line: ``k = 2, draw 7 (a.csv + b.csv): reason``."""
        return f"k = {self.k}, draw {self.draw} ({' + '.join(self.sets)}): {self.reason}"


@dataclass(frozen=True)
class PoolingResult:
    """Coverage, expanded uncertainty and value of pooled draws, per number of sets k.

    Attributes
    ----------
    k : (K,) ndarray of int
        Numbers of pooled point sets.
    output_names : tuple of str
        Feature outputs (``sphere_diameter``, ``sphericity`` …), the last axis below.
    unit : str
        Unit of the values and uncertainties (the features', mm).
    reference_value, reference_uncertainty : (m,) ndarray
        y_cal and u_cal of each output.
    values, expanded_uncertainty : (K, draws, m) ndarray
        y and U of every draw; NaN for a draw whose fit failed.
    coverage : (K, m) ndarray
        Mean over the draws of eq. 6-16 (the delivered coverage probability), failed fits
        excluded; NaN when every draw of a k failed.
    mean_expanded_uncertainty, mean_value : (K, m) ndarray
        Means of U and y over the draws whose fit succeeded (NaN when none did).
    points_per_draw : int
    p : float
        Coverage probability the intervals were stated for.
    source : dict or None
        The files of the request, recorded as ``source`` in the document
        (:func:`~mtmetrology.omm.validation_request.pooling_from_files`).
    failed : tuple of FailedFit
        The draws excluded because their fit failed, in order.
    """

    k: np.ndarray
    output_names: tuple[str, ...]
    unit: str
    reference_value: np.ndarray
    reference_uncertainty: np.ndarray
    values: np.ndarray
    expanded_uncertainty: np.ndarray
    coverage: np.ndarray
    mean_expanded_uncertainty: np.ndarray
    mean_value: np.ndarray
    points_per_draw: int
    p: float
    source: dict | None = None
    failed: tuple[FailedFit, ...] = ()

    @property
    def draws(self) -> int:
        """Draws per k."""
        return self.values.shape[1]

    @property
    def fits_used(self) -> np.ndarray:
        """(K,) number of draws of each k whose fit succeeded (the coverage's denominator)."""
        return np.array([self.draws - sum(f.k == k for f in self.failed) for k in self.k])

    def to_dict(self) -> dict:
        """An ``omm-pooling-test`` document: per output, per k, coverage, mean y, mean U over
        the draws whose fit succeeded (``fits_used``; null when none did), and the failed
        fits (``failed_fits``), each named."""

        def number(v) -> float | None:
            return float(v) if np.isfinite(v) else None

        used = self.fits_used
        outputs = []
        for j, name in enumerate(self.output_names):
            outputs.append(
                {
                    "name": name,
                    "unit": self.unit,
                    "reference": {
                        "value": float(self.reference_value[j]),
                        "u": float(self.reference_uncertainty[j]),
                    },
                    "per_k": [
                        {
                            "k": int(k),
                            "fits_used": int(used[i]),
                            "coverage": number(self.coverage[i, j]),
                            "mean_value": number(self.mean_value[i, j]),
                            "mean_U": number(self.mean_expanded_uncertainty[i, j]),
                        }
                        for i, k in enumerate(self.k)
                    ],
                }
            )
        doc = {
            "kind": "omm-pooling-test",
            "version": 1,
            "method": "guf",
            "p": self.p,
            "draws": self.draws,
            "points_per_draw": self.points_per_draw,
            "outputs": outputs,
            "failed_fits": [f.to_dict() for f in self.failed],
        }
        if self.source is not None:
            doc["source"] = dict(self.source)
        return doc


def _draw_indices(
    labels: np.ndarray, n_sets: int, k: int, draws: int, size: int, rng: np.random.Generator
) -> np.ndarray:
    """(draws, size) indices into the stacked points: k sets at random, then points.

    Uniform keys rank the sets (the k smallest are pooled) and the points (the ``size``
    smallest of the pooled points are drawn): sampling without replacement at both
    levels, vectorised over draws.
    """
    set_rank = np.argsort(rng.random((draws, n_sets)), axis=1)  # (draws, n_sets)
    chosen = np.zeros((draws, n_sets), bool)
    np.put_along_axis(chosen, set_rank[:, :k], True, axis=1)
    keys = rng.random((draws, labels.size))
    keys[~chosen[:, labels]] = np.inf  # points of sets not pooled are never drawn
    return np.argpartition(keys, size - 1, axis=1)[:, :size]


def pooling_experiment(
    machine: Machine,
    point_sets: Sequence[np.ndarray],
    parameters: np.ndarray,
    parameter_covariance: np.ndarray,
    features: Sequence,
    references: Sequence,
    *,
    reading_covariance=None,
    unexplained_covariance: np.ndarray | None = None,
    k_values: Sequence[int] | None = None,
    draws: int = 200,
    points_per_draw: int = 25,
    p: float = 0.95,
    seed: SeedLike = None,
    set_names: Sequence[str] | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> PoolingResult:
    """Coverage of task-uncertainty intervals on draws pooled from several poses.

    Parameters
    ----------
    machine : Machine
        As for :func:`~mtmetrology.omm.task.task_uncertainty` (X, Y, Z linear axes).
    point_sets : sequence of (n_i, n_axes) arrays
        Readings of each point set (mm, rad): one pose per set, the same workpiece.
    parameters : (P,) array
        Machine parameters δ used for the compensation (internal units).
    parameter_covariance : (P, P) array
        Their covariance, propagated as the calibration's U_θ (the ``calibration`` group of
        :func:`~mtmetrology.omm.task.task_uncertainty`; a covariance from
        :func:`mtmetrology.identification.long_term.long_term_parameters` stands in for both U_θ and
        the long-term variation).
    features : sequence of Feature
        Features of each drawn point set, sharing one unit (e.g. ``SphereDiameter``,
        ``Sphericity``); their outputs, in order, are the result's outputs.
    references : sequence of ReferenceValue or (value, standard_uncertainty)
        The calibrated y_cal and u_cal (feature unit) of each output.
    reading_covariance : None, (n_axes, n_axes) array or sequence of (n_i, n_axes, n_axes)
        Repeatability v of the readings: none, one for every reading, or one per reading
        of each set (e.g. :func:`mtmetrology.omm.task.reading_covariance`).
    unexplained_covariance : (3, 3) array, optional
        cov(e) of the unexplained volumetric errors, mm².
    k_values : sequence of int, optional
        Numbers of sets to pool, each in 1 … len(point_sets); default all of them.
    draws : int
        Random draws per k (200 in the thesis).
    points_per_draw : int
        Points per draw (25 in the thesis); the k smallest sets must hold as many.
    p : float
        Coverage probability of the intervals (k_p from the GUF).
    seed : int, SeedSequence or Generator, optional
        Each k draws from its own stream of one SeedSequence, so a k's result does not
        depend on which other k are asked for.
    set_names : sequence of str, optional
        A name for each point set (its file), for the failed fits; default ``set 1`` ….
    progress : callable, optional
        ``progress(done, total)`` after each draw (total = number of k × draws), for a
        progress display; the result does not depend on it.

    Returns
    -------
    PoolingResult
        Draws whose fit failed (module notes) excluded from the coverage and the means
        and listed in ``failed``.

    Raises
    ------
    InputError
        No point sets, sets that do not have the machine's axes, a k outside 1 …
        len(point_sets), too few points for a draw, references that do not match the
        outputs, or what :func:`~mtmetrology.omm.task.task_uncertainty` refuses.

    Notes
    -----
    For each k and draw: k of the sets are chosen uniformly without replacement, then
    ``points_per_draw`` of their pooled points; the draw's readings are compensated and
    propagated to y ± U by the full-covariance GUF, and eq. 6-16 of Sepahi Boroujeni
    (2021)::

        p_i = Φ((y_i + U_i − y_cal)/u_cal) − Φ((y_i − U_i − y_cal)/u_cal)

    is averaged over the draws whose fit succeeded. With k = 1 and ``points_per_draw``
    equal to the set size every draw of a set is that set.

    Examples
    --------
    Two sets of 8 readings on a 20 mm sphere (stylus-centre points) at two B/C poses of a
    perfect machine, 1 µm repeatability; every interval covers the true diameter:

    >>> import numpy as np
    >>> from mtmetrology.fitting.features import SphereDiameter
    >>> from mtmetrology.omm.repeatability import sphere_normal
    >>> m = Machine.load("five-axis-wcbxfzyst")
    >>> rng = np.random.default_rng(0)
    >>> sets = []
    >>> for b, c in [(0.3, 1.0), (-0.4, 2.0)]:
    ...     pts = [0, 0, 50.0] + 10.0 * sphere_normal(rng.uniform(0, 1.3, 8),
    ...                                             rng.uniform(0, 6.3, 8))
    ...     sets.append(m.inverse(pts, np.array([0, 0, 0, b, c, 0.0]), np.zeros(13)))
    >>> v = np.diag([1e-6, 1e-6, 1e-6, 0, 0, 0])
    >>> r = pooling_experiment(m, sets, np.zeros(13), np.zeros((13, 13)), [SphereDiameter()],
    ...                        [(20.0, 0.0)], reading_covariance=v, draws=5,
    ...                        points_per_draw=8, seed=1)
    >>> r.k.tolist(), r.coverage[:, 0].tolist()
    ([1, 2], [1.0, 1.0])
    """
    sets = [np.asarray(s, float) for s in point_sets]
    if not sets:
        raise InputError("point_sets: give at least one point set")
    for i, s in enumerate(sets):
        if s.ndim != 2 or s.shape[1] != machine.n_axes or not np.all(np.isfinite(s)):
            raise InputError(
                f"point set {i + 1}: expected finite readings of shape (n, {machine.n_axes}), "
                f"got {s.shape}"
            )
    n_sets = len(sets)
    ks = np.arange(1, n_sets + 1) if k_values is None else np.asarray(k_values)
    if ks.ndim != 1 or ks.size == 0 or not np.all((ks >= 1) & (ks <= n_sets) & (ks % 1 == 0)):
        raise InputError(f"k_values: each must be an integer in 1 … {n_sets}, got {k_values!r}")
    ks = ks.astype(int)
    if int(draws) != draws or draws < 1:
        raise InputError(f"draws: must be a positive integer, got {draws!r}")
    sizes = np.sort([len(s) for s in sets])
    if int(points_per_draw) != points_per_draw or points_per_draw < 1:
        raise InputError(f"points_per_draw: must be a positive integer, got {points_per_draw!r}")
    if sizes[: ks.min()].sum() < points_per_draw:
        raise InputError(
            f"points_per_draw = {points_per_draw}, but {ks.min()} set(s) may hold only "
            f"{sizes[: ks.min()].sum()} points; draw fewer points or pool more sets"
        )
    try:
        feature = CombinedFeature(tuple(features))  # one GUF per draw for all outputs
    except ValueError as err:
        raise InputError(f"features: {err}") from None
    need = max(getattr(f, "min_points", 1) for f in features)
    if points_per_draw < need:
        raise InputError(
            f"points_per_draw = {points_per_draw}: the features need at least {need} points "
            "per draw"
        )
    m_out = len(feature.output_names)
    refs = [
        (r.value, r.standard_uncertainty) if isinstance(r, ReferenceValue) else r
        for r in references
    ]
    if len(refs) != m_out:
        raise InputError(
            f"references: {len(refs)} given for {m_out} outputs ({', '.join(feature.output_names)})"
        )
    y_cal = np.array([float(r[0]) for r in refs])
    u_cal = np.array([float(r[1]) for r in refs])
    names = [f"set {i + 1}" for i in range(n_sets)] if set_names is None else list(set_names)
    if len(names) != n_sets:
        raise InputError(f"set_names: {len(names)} given for {n_sets} point sets")
    readings = np.concatenate(sets)  # (N, n_axes), all sets stacked
    labels = np.repeat(np.arange(n_sets), [len(s) for s in sets])
    v_all = _reading_covariances(reading_covariance, sets, machine.n_axes)
    values = np.full((ks.size, int(draws), m_out), np.nan)
    big_u = np.full_like(values, np.nan)
    failed = []
    streams = chunk_generators(seed, n_sets + 1)  # stream k for k sets, whatever else is asked
    for i, k in enumerate(ks):
        picks = _draw_indices(labels, n_sets, k, int(draws), int(points_per_draw), streams[k])
        for d, idx in enumerate(picks):
            reason, res = _draw_uncertainty(
                machine,
                readings[idx],
                parameters,
                parameter_covariance,
                feature,
                reading_covariance=None if v_all is None else v_all[idx],
                unexplained_covariance=unexplained_covariance,
                p=p,
            )
            if reason is None:
                values[i, d], big_u[i, d] = res.estimate, res.expanded_uncertainty
            else:
                pooled = tuple(names[s] for s in np.unique(labels[idx]))
                failed.append(FailedFit(int(k), d + 1, pooled, reason))
            if progress is not None:
                progress(i * int(draws) + d + 1, ks.size * int(draws))
    # eq. 6-16 of each draw (NaN where the fit failed), averaged over the others
    ok = np.isfinite(values[..., 0])
    per_draw = np.full_like(values, np.nan)
    if ok.any():
        for j in range(m_out):
            per_draw[ok, j] = coverage_probability(values[ok, j], big_u[ok, j], y_cal[j], u_cal[j])
    coverage = _mean_or_nan(per_draw)
    return PoolingResult(
        ks,
        feature.output_names,
        feature.unit,
        y_cal,
        u_cal,
        values,
        big_u,
        coverage,
        _mean_or_nan(big_u),
        _mean_or_nan(values),
        int(points_per_draw),
        float(p),
        failed=tuple(failed),
    )


def _mean_or_nan(a: np.ndarray) -> np.ndarray:
    """(K, m) mean over axis 1 of the finite entries (NaN marks failed fits), NaN if none."""
    ok = np.isfinite(a)
    count = ok.sum(axis=1)
    total = np.where(ok, a, 0.0).sum(axis=1)
    return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def _draw_uncertainty(machine, readings, parameters, covariance, feature, **kw):
    """``(None, GUF result)`` of one draw, or ``(reason, None)`` when its fit failed.

    Failed: the fit raises (coplanar points …), the least-squares sphere of the
    compensated points stops without converging (Status ≤ 0, the convergence test of
    :func:`mtmetrology.fitting.batch.fit_spheres`), or y or U is not finite.
    """
    try:
        result = task_uncertainty(machine, readings, parameters, covariance, feature, **kw)
        fit = fit_spheres(result.points[None])
    except FitError as err:
        return str(err), None
    if fit.status[0] <= 0:
        why = STATUS_MESSAGES[Status(int(fit.status[0]))]
        return (
            f"the least-squares sphere did not converge: {why} ({int(fit.nit[0])} iterations)",
            None,
        )
    guf = result.guf
    if not (np.all(np.isfinite(guf.estimate)) and np.all(np.isfinite(guf.expanded_uncertainty))):
        return "the value or its U is not finite", None
    return None, guf


def _reading_covariances(given, sets, n_axes: int) -> np.ndarray | None:
    """(N, n_axes, n_axes) covariances of the stacked readings, or None."""
    if given is None:
        return None
    total = sum(len(s) for s in sets)
    if not isinstance(given, list | tuple):
        one = np.asarray(given, float)
        if one.shape != (n_axes, n_axes):
            raise InputError(
                f"reading_covariance: expected one ({n_axes}, {n_axes}) matrix or a list of "
                f"one array per point set, got shape {one.shape}"
            )
        return np.broadcast_to(one, (total, n_axes, n_axes))
    blocks = list(given)
    if len(blocks) != len(sets):
        raise InputError(
            f"reading_covariance: give one ({n_axes}, {n_axes}) matrix or one array per "
            f"point set ({len(sets)}), got {len(blocks)}"
        )
    out = []
    for i, (b, s) in enumerate(zip(blocks, sets, strict=True)):
        b = np.asarray(b, float)
        if b.shape != (len(s), n_axes, n_axes):
            raise InputError(
                f"reading_covariance of point set {i + 1}: expected shape "
                f"({len(s)}, {n_axes}, {n_axes}), got {b.shape}"
            )
        out.append(b)
    return np.concatenate(out)
