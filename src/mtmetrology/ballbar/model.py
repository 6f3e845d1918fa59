"""The ballbar reading as an observation of the kinematic chain (ISO 230-1 model + dynamics).

Measurement model of sample k of test t (plane axes a, b; unit vectors e_a, e_b)::

    ℓ_k = ‖p(q_k; θ, s_k) + δ_k − c_t‖ − R_t − L                        (1)

``p(q; θ, s)``
    the tool point of the machine's kinematic chain at the commanded readings q, with the
    ISO 230-1 error parameters θ and the senses of motion s (reversal terms), in the
    workpiece frame (:meth:`mtmetrology.kinematics.Machine.evaluate`; no second copy of
    the kinematics);
``c_t``
    the pivot of test t, fixed to the table (workpiece frame); its two in-plane
    coordinates are nuisance unknowns (``pivot <test> a|b``), the out-of-plane one is held
    at the nominal pivot p(q_centre; 0) because ℓ does not depend on it to first order;
``L``
    the bar's length offset (``length offset``), one for the instrument, unknown only when
    its length is not calibrated (then it confounds with an isotropic scale on one radius);
``δ_k``
    what the ballbar sees that no quasi-static error model holds:

    - **servo mismatch** ``servo_mismatch_ab`` = τ, s (shown in ms): axis b lags axis a by
      τ, ``δ = −τ v_b e_b`` with v_b the commanded velocity of b (feed F, direction d:
      v = d·F·(−sin θ e_a + cos θ e_b)).  A positive τ shortens the bar at 45°
      counter-clockwise (ℓ = −τ d F sin θ cos θ to first order) and lengthens it there
      clockwise: an ellipse at 45°/135° whose sign flips with the direction;
    - **reversal spike** ``reversal_spike_a`` = A, mm (shown in µm): at each reversal of
      axis a the axis stalls: the tool lags by A behind the new sense of motion s_a of a,
      decaying with the arc Δφ travelled after the reversal,
      ``δ = −A s_a exp(−Δφ/φ₀) e_a`` (φ₀ the stated decay arc, 3° by default).  A
      positive A is an outward spike at the quadrant crossing (ℓ = +A there).

The model assumes steady contouring over the data arc: the arc of overshoot before it
(a test condition) has already reversed each axis, so the first samples carry the sense and
the decaying spike of the reversal before them.  Senses of motion are those of the
commanded path just after the sample in the run's direction: at a reversal point the new
sense, so that reversal steps (``E_XXb``: the tool displaced by +E_XXb in the sense of
motion of X) sit at the quadrant crossings, e.g. in
the XY plane counter-clockwise ℓ = −E_XXb · sign(sin θ) cos θ: a step of 2·E_XXb at
θ = 0° and 180°.

Residuals are ``(ℓ_model − ℓ_measured)/σ``; the Jacobian is analytic: ∂ℓ/∂θ = uᵀ ∂p/∂θ,
∂ℓ/∂c = −u, ∂ℓ/∂L = −1, ∂ℓ/∂τ = −v_b (u·e_b), ∂ℓ/∂A = −s_a e^(−Δφ/φ₀) (u·e_a), with u the
unit vector from the pivot to the tool.

References
----------
ISO 230-4:2005, clauses 3 and 5 (the circular test); ISO 230-1:2012, §3 (error motions,
location errors, reversal); Kakino, Ihara & Shinohara, *Accuracy Inspection of NC Machine
Tools by Double Ball Bar Method*, Hanser 1993 (the servo-mismatch and reversal-spike
signatures).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mtmetrology.ballbar.records import BallbarTest
from mtmetrology.errors import InputError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.units import to_internal

__all__ = [
    "DEFAULT_SPIKE_DECAY_DEG",
    "DYNAMIC_UNITS",
    "BallbarProblem",
    "dynamic_names",
    "plane_model",
]

#: Decay arc φ₀ of a reversal spike, degrees of the circle.
DEFAULT_SPIKE_DECAY_DEG = 3.0
#: Display unit of each kind of dynamic term.
DYNAMIC_UNITS = {"servo_mismatch": "ms", "reversal_spike": "µm", "length": "µm"}
_EPS = 1e-9  # rad: "just after" the sample in the run's direction


def plane_model(machine: Machine, plane: str) -> list[str]:
    """The ISO 230-1 parameters of a plane's two axes a, b that a circular test sees.

    Positioning (scale) ``E_aa1``, ``E_bb1``; squareness — the orientation error about the
    plane's normal of whichever of a, b is nearer the tool in the topology (``E_C0Y`` for
    X/Y on XFYZ, as the presets name it); straightness ``E_ba2`` and ``E_ab2``; reversal
    ``E_aab`` and ``E_bbb``.

    Examples
    --------
    >>> m = Machine.from_topology("WXFYZT")
    >>> plane_model(m, "XY")
    ['E_XX1', 'E_YY1', 'E_C0Y', 'E_YX2', 'E_XY2', 'E_XXb', 'E_YYb']
    """
    from mtmetrology.ballbar.records import PLANES

    a, b = PLANES[plane]
    normal = "ABC"["XYZ".index(({"X", "Y", "Z"} - {a, b}).pop())]
    order = machine.topology.string
    later = a if order.index(a) > order.index(b) else b
    return [
        f"E_{a}{a}1",
        f"E_{b}{b}1",
        f"E_{normal}0{later}",
        f"E_{b}{a}2",
        f"E_{a}{b}2",
        f"E_{a}{a}b",
        f"E_{b}{b}b",
    ]


def dynamic_names(tests: Sequence[BallbarTest], terms: Sequence[str]) -> list[str]:
    """Names of the dynamic unknowns for the planes of ``tests``: ``servo_mismatch_ab`` per
    plane and ``reversal_spike_a`` per axis, in order of first appearance."""
    names: list[str] = []
    for t in tests:
        a, b = t.conditions.axes
        wanted = []
        if "servo" in terms:
            wanted.append(f"servo_mismatch_{a}{b}")
        if "spike" in terms:
            wanted += [f"reversal_spike_{a}", f"reversal_spike_{b}"]
        names += [n for n in wanted if n not in names]
    return names


def dynamic_scale(name: str) -> float:
    """Internal units per display unit of a dynamic or nuisance unknown."""
    if name.startswith("servo_mismatch"):
        return float(to_internal(1.0, "ms"))
    return float(to_internal(1.0, "µm"))


class _Samples:
    """The fixed geometry of one test: readings, senses, velocities, spike shapes."""

    def __init__(self, machine: Machine, test: BallbarTest, decay: float):
        c = test.conditions
        n = len(test)
        axes = machine.axis_names
        missing = [a for a in c.axes if a not in axes]
        if missing:
            raise InputError(
                f"{test.source}: the {c.plane} plane needs axis {missing[0]}, which "
                f"{machine.name} does not have"
            )
        self.columns = [axes.index(a) for a in c.axes]
        q = np.zeros((n, machine.n_axes))
        centre = np.zeros(machine.n_axes)
        for i, a in enumerate("XYZ"):
            if a in axes:
                q[:, axes.index(a)] = test.commanded[:, i]
                centre[axes.index(a)] = c.centre[i]
        self.readings = q
        self.pivot0 = machine.forward(centre)
        th, d = test.angle, test.direction
        after = th + d * _EPS
        # d(position)/dθ of the plane's axes, times dθ/dt's sign d
        rate = np.stack([-np.sin(after), np.cos(after)], axis=1) * d[:, None]
        sense = np.sign(rate)
        self.senses = np.ones((n, machine.n_axes))
        self.senses[:, self.columns] = sense
        speed = float(to_internal(c.feed, "mm/min"))
        self.velocity = speed * np.stack([-np.sin(th), np.cos(th)], axis=1) * d[:, None]
        # arc since the last reversal of each axis (a reverses at 0, π; b at π/2, 3π/2)
        since = np.stack(
            [np.mod(d * (th - r0) + _EPS, np.pi) - _EPS for r0 in (0.0, 0.5 * np.pi)], axis=1
        )
        # the stalled axis stays behind its new sense of motion: −s_a
        self.spike = -sense * np.exp(-np.maximum(since, 0.0) / decay)
        self.basis = c.basis
        self.radius = c.radius
        self.n = n


class BallbarProblem:
    """Weighted least squares of ballbar readings (model (1) of the module notes).

    Parameters
    ----------
    machine : Machine
        Its active parameters are the identified ISO 230-1 unknowns.
    tests : sequence of BallbarTest
        One or several tests (planes, radii) identified together; names must differ.
    dynamic : sequence of {"servo", "spike"}
        Dynamic terms among the unknowns.
    length_calibrated : bool
        The bar length is known (R exact); else one ``length offset`` unknown.
    sigma : float
        Standard uncertainty of one reading, mm (row weight 1/σ).
    spike_decay : float
        φ₀, rad.

    Attributes
    ----------
    names : tuple of str
        Machine parameters, dynamic terms, ``length offset``, ``pivot <test> a|b``.
    """

    def __init__(
        self,
        machine: Machine,
        tests: Sequence[BallbarTest],
        *,
        dynamic: Sequence[str] = ("servo", "spike"),
        length_calibrated: bool = True,
        sigma: float,
        spike_decay: float | None = None,
    ):
        tests = list(tests)
        if not tests:
            raise InputError("no ballbar test to identify")
        ids = [t.conditions.name for t in tests]
        if len(set(ids)) != len(ids):
            raise InputError(f"two tests share the name {next(i for i in ids if ids.count(i) > 1)}")
        unknown = sorted(set(dynamic) - {"servo", "spike"})
        if unknown:
            raise InputError(f"dynamic term {unknown[0]!r}: expected servo or spike")
        if not (np.isfinite(sigma) and sigma > 0):
            raise InputError(f"sigma must be positive, got {sigma}")
        decay = (
            float(to_internal(DEFAULT_SPIKE_DECAY_DEG, "deg"))
            if spike_decay is None
            else spike_decay
        )
        self.machine = machine
        self.tests = tests
        self.sigma = float(sigma)
        self.samples = [_Samples(machine, t, decay) for t in tests]
        self.measured = np.concatenate([t.reading for t in tests])
        self.dynamic = dynamic_names(tests, dynamic)
        self.length_calibrated = length_calibrated
        nuisance = [] if length_calibrated else ["length offset"]
        for t in tests:
            nuisance += [f"pivot {t.conditions.name} {a}" for a in t.conditions.axes]
        self.nuisance = nuisance
        self.names = (*machine.parameter_names, *self.dynamic, *nuisance)
        self.n_rows = int(self.measured.size)

    def initial(self) -> np.ndarray:
        """Zero errors, zero dynamics, nominal pivots (the commanded centres)."""
        x = np.zeros(len(self.names))
        k = self.machine.n_params + len(self.dynamic) + (0 if self.length_calibrated else 1)
        for s in self.samples:
            x[k : k + 2] = s.basis @ s.pivot0
            k += 2
        return x

    def split(self, x: np.ndarray):
        """(θ, dynamic, length offset, pivots (n_tests, 2)) from unknowns (..., n)."""
        n_p, n_d = self.machine.n_params, len(self.dynamic)
        theta = x[..., :n_p]
        dyn = x[..., n_p : n_p + n_d]
        k = n_p + n_d
        length = np.zeros(x.shape[:-1]) if self.length_calibrated else x[..., k]
        k += 0 if self.length_calibrated else 1
        pivots = x[..., k:].reshape(*x.shape[:-1], len(self.tests), 2)
        return theta, dyn, length, pivots

    def model(self, x: np.ndarray, *, jacobian: bool = False):
        """ℓ of every sample (..., m) for unknowns x (..., n), and ∂ℓ/∂x (m, n) if asked
        (only for a single x)."""
        theta, dyn, length, pivots = self.split(np.asarray(x, dtype=float))
        out, rows = [], []
        for t, s in enumerate(self.samples):
            ev = self.machine.evaluate(
                s.readings, theta[..., None, :], senses=s.senses, d_params=jacobian
            )
            delta, d_dyn = self._dynamic(t, s, dyn)
            # the in-plane pivot coordinates are unknowns, the normal one stays nominal
            pivot = s.pivot0 + (pivots[..., t, :] - s.basis @ s.pivot0) @ s.basis
            vec = ev.position + delta - pivot[..., None, :]
            dist = np.sqrt(np.einsum("...j,...j->...", vec, vec))
            out.append(dist - s.radius - length[..., None])
            if jacobian:
                u = vec / dist[..., None]
                block = np.zeros((s.n, len(self.names)))
                block[:, : self.machine.n_params] = np.einsum("kj,kjp->kp", u, ev.d_params)
                n0 = self.machine.n_params
                block[:, n0 : n0 + len(self.dynamic)] = np.einsum("kj,kjd->kd", u, d_dyn)
                if not self.length_calibrated:
                    block[:, n0 + len(self.dynamic)] = -1.0
                k = len(self.names) - 2 * (len(self.tests) - t)
                block[:, k : k + 2] = -u @ s.basis.T
                rows.append(block)
        ell = np.concatenate(out, axis=-1)
        return (ell, np.vstack(rows)) if jacobian else ell

    def _dynamic(self, t: int, s: _Samples, dyn: np.ndarray):
        """Tool displacement δ (..., m, 3) of the dynamic terms and ∂δ/∂dyn (m, 3, n_dyn)."""
        a, b = self.tests[t].conditions.axes
        d_dyn = np.zeros((s.n, 3, len(self.dynamic)))
        for i, name in enumerate(self.dynamic):
            if name == f"servo_mismatch_{a}{b}":
                d_dyn[:, :, i] = -s.velocity[:, 1:2] * s.basis[1]
            elif name == f"reversal_spike_{a}":
                d_dyn[:, :, i] = s.spike[:, 0:1] * s.basis[0]
            elif name == f"reversal_spike_{b}":
                d_dyn[:, :, i] = s.spike[:, 1:2] * s.basis[1]
        return np.tensordot(dyn, d_dyn, axes=([-1], [2])), d_dyn

    def evaluate(self, x: np.ndarray, jacobian: bool = True):
        """Weighted residuals (ℓ_model − ℓ)/σ and their Jacobian (the engine's protocol)."""
        ell, jac = self.model(x, jacobian=True)
        r = (ell - self.measured) / self.sigma
        return (r, jac / self.sigma) if jacobian else r

    def residuals_batch(self, x: np.ndarray, measured: np.ndarray) -> np.ndarray:
        """Weighted residuals of K problems with readings ``measured`` (K, m) at x (K, n)."""
        return (self.model(x) - measured) / self.sigma

    def scales(self) -> np.ndarray:
        """Internal units per display unit of every unknown (machine parameters: their
        customary units; dynamic terms: ms or µm; nuisance: µm)."""
        return np.concatenate(
            [
                self.machine.parameter_scales,
                [dynamic_scale(n) for n in self.dynamic],
                [dynamic_scale("length")] * len(self.nuisance),
            ]
        )
