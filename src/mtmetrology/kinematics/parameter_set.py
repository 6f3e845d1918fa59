"""Parameter sets: names, values with units, covariance and provenance (JSON or YAML).

The file form follows ARCHITECTURE.md::

    {"kind": "parameter-set", "version": 1,
     "machine": "five-axis-wcbxfzyst", "model": "13",
     "parameters": [{"name": "E_X0C", "value": -104.59, "unit": "µm", "u": 0.48}, ...],
     "covariance": {"names": [...], "matrix": [[...]]},      # in the listed units
     "tool_mm": [0.0, 0.0, -150.0],                           # optional: a calibrated tool
     "provenance": {...}}

Values are converted to internal units on reading (µm -> mm, µrad -> rad, µm/m -> 1)
and back on writing; a unit whose dimension does not fit the parameter is an error. The
covariance is accepted when symmetric to 1e-9 of its largest entry and symmetrised
(:mod:`mtmetrology.io.covariance`); it is written exactly symmetric.

Reading is strict, because a parameter set moves a machine: ``kind`` must be
``parameter-set`` (or a calibration result that embeds one, :data:`RESULT_KINDS`, whose
other keys belong to that result), ``version`` must be 1, ``machine`` must name the machine
the set is applied to, ``model`` (when given) must be one of its error models, values must
be JSON/YAML numbers (``true`` or ``"12.5"`` are refused) within :data:`MAX_MAGNITUDE` of
their customary unit, and unknown keys are errors.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from mtmetrology.display import NotebookRepr
from mtmetrology.errors import InputError
from mtmetrology.io.covariance import symmetric, symmetric_covariance
from mtmetrology.io.documents import load_document
from mtmetrology.io.files import InputFileError, atomic_write
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameters import ParameterNameError, parse_parameter
from mtmetrology.units import UnitError, parse_unit

__all__ = ["KIND", "RESULT_KINDS", "ParameterSet"]

KIND = "parameter-set"
VERSION = 1
#: Result documents that embed a parameter set (``mtm predict --params`` reads them as they
#: are); their keys beyond the parameter set are the result's own.
RESULT_KINDS = (
    "samba-calibration",
    "ballplate-calibration",
    "tracker-calibration",
    "iso230-2-positioning",
    "iso230-4-calibration",
    "r-test",
)
_KEYS = {"kind", "version", "machine", "model", "parameters", "covariance", "tool_mm", "provenance"}
_ENTRY_KEYS = {"name", "value", "unit", "u"}
#: Largest magnitude of a parameter in its customary unit (1 m in µm, 1 rad in µrad): far
#: beyond any machine error, and far below values that overflow the kinematic chain.
MAX_MAGNITUDE = 1e6


def _number(value: object, where: str) -> float:
    """A finite JSON/YAML number; booleans and strings are refused."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InputFileError(f"{where}: {value!r} is not a number")
    v = float(value)
    if not math.isfinite(v):
        raise InputFileError(f"{where}: {value!r} is not finite")
    return v


@dataclass(frozen=True)
class ParameterSet(NotebookRepr):
    """Error-parameter values of a machine, never a bare vector.

    Attributes
    ----------
    names : tuple of str
    values : ndarray, shape (n,)
        Internal units (mm, rad, dimensionless, ...).
    units : tuple of str
        Customary unit of each parameter (µm, µrad, µm/m, ...), used in files.
    covariance : ndarray, shape (n, n) or None
        Internal units.
    provenance : dict
    machine : str or None
        Name of the machine the set belongs to (its definition's ``name``).
    model : str or None
        The machine's error model the set was made with, when it was a named model.
    tool : ndarray, shape (3,) or None
        Tool (stylus-centre) vector identified with the parameters (e.g. SAMBA
        ``--estimate-tool``), mm; :meth:`machine_for` puts it on the machine, so what the
        calibration identified, compensation uses. None: the machine's nominal tool.
    """

    names: tuple[str, ...]
    values: np.ndarray
    units: tuple[str, ...]
    covariance: np.ndarray | None = None
    provenance: dict = field(default_factory=dict)
    machine: str | None = None
    model: str | None = None
    tool: np.ndarray | None = None

    def __repr__(self) -> str:
        """The values and u in their customary units (µm, µrad, µm/m), GUM 7.2.6 digits."""
        from mtmetrology.formatting import format_parameters

        f = self.scales()
        u = self.standard_uncertainty
        lines = format_parameters(
            self.names, self.values / f, None if u is None else u / f, self.units
        )
        head = ", ".join(
            f"{k}={v!r}" for k, v in (("machine", self.machine), ("model", self.model)) if v
        )
        what = f"{len(self.names)} parameters" + ("" if u is not None else ", no covariance")
        return f"ParameterSet({head + ', ' if head else ''}{what}:\n  " + "\n  ".join(lines) + ")"

    @property
    def standard_uncertainty(self) -> np.ndarray | None:
        """Square roots of the covariance diagonal (internal units), None without one."""
        if self.covariance is None:
            return None
        return np.sqrt(np.diag(self.covariance))

    @classmethod
    def zeros(cls, machine: Machine) -> ParameterSet:
        """Zero errors for every active parameter of ``machine``."""
        return cls(
            machine.parameter_names,
            np.zeros(machine.n_params),
            machine.parameter_units,
            machine=machine.name,
            model=machine.model_name,
        )

    def machine_for(self, base: Machine) -> Machine:
        """``base`` with exactly these parameters active, under the set's error model.

        The named model of the set is activated first (its basis defines what the
        coefficients mean), then the parameter list is matched; a calibrated tool vector
        replaces the nominal one.

        Raises
        ------
        InputFileError
            If the set was made for another machine.
        """
        self.check_machine(base)
        if self.model is not None and base.spec is not None and base.model_name != self.model:
            base = Machine.from_spec(base.spec, model=self.model, source=base.name)
        if base.parameter_names != self.names:
            base = base.with_parameters(self.names)
        return base if self.tool is None else base.with_tool(self.tool)

    def check_machine(self, machine: Machine, source: str = "parameter set") -> None:
        """Refuse a set made for another machine or model."""
        if self.machine is not None and self.machine != machine.name:
            raise InputFileError(
                f"{source}: made for machine {self.machine!r}, not {machine.name!r}"
            )
        if (
            self.model is not None
            and machine.spec is not None
            and self.model not in machine.spec.error_models
        ):
            raise InputFileError(
                f"{source}: error model {self.model!r} is not a model of {machine.name} "
                f"(models: {', '.join(machine.spec.error_models)})"
            )

    def scales(self) -> np.ndarray:
        """Factors from the customary units to internal units."""
        return np.array([parse_unit(u).factor for u in self.units])

    def to_document(self) -> dict:
        """The JSON-ready document with values in customary units."""
        f = self.scales()
        u = self.standard_uncertainty
        params = []
        for i, n in enumerate(self.names):
            entry = {"name": n, "value": float(self.values[i] / f[i]), "unit": self.units[i]}
            if u is not None:
                entry["u"] = float(u[i] / f[i])
            params.append(entry)
        doc: dict = {"kind": KIND, "version": VERSION}
        if self.machine is not None:
            doc["machine"] = self.machine
        if self.model is not None:
            doc["model"] = self.model
        doc["parameters"] = params
        if self.covariance is not None:
            doc["covariance"] = {
                "names": list(self.names),
                "matrix": (symmetric(self.covariance) / np.outer(f, f)).tolist(),
            }
        if self.tool is not None:
            doc["tool_mm"] = [float(v) for v in self.tool]
        if self.provenance:
            doc["provenance"] = self.provenance
        return doc

    def save(self, path: str | Path) -> None:
        """Write JSON (``.json``) or YAML (``.yaml``/``.yml``) atomically.

        Raises
        ------
        InputError
            A value or covariance entry that is not finite (NaN is never a result; YAML
            would write it as ``.nan``), naming the parameter; nothing is written.
        """
        p = Path(path)
        bad = [n for n, v in zip(self.names, self.values, strict=True) if not math.isfinite(v)]
        if self.covariance is not None:
            rows = ~np.all(np.isfinite(self.covariance), axis=1)
            bad += [f"covariance row {n}" for n, r in zip(self.names, rows, strict=True) if r]
        if bad:
            raise InputError(f"{p}: {bad[0]} is not finite; nothing written")
        doc = self.to_document()
        text = (
            yaml.safe_dump(doc, sort_keys=False, allow_unicode=True)
            if p.suffix in (".yaml", ".yml")
            else json.dumps(doc, indent=2, ensure_ascii=False, allow_nan=False) + "\n"
        )
        with atomic_write(p) as fh:
            fh.write(text)

    @classmethod
    def from_document(
        cls, doc: object, machine: Machine, source: str = "<parameters>"
    ) -> ParameterSet:
        """Validate a parameter document against a machine's catalogue and bases.

        Raises
        ------
        InputFileError
            Naming the file, the key or parameter, and what is wrong.
        """
        if not isinstance(doc, dict):
            raise InputFileError(f"{source}: a parameter set must be a mapping")
        kind = doc.get("kind")
        if kind != KIND and kind not in RESULT_KINDS:
            raise InputFileError(
                f"{source}: kind: {kind!r} is not a parameter set (expected {KIND!r} or a "
                f"calibration result: {', '.join(RESULT_KINDS)})"
            )
        if kind == KIND:
            unknown = sorted(set(doc) - _KEYS)
            if unknown:
                raise InputFileError(f"{source}: {unknown[0]}: unknown key in a parameter set")
        version = doc.get("version")
        if isinstance(version, bool) or version != VERSION:
            raise InputFileError(f"{source}: version: {version!r} is not supported (1 is)")
        for key in ("machine", "model"):
            if key in doc and not isinstance(doc[key], str):
                raise InputFileError(f"{source}: {key}: must be a string, got {doc[key]!r}")
        if "machine" not in doc:
            raise InputFileError(
                f"{source}: machine: missing; name the machine the set belongs to "
                f"(here {machine.name!r})"
            )
        names, values, units, factors = [], [], [], []

        def misfit(detail: str) -> InputFileError:
            # A set made for another machine fails first on an axis or a unit: say so.
            if doc["machine"] == machine.name:
                return InputFileError(f"{source}: {detail}")
            return InputFileError(
                f"{source}: made for machine {doc['machine']!r}, not {machine.name!r} ({detail})"
            )

        entries = doc.get("parameters")
        if not isinstance(entries, list) or not entries:
            raise InputFileError(f"{source}: parameters: must be a non-empty list")
        for k, e in enumerate(entries):
            where = f"{source}: parameters[{k}]"
            if not isinstance(e, dict) or not {"name", "value", "unit"} <= set(e):
                raise InputFileError(f"{where}: needs 'name', 'value' and 'unit'")
            extra = sorted(set(e) - _ENTRY_KEYS)
            if extra:
                raise InputFileError(f"{where}: {extra[0]}: unknown key")
            if not isinstance(e["name"], str):
                raise InputFileError(f"{where}: name must be a string, got {e['name']!r}")
            try:
                p = parse_parameter(e["name"])
            except ParameterNameError as err:
                raise InputFileError(f"{where}: {err}") from None
            if p.axis not in machine.topology.axes:
                raise misfit(
                    f"parameters[{k}]: {p.name} refers to axis {p.axis}, not in {machine.name}"
                )
            expected = machine.unit_of(p)
            if not isinstance(e["unit"], str):
                raise InputFileError(f"{where} ({p.name}): unit must be a string")
            try:
                declared = parse_unit(e["unit"])
            except UnitError as err:
                raise InputFileError(f"{where} ({p.name}): {err}") from None
            if declared.dimension != parse_unit(expected).dimension:
                raise misfit(
                    f"parameters[{k}] ({p.name}): unit {e['unit']!r} does not fit this parameter "
                    f"(expected a unit like {expected!r})"
                )
            value = _number(e["value"], f"{where} ({p.name}): value")
            if abs(value) * declared.factor > MAX_MAGNITUDE * parse_unit(expected).factor:
                raise InputFileError(
                    f"{where} ({p.name}): value {value:g} {e['unit']} is beyond "
                    f"{MAX_MAGNITUDE:g} {expected}; no machine has such an error"
                )
            names.append(p.name)
            values.append(value * declared.factor)
            units.append(expected)
            factors.append(declared.factor)
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise InputFileError(f"{source}: parameter(s) listed twice: {', '.join(dup)}")
        # every u given is a standard uncertainty, with or without a covariance beside it
        for k, e in enumerate(entries):
            if "u" in e and _number(e["u"], f"{source}: {e['name']}: u") < 0:
                raise InputFileError(
                    f"{source}: parameters[{k}] ({e['name']}): u must be >= 0 (a standard "
                    f"uncertainty), got {e['u']!r}"
                )
        cov = None
        if doc.get("covariance") is not None:
            cov = cls._covariance(doc["covariance"], names, np.array(factors), source)
        elif any("u" in e for e in entries):
            if not all("u" in e for e in entries):
                missing = next(e["name"] for e in entries if "u" not in e)
                raise InputFileError(f"{source}: {missing}: u missing while others have one")
            u = np.array([float(e["u"]) for e in entries], dtype=float)
            cov = np.diag((u * np.array(factors)) ** 2)
        tool = None
        # A calibration result writes its tool always; it is the identified one only when
        # it says so (otherwise the nominal tool of the machine it was made on).
        if "tool_mm" in doc and (kind == KIND or doc.get("tool_estimated") is True):
            t = doc["tool_mm"]
            if not isinstance(t, list) or len(t) != 3:
                raise InputFileError(f"{source}: tool_mm: must be a list of 3 numbers (mm)")
            tool = np.array([_number(v, f"{source}: tool_mm[{i}]") for i, v in enumerate(t)])
        provenance = doc.get("provenance") or {}
        if not isinstance(provenance, dict):
            raise InputFileError(f"{source}: provenance: must be a mapping")
        pset = cls(
            tuple(names),
            np.array(values),
            tuple(units),
            cov,
            dict(provenance),
            machine=doc["machine"],
            model=doc.get("model"),
            tool=tool,
        )
        pset.check_machine(machine, source)
        return pset

    @staticmethod
    def _covariance(block, names, factors, source):
        if not isinstance(block, dict) or set(block) != {"names", "matrix"}:
            raise InputFileError(f"{source}: covariance needs exactly 'names' and 'matrix'")
        if not isinstance(block["names"], list) or not all(
            isinstance(n, str) for n in block["names"]
        ):
            raise InputFileError(f"{source}: covariance.names must be a list of names")
        cnames = [parse_parameter(n).name for n in block["names"]]
        if sorted(cnames) != sorted(names):
            raise InputFileError(f"{source}: covariance names differ from the parameter names")
        rows = block["matrix"]
        n = len(names)
        if not isinstance(rows, list) or len(rows) != n:
            raise InputFileError(f"{source}: covariance.matrix must be {n}x{n}")
        mat = np.empty((n, n))
        for i, row in enumerate(rows):
            if not isinstance(row, list) or len(row) != n:
                raise InputFileError(f"{source}: covariance.matrix row {i} must have {n} entries")
            for j, v in enumerate(row):
                mat[i, j] = _number(v, f"{source}: covariance.matrix[{i}][{j}]")
        # symmetric to 1e-9 of its largest entry, then exactly (mtmetrology.io.covariance)
        mat = symmetric_covariance(mat, f"{source}: covariance.matrix")
        order = [cnames.index(nm) for nm in names]
        mat = mat[np.ix_(order, order)]
        if np.linalg.eigvalsh(mat).min() < -1e-9 * np.abs(mat).max():
            raise InputFileError(f"{source}: covariance matrix is not positive semi-definite")
        # the matrix is in the units listed with the parameters
        return mat * np.outer(factors, factors)

    @classmethod
    def load(cls, path: str | Path, machine: Machine) -> ParameterSet:
        """Read a JSON or YAML parameter file (strict; see the module notes)."""
        doc = load_document(path, "parameter set")
        return cls.from_document(doc, machine, str(path))

    def vector_for(self, machine: Machine) -> np.ndarray:
        """Values ordered as ``machine.parameter_names`` (which must hold these names)."""
        missing = set(self.names) - set(machine.parameter_names)
        if missing:
            raise ValueError(f"machine model lacks {', '.join(sorted(missing))}")
        out = np.zeros(machine.n_params)
        for n, v in zip(self.names, self.values, strict=True):
            out[machine.parameter_names.index(n)] = v
        return out
