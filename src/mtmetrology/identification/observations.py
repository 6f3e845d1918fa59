"""Observation model of ball-centre indications (SAMBA, ball plates, R-test-like set-ups).

A probing of ball i at axis readings q gives a *ball-centre indication*: the readings
that put the stylus centre at the ball centre.  With machine errors θ, tool-vector
correction Δt and the (unknown, uncalibrated) ball centre d_i in the workpiece frame,
the residual is (Sepahi Boroujeni (2021), eqs 5-1…5-3; Alami Mchichi (2018), eq. 5.2)::

    r_k = p(q_k; θ, t0 + Δt) − d_i(k)                 3 rows per indication

and a calibrated scale bar between balls a and b adds (Sepahi Boroujeni (2021), Ch. 5;
Alami Mchichi (2018), Ch. 5)::

    r_L = ‖d_a − d_b‖ − L                              1 row per bar

and an optional prior on the tool vector (the stylus length known a priori with
u = 1 mm, Alami Mchichi (2018) §5.3.4) adds weighted pseudo-observations::

    r_t = t0 + Δt − t̄                                 3 rows, weight 1/u_t

where t̄ is the prior's value (the nominal tool vector of the machine), an uncertain input
like the readings, so that propagation through the identification carries it.

Rows are weighted by the standard uncertainty of each kind (coordinates σ, bar u_L), so
the problem is the weighted least squares the identification engine solves.

The *inputs* of the problem, for uncertainty propagation, are the linear-axis readings of
every indication (X, Y, Z in the order of the machine's linear axes, mm) followed by the
calibrated bar lengths (mm) and, with a tool prior, its value t̄ (mm):
:meth:`BallCentreProblem.input_estimate`,
:meth:`~BallCentreProblem.input_jacobian` (∂r/∂z for the GUF) and
:meth:`~BallCentreProblem.residuals_batch` (exact residuals of K perturbed copies, for the
batched Monte Carlo re-solve of :func:`mtmetrology.optimize.chord_batch`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.kinematics.machine import Machine

__all__ = ["BallCentreProblem", "ScaleBar", "senses_from_sequence"]


@dataclass(frozen=True)
class ScaleBar:
    """A calibrated distance between two probed balls.

    Attributes
    ----------
    ends : (str, str)
        Ball ids of the two ends.
    length : float
        Calibrated centre-to-centre length, mm.
    u : float
        Standard uncertainty of the length, mm.
    """

    ends: tuple[str, str]
    length: float
    u: float

    def __post_init__(self):
        if not (self.length > 0 and np.isfinite(self.length)):
            raise InputError(f"scale bar length must be positive, got {self.length}")
        if not (self.u > 0 and np.isfinite(self.u)):
            raise InputError(f"scale bar uncertainty u must be positive, got {self.u}")
        if self.ends[0] == self.ends[1]:
            raise InputError(f"scale bar ends must be two different balls, got {self.ends}")


def senses_from_sequence(readings: np.ndarray, initial: float = 1.0) -> np.ndarray:
    """Sense of motion of every axis from the order of the probings.

    The sense of axis k at probing i is the sign of the last non-zero move of that axis
    before (or at) i; ``initial`` before the first move.  Reversal terms need both senses
    in the data to be identifiable.

    Parameters
    ----------
    readings : ndarray, shape (n, n_axes)
        Readings in probing order.

    Returns
    -------
    ndarray, shape (n, n_axes) of ±1
    """
    q = np.asarray(readings, dtype=float)
    steps = np.diff(q, axis=0, prepend=q[:1])
    out = np.empty_like(q)
    current = np.full(q.shape[1], float(initial))
    for i in range(q.shape[0]):
        moved = steps[i] != 0
        current = np.where(moved, np.sign(steps[i]), current)
        out[i] = current
    return out


class BallCentreProblem:
    """Weighted least-squares problem of ball-centre indications.

    Parameters
    ----------
    machine : Machine
        Machine with its active error parameters (the identified unknowns).
    readings : ndarray, shape (n, n_axes)
        Ball-centre indications in internal units (mm, rad).
    balls : sequence of str, length n
        Ball id of each indication.
    senses : ndarray, shape (n, n_axes), optional
        Sense of motion per axis (needed for reversal terms).
    scale_bars : sequence of ScaleBar
    estimate_tool : bool
        Add the three tool-vector corrections to the unknowns (identifiable only with
        spindle indexing, e.g. S = 90°, 180°, 270°).
    sigma : float
        Standard uncertainty of one indication coordinate, mm (row weight 1/σ); required,
        because it sets the weight of the indications against the scale bar and the scale
        of the covariance.
    tool_prior : float or (3,) floats, optional
        Standard uncertainty u_t (mm) of each component of the tool vector about its
        prior value (one value for the three components, or x, y, z); needs
        ``estimate_tool``.  Adds the rows ``(t0 + Δt − t̄)/u_t`` and the inputs t̄.
    tool_prior_value : (3,) floats, optional
        The prior's value t̄ of the tool vector, mm; the machine's nominal tool by default.
    tools : ndarray, shape (n_tools, 3), optional
        Nominal vectors of several tools (e.g. two stylus lengths), mm; the machine's tool
        by default.  With ``estimate_tool`` each tool has its own three corrections
        (``tool <k> x|y|z``, k = 1, 2, ...): a second stylus length separates the errors one
        length leaves confounded with the gains (e.g. E_AY1 ~ E_YY1, Alami Mchichi (2018)
        Table 4.4).  No tool prior with several tools.
    tool_index : sequence of int, length n, optional
        Tool (row of ``tools``) of each indication; all the first by default.

    Attributes
    ----------
    names : tuple of str
        Unknowns: machine parameters, ``ball <id> x|y|z``, ``tool x|y|z``.
    ball_ids : tuple of str
        Distinct balls in order of first appearance.
    """

    def __init__(
        self,
        machine: Machine,
        readings: np.ndarray,
        balls: Sequence[str],
        *,
        senses: np.ndarray | None = None,
        scale_bars: Sequence[ScaleBar] = (),
        estimate_tool: bool = False,
        sigma: float,
        tool_prior=None,
        tool_prior_value=None,
        tools=None,
        tool_index=None,
    ):
        q = np.asarray(readings, dtype=float)
        if q.ndim != 2 or q.shape[1] != machine.n_axes:
            raise InputError(
                f"readings must be (n, {machine.n_axes}) for axes {''.join(machine.axis_names)}"
            )
        balls = [str(b) for b in balls]
        if len(balls) != q.shape[0]:
            raise InputError(f"{len(balls)} ball ids for {q.shape[0]} indications")
        if not (sigma > 0):
            raise InputError(f"sigma must be positive, got {sigma}")
        self.machine = machine
        self.readings = q
        self.senses = None if senses is None else np.asarray(senses, dtype=float)
        self.ball_ids = tuple(dict.fromkeys(balls))
        self._ball_index = np.array([self.ball_ids.index(b) for b in balls])
        for bar in scale_bars:
            for end in bar.ends:
                if end not in self.ball_ids:
                    raise InputError(f"scale bar end {end!r} is not among the probed balls")
        self.scale_bars = tuple(scale_bars)
        self.estimate_tool = estimate_tool
        self.sigma = float(sigma)
        self.tool_prior, self.tool_prior_value = _tool_prior(
            machine, estimate_tool, tool_prior, tool_prior_value
        )
        self.tools, self.tool_index = _tools(machine, q.shape[0], tools, tool_index)
        if len(self.tools) > 1 and tool_prior is not None:
            raise InputError("a tool prior applies to one tool: give it with a single tool")
        self._row_tool = self.tools[self.tool_index]
        self.n_params = machine.n_params
        self.n_balls = len(self.ball_ids)
        self._linear = np.array(
            [i for i, a in enumerate(machine.axis_names) if a in machine.linear_axes]
        )
        ball_names = [f"ball {b} {c}" for b in self.ball_ids for c in "xyz"]
        labels = (
            ["tool"] if len(self.tools) == 1 else [f"tool {k + 1}" for k in range(len(self.tools))]
        )
        tool_names = [f"{t} {c}" for t in labels for c in "xyz"] if estimate_tool else []
        self.names = (*machine.parameter_names, *ball_names, *tool_names)

    @property
    def n_unknowns(self) -> int:
        return len(self.names)

    @property
    def n_prior(self) -> int:
        """Rows (and inputs) of the tool prior: 3 with a prior, else 0."""
        return 0 if self.tool_prior is None else 3

    @property
    def n_rows(self) -> int:
        return 3 * self.readings.shape[0] + len(self.scale_bars) + self.n_prior

    @property
    def residual_rounding(self) -> float:
        """Rounding unit of one weighted residual: eps × the largest coordinate / σ (a
        residual is a difference of positions of that size)."""
        size = max(float(np.abs(self.readings).max(initial=0.0)), 1.0)
        return float(np.finfo(float).eps) * size / self.sigma

    @property
    def n_inputs(self) -> int:
        """Linear-axis readings of every indication, the bar lengths, the tool prior's value."""
        return self.readings.shape[0] * self._linear.size + len(self.scale_bars) + self.n_prior

    def input_estimate(self) -> np.ndarray:
        """The inputs z (n_inputs,): linear readings (indication-major, mm), bar lengths (mm),
        the tool prior's value t̄ (mm, with a prior)."""
        lengths = [bar.length for bar in self.scale_bars]
        prior = [] if self.tool_prior is None else self.tool_prior_value
        return np.concatenate([self.readings[:, self._linear].ravel(), lengths, prior])

    def input_uncertainties(self) -> np.ndarray:
        """Standard uncertainties (mm) of the inputs after the readings: bar lengths, then
        the tool prior's components."""
        prior = [] if self.tool_prior is None else self.tool_prior
        return np.concatenate([[bar.u for bar in self.scale_bars], prior])

    def input_names(self) -> list[str]:
        """Names of the inputs, e.g. ``indication 3 (ball 2) Y`` and ``scale bar SB1-SB2``."""
        axes = [self.machine.axis_names[i] for i in self._linear]
        names = [
            f"indication {k + 1} (ball {self.ball_ids[b]}) {a}"
            for k, b in enumerate(self._ball_index)
            for a in axes
        ]
        names += [f"scale bar {bar.ends[0]}-{bar.ends[1]}" for bar in self.scale_bars]
        return names + ([f"tool prior {c}" for c in "xyz"] if self.n_prior else [])

    def input_jacobian(self, x: np.ndarray) -> np.ndarray:
        """∂r/∂z (n_rows, n_inputs) of the weighted residuals with respect to the inputs.

        Block diagonal: ``∂p/∂q_lin / σ`` (3×3, the machine's axis Jacobian) for each
        indication, ``−1/u_L`` for each bar length, ``−1/u_t`` for each component of the
        tool prior's value.
        """
        theta, _, dtool = self.split(np.asarray(x, dtype=float))
        d_axes = self.machine.evaluate(
            self.readings, theta, senses=self.senses, tool=self._tool_of_rows(dtool), d_axes=True
        ).d_axes[:, :, self._linear]  # (n, 3, 3)
        n, nl = self.readings.shape[0], self._linear.size
        jac = np.zeros((self.n_rows, self.n_inputs))
        rows = 3 * np.arange(n)[:, None, None] + np.arange(3)[None, :, None]
        cols = nl * np.arange(n)[:, None, None] + np.arange(nl)[None, None, :]
        jac[rows, cols] = d_axes / self.sigma
        for k, bar in enumerate(self.scale_bars):
            jac[3 * n + k, n * nl + k] = -1.0 / bar.u
        if self.n_prior:
            rows = self.n_rows - 3 + np.arange(3)
            jac[rows, self.n_inputs - 3 + np.arange(3)] = -1.0 / self.tool_prior
        return jac

    def with_inputs(self, inputs: np.ndarray) -> BallCentreProblem:
        """The same problem with other inputs z (n_inputs,): linear readings, bar lengths,
        tool prior's value."""
        z = np.asarray(inputs, dtype=float)
        if z.shape != (self.n_inputs,):
            raise ValueError(f"inputs must have shape ({self.n_inputs},), got {z.shape}")
        n, nl = self.readings.shape[0], self._linear.size
        q = self.readings.copy()
        q[:, self._linear] = z[: n * nl].reshape(n, nl)
        bars = [
            ScaleBar(bar.ends, float(z[n * nl + k]), bar.u) for k, bar in enumerate(self.scale_bars)
        ]
        return BallCentreProblem(
            self.machine,
            q,
            [self.ball_ids[i] for i in self._ball_index],
            senses=self.senses,
            scale_bars=bars,
            estimate_tool=self.estimate_tool,
            sigma=self.sigma,
            tool_prior=self.tool_prior,
            tool_prior_value=z[self.n_inputs - 3 :] if self.n_prior else None,
            tools=self.tools,
            tool_index=self.tool_index,
        )

    def residuals_batch(self, x: np.ndarray, inputs: np.ndarray | None = None) -> np.ndarray:
        """Weighted residuals of K copies of the problem, each with its own unknowns and inputs.

        Parameters
        ----------
        x : ndarray, shape (K, n_unknowns)
        inputs : ndarray, shape (K, n_inputs), optional
            Perturbed inputs (see :meth:`input_estimate`); the problem's own when omitted.

        Returns
        -------
        ndarray, shape (K, n_rows)
            The residuals :meth:`evaluate` gives for each copy, computed by the
            kinematic engine over all (copy, indication) pairs at once, in blocks of its
            block size.
        """
        x = np.asarray(x, dtype=float)
        z = self.input_estimate()[None] if inputs is None else np.asarray(inputs, dtype=float)
        z = np.broadcast_to(z, (x.shape[0], z.shape[1]))
        # blocks of copies whose (copy, indication) pairs fit one block of the kinematic
        # engine: it then broadcasts the parameters instead of copying them per point
        n = self.readings.shape[0]
        block = getattr(self.machine.chain, "chunk_size", 16384)
        step = max(1, block // max(n, 1))
        r = np.empty((x.shape[0], self.n_rows))
        for start in range(0, x.shape[0], step):
            part = slice(start, start + step)
            r[part] = self._residuals_block(x[part], z[part])
        return r

    def _residuals_block(self, x: np.ndarray, z: np.ndarray) -> np.ndarray:
        k, n = x.shape[0], self.readings.shape[0]
        p, nb = self.n_params, self.n_balls
        lin = z[:, : n * self._linear.size].reshape(k, n, -1)
        nt = len(self.tools)
        dtool = x[:, p + 3 * nb :] if self.estimate_tool else np.zeros((k, 3 * nt))
        tool = self.tools[None] + dtool.reshape(k, nt, 3)  # (k, n_tools, 3)
        # the rotary readings are not inputs: their rotations are computed once per pose
        pos = self.machine.chain.positions_shared_poses(
            self.readings,
            self._linear,
            lin,
            x[:, :p],
            senses=self.senses,
            tool=tool[:, self.tool_index] if nt > 1 else tool,
        )  # (k, n, 3)
        centres = x[:, p : p + 3 * nb].reshape(k, nb, 3)
        r = np.empty((k, self.n_rows))
        r[:, : 3 * n] = ((pos - centres[:, self._ball_index]) / self.sigma).reshape(k, 3 * n)
        lengths = z[:, n * self._linear.size :]
        for j, bar in enumerate(self.scale_bars):
            a, b = (self.ball_ids.index(e) for e in bar.ends)
            dist = np.linalg.norm(centres[:, a] - centres[:, b], axis=1)
            r[:, 3 * n + j] = (dist - lengths[:, j]) / bar.u
        if self.n_prior:
            r[:, -3:] = (tool[:, 0] - z[:, -3:]) / self.tool_prior
        return r

    def split(self, x: np.ndarray):
        """(θ, ball centres (n_balls, 3), tool correction) from the unknown vector: the
        correction is (3,) with one tool, (n_tools, 3) with several."""
        p, nb = self.n_params, self.n_balls
        theta = x[:p]
        centres = x[p : p + 3 * nb].reshape(nb, 3)
        dtool = x[p + 3 * nb :] if self.estimate_tool else np.zeros(3 * len(self.tools))
        return theta, centres, dtool.reshape(-1, 3) if len(self.tools) > 1 else dtool.reshape(3)

    def _tool_of_rows(self, dtool: np.ndarray) -> np.ndarray:
        """(n, 3) tool vector of each indication: nominal plus its tool's correction."""
        return self._row_tool + np.reshape(dtool, (-1, 3))[self.tool_index]

    def initial(self, params: np.ndarray | None = None) -> np.ndarray:
        """Starting point: given (or zero) errors, each ball at the mean of its nominal
        predicted positions (Sepahi Boroujeni (2021), Ch. 5), zero tool correction."""
        theta = np.zeros(self.n_params) if params is None else np.asarray(params, dtype=float)
        pos = self.machine.forward(self.readings, theta, senses=self.senses, tool=self._row_tool)
        centres = np.zeros((self.n_balls, 3))
        for i in range(self.n_balls):
            centres[i] = pos[self._ball_index == i].mean(axis=0)
        parts = [theta, centres.ravel()]
        if self.estimate_tool:
            parts.append(np.zeros(3 * len(self.tools)))
        return np.concatenate(parts)

    def evaluate(self, x: np.ndarray, jacobian: bool = True):
        """Weighted residuals (n_rows,) and, optionally, their Jacobian (n_rows, n_unknowns)."""
        theta, centres, dtool = self.split(np.asarray(x, dtype=float))
        ev = self.machine.evaluate(
            self.readings,
            theta,
            senses=self.senses,
            tool=self._tool_of_rows(dtool),
            d_params=jacobian,
            d_tool=jacobian and self.estimate_tool,
        )
        n = self.readings.shape[0]
        r_coord = (ev.position - centres[self._ball_index]) / self.sigma  # (n, 3)
        r_bar = np.empty(len(self.scale_bars))
        for k, bar in enumerate(self.scale_bars):
            a, b = (self.ball_ids.index(e) for e in bar.ends)
            r_bar[k] = (np.linalg.norm(centres[a] - centres[b]) - bar.length) / bar.u
        r_prior = []
        if self.n_prior:
            r_prior = (self.tools[0] + dtool - self.tool_prior_value) / self.tool_prior
        r = np.concatenate([r_coord.ravel(), r_bar, r_prior])
        if not jacobian:
            return r, None
        jac = np.zeros((self.n_rows, self.n_unknowns))
        p = self.n_params
        jac[: 3 * n, :p] = ev.d_params.reshape(3 * n, p) / self.sigma
        rows = np.arange(3 * n)
        cols = p + 3 * np.repeat(self._ball_index, 3) + np.tile(np.arange(3), n)
        jac[rows, cols] = -1.0 / self.sigma
        if self.estimate_tool:
            first = p + 3 * self.n_balls + 3 * self.tool_index  # each row's tool columns
            cols = first[:, None, None] + np.arange(3)[None, None, :]
            rows = 3 * np.arange(n)[:, None, None] + np.arange(3)[None, :, None]
            jac[rows, cols] = ev.d_tool / self.sigma
        for k, bar in enumerate(self.scale_bars):
            a, b = (self.ball_ids.index(e) for e in bar.ends)
            diff = centres[a] - centres[b]
            unit = diff / np.linalg.norm(diff)
            jac[3 * n + k, p + 3 * a : p + 3 * a + 3] = unit / bar.u
            jac[3 * n + k, p + 3 * b : p + 3 * b + 3] = -unit / bar.u
        if self.n_prior:
            jac[-3:, -3:] = np.diag(1.0 / self.tool_prior)
        return r, jac


def _tools(machine: Machine, n: int, tools, tool_index):
    """Validated (tools (n_tools, 3), tool_index (n,)) of a problem."""
    t = machine.tool[None] if tools is None else np.asarray(tools, dtype=float)
    if t.ndim != 2 or t.shape[1] != 3 or len(t) == 0 or not np.all(np.isfinite(t)):
        raise InputError(f"tools must be (n_tools, 3) finite vectors (mm), got shape {t.shape}")
    idx = np.zeros(n, dtype=int) if tool_index is None else np.asarray(tool_index)
    if idx.shape != (n,) or not np.issubdtype(idx.dtype, np.integer):
        raise InputError(f"tool_index must give one integer per indication ({n})")
    if n and (idx.min() < 0 or idx.max() >= len(t)):
        raise InputError(f"tool_index must lie in 0..{len(t) - 1}")
    unused = sorted(set(range(len(t))) - set(idx.tolist()))
    if unused:
        raise InputError(f"tool(s) {', '.join(str(k + 1) for k in unused)} never used")
    return t, idx


def _tool_prior(machine: Machine, estimate_tool: bool, u, value):
    """Validated (u_t (3,), t̄ (3,)) of a tool prior, mm; (None, None) without one."""
    if u is None:
        if value is not None:
            raise InputError("tool_prior_value needs tool_prior (its standard uncertainty)")
        return None, None
    if not estimate_tool:
        raise InputError("a tool prior needs the tool vector among the unknowns (estimate_tool)")
    u = np.asarray(u, dtype=float).ravel()
    if u.size not in (1, 3):
        raise InputError(f"tool prior: give one standard uncertainty or three (x, y, z), got {u}")
    u = np.broadcast_to(u, (3,)).copy()
    if not np.all(np.isfinite(u) & (u > 0)):
        raise InputError(f"tool prior standard uncertainties must be positive and finite, got {u}")
    t = machine.tool if value is None else np.asarray(value, dtype=float)
    if t.shape != (3,) or not np.all(np.isfinite(t)):
        raise InputError(f"tool prior value must be 3 finite coordinates (mm), got {t}")
    return u, np.array(t, dtype=float)
