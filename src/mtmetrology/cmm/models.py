"""Error models of a bridge CMM and their datum (which terms are left out), chosen by rank.

Models
------
``seed``
    The source's local kinematic model (Salacheep 2016, §4.5 and Appendix 2; digest §2.6–2.7):
    the machine definition's named model ``21-chebyshev`` — positioning slopes, three
    squareness errors, rotations of degree 1 and 2 in Chebyshev polynomials of the
    normalised travel.  The source's constraints (every function zero at the origin,
    δ_xy(1) = δ_xz(1) = δ_yz(1) = 0) are built in by leaving those terms out, i.e. the
    constraints ``φ(0)ᵀc = 0`` are applied as the digest recommends, not as the source's
    "first coefficient = 0".
``full-<d>``
    All 21 functions: the 18 error motions ``E_XX … E_CZ`` of the three linear axes with
    every degree 0…d, and the squareness errors ``E_C0X`` (X to Y), ``E_A0Z`` (Z to Y),
    ``E_B0Z`` (Z to X); ``degrees`` overrides the maximum degree per function (0 drops
    the function).

Datum
-----
A plate in an unknown pose cannot tell a constant offset from a shift of the plate, nor a
global rotation of the machine's axes from a rotation of the plate: constant terms, and
the straightness slopes that are squareness or global rotations, are not identifiable
together with the plate poses.  Which ones to leave out is decided here by rank, not by a
table: on a reference design that sees every error (points spread over the whole
travel, several plate poses, five styli in different directions) the candidate columns
are taken in a fixed priority order — squareness, then motion terms by increasing degree
(positioning, then rotations, then straightness), constant terms last — and a column is
kept only if it is not a linear combination of the columns already kept and of the pose
columns.  What is dropped, and what it is confounded with, is reported.  Predictions that
are invariant under a rigid motion (lengths, compensated plate geometry) do not depend on
this choice nor on the basis; the absolute frame of the compensated coordinates is the
datum's (the machine frame in which the kept terms vanish at the reference of the basis).

References
----------
Salacheep, P. (2016). *Error Compensation and Uncertainty Evaluation of CMMs Based on
Kinematic Error Models and Gaussian Processes*. MPhil thesis, Brunel University London,
§2.3.2, §4.4.1, §4.5.
ISO 230-1:2012, §3 (error motions; squareness as the orientation of axis average lines).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mtmetrology.cmm.problem import skew
from mtmetrology.errors import InputError
from mtmetrology.kinematics.config import ErrorModelSpec
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameters import parse_parameter

__all__ = [
    "SQUARENESS",
    "Datum",
    "ModelChoice",
    "choose_datum",
    "machine_for_model",
    "parse_model",
]

AXES = "XYZ"
#: Squareness errors of the WFYXZT bridge: X to Y, Z to Y, Z to X (as the preset).
SQUARENESS = ("E_C0X", "E_A0Z", "E_B0Z")
FUNCTIONS = tuple(f"E_{c}{a}" for a in AXES for c in "XYZABC")
SEED_MODEL = "21-chebyshev"


@dataclass(frozen=True)
class ModelChoice:
    """A candidate error model.

    Attributes
    ----------
    name : str
        ``seed`` or ``full-<d>`` (with overrides appended, e.g. ``full-2[E_YX=3]``).
    degrees : dict of str to int or None
        Maximum degree per motion function (``full`` models); None for ``seed``.
    """

    name: str
    degrees: dict | None = None

    @property
    def is_seed(self) -> bool:
        return self.degrees is None


def parse_model(
    text: str, overrides: str | None = None, *, option: str = "--model", others=("auto",)
) -> ModelChoice:
    """``seed`` or ``full-<d>`` with optional per-function degrees ``"E_YX=3,E_AZ=0"``.

    ``option`` is the option the text came from and ``others`` the further words it takes
    (handled by the caller), both named in a refusal.

    Raises
    ------
    InputError
        Unknown model name, bad degree or function name.

    Examples
    --------
    >>> parse_model("full-2", "E_YX=3").degrees["E_YX"], parse_model("seed").is_seed
    (3, True)
    """
    t = text.strip()
    if t == "seed":
        if overrides:
            raise InputError("--degrees applies to a full-<d> model, not to the seed model")
        return ModelChoice("seed")
    if not t.startswith("full-") or not t[5:].isdigit() or not 1 <= int(t[5:]) <= 5:
        words = ", ".join(("seed", *others))
        raise InputError(f"{option} {text!r}: use {words} or full-<d> with d in 1..5")
    d = int(t[5:])
    degrees = dict.fromkeys(FUNCTIONS, d)
    if overrides:
        for item in overrides.split(","):
            key, _, val = item.partition("=")
            key = key.strip()
            if key not in FUNCTIONS or not val.strip().isdigit() or int(val) > 5:
                raise InputError(
                    f"--degrees {item!r}: expected FUNCTION=DEGREE with FUNCTION one of "
                    f"{', '.join(FUNCTIONS)} and DEGREE 0..5"
                )
            degrees[key] = int(val)
        t = f"{t}[{overrides.replace(' ', '')}]"
    return ModelChoice(t, degrees)


def machine_for_model(base: Machine, choice: ModelChoice, basis: str | None = None) -> Machine:
    """The machine with the candidate parameters of a model (before the datum).

    Parameters
    ----------
    base : Machine
        A bridge CMM (three linear axes) loaded from a preset or file.
    choice : ModelChoice
    basis : {"monomial", "legendre", "chebyshev"}, optional
        Basis of the error motions; the machine definition's when omitted.
    """
    if base.spec is None:
        raise InputError(f"{base.name}: a machine definition is needed to build error models")
    if choice.is_seed:
        if SEED_MODEL not in base.spec.error_models:
            raise InputError(
                f"{base.name}: the seed model needs the error model {SEED_MODEL!r} "
                f"(models: {', '.join(base.spec.error_models)})"
            )
        em = base.spec.error_models[SEED_MODEL]
        if basis is not None and basis != em.basis:
            em = em.model_copy(update={"basis": basis})
        name = SEED_MODEL
    else:
        motions = {f: list(range(d + 1)) for f, d in choice.degrees.items() if d > 0}
        em = ErrorModelSpec(
            description=f"{choice.name}: 21 error functions (bridge CMM)",
            basis=basis or base.spec.error_models.get(SEED_MODEL, ErrorModelSpec()).basis,
            motions=motions,
            parameters=list(SQUARENESS),
        )
        name = choice.name
    models = {**base.spec.error_models, name: em}
    spec = base.spec.model_copy(update={"error_models": models, "default_model": name})
    return Machine.from_spec(spec, model=name, source=base.name)


def _priority(name: str) -> tuple:
    p = parse_parameter(name)
    if p.kind == "location":
        return (0, 0, 0, name)
    if p.degree == 0:
        return (3, 0, 0, name)
    along = AXES.index(p.axis) == p.component
    kind = 0 if along else (1 if p.is_rotation else 2)
    return (1, p.degree, kind, name)


@dataclass(frozen=True)
class Datum:
    """The terms kept and dropped by :func:`choose_datum`.

    Attributes
    ----------
    kept : tuple of str
    dropped : tuple of (str, tuple of str)
        Each dropped term with the kept terms it is a combination of (besides the poses).
    """

    kept: tuple[str, ...]
    dropped: tuple[tuple[str, tuple[str, ...]], ...]

    def to_dict(self) -> dict:
        return {
            "rule": "rank on a reference design: squareness, then motions by degree "
            "(positioning, rotation, straightness), constants last; a term that is a "
            "combination of kept terms and plate poses is dropped",
            "kept": list(self.kept),
            "dropped": [{"name": n, "combination_of": list(c)} for n, c in self.dropped],
        }


def _reference_jacobian(machine: Machine) -> np.ndarray:
    """Jacobian [machine params | 6 pose columns per group] of a rich reference design."""
    rng = np.random.default_rng(20160901)  # fixed: the datum must not depend on a seed
    lo = np.array([machine.axes[a].travel[0] for a in machine.axis_names])
    hi = np.array([machine.axes[a].travel[1] for a in machine.axis_names])
    tools = np.array(
        [[0, 0, -150], [100, 0, -100], [-100, 0, -100], [0, 100, -100], [0, -100, -100]],
        dtype=float,
    )
    n_groups, n_pts = 4, 24
    blocks = []
    for g in range(n_groups):
        q = lo + (hi - lo) * (0.1 + 0.8 * rng.random((n_pts, 3)))
        qq = np.repeat(q, len(tools), axis=0)
        tt = np.tile(tools, (n_pts, 1))
        ev = machine.evaluate(qq, None, tool=tt, d_params=True)
        jp = ev.d_params.reshape(-1, machine.n_params)
        pose = np.zeros((jp.shape[0], 6 * n_groups))
        pose[:, 6 * g : 6 * g + 3] = skew(ev.position).reshape(-1, 3)
        pose[:, 6 * g + 3 : 6 * g + 6] = -np.tile(np.eye(3), (qq.shape[0], 1))
        blocks.append(np.hstack([jp, pose]))
    return np.vstack(blocks)


def choose_datum(machine: Machine, rtol: float = 1e-7, prefer=()) -> Datum:
    """Keep the candidate terms that are independent of the kept ones and of the poses.

    Parameters
    ----------
    machine : Machine
        A bridge CMM with its candidate parameters active.
    rtol : float
        A column whose component orthogonal to the kept columns has a norm below ``rtol``
        (columns scaled to unit norm) is dependent.
    prefer : sequence of str
        Terms taken before all others (an equivalent datum, e.g. straightness slopes
        instead of squareness errors).

    Returns
    -------
    Datum
    """
    jac = _reference_jacobian(machine)
    n = machine.n_params
    jac = jac / np.where((norms := np.linalg.norm(jac, axis=0)) > 0, norms, 1.0)
    q, _ = np.linalg.qr(jac[:, n:])
    basis = [q]
    kept: list[int] = []
    dropped_idx: list[int] = []
    names = machine.parameter_names
    order = sorted(range(n), key=lambda j: (names[j] not in prefer, _priority(names[j])))
    for j in order:
        c = jac[:, j].copy()
        for _ in range(2):  # twice is enough (Gram–Schmidt re-orthogonalisation)
            for b in basis:
                c -= b @ (b.T @ c)
        if np.linalg.norm(c) > rtol:
            kept.append(j)
            basis.append((c / np.linalg.norm(c))[:, None])
        else:
            dropped_idx.append(j)
    dropped: list[tuple[str, tuple[str, ...]]] = []
    if dropped_idx:
        a = jac[:, [*kept, *range(n, jac.shape[1])]]
        coef = np.linalg.lstsq(a, jac[:, dropped_idx], rcond=None)[0][: len(kept)]
        for k, j in enumerate(dropped_idx):
            ck = np.abs(coef[:, k])
            big = ck > 1e-6 * max(ck.max(initial=0.0), 1e-300)
            partners = tuple(machine.parameter_names[kept[i]] for i in np.flatnonzero(big))
            dropped.append((machine.parameter_names[j], partners))
    kept_names = tuple(machine.parameter_names[j] for j in sorted(kept))
    return Datum(kept_names, tuple(dropped))
