"""Parameter sets: names, values with units, covariance and provenance (JSON or YAML).

The file form follows ARCHITECTURE.md::

    {"kind": "parameter-set", "version": 1,
     "machine": "five-axis-wcbxfzyst", "model": "13",
     "parameters": [{"name": "E_X0C", "value": -104.59, "unit": "µm", "u": 0.48}, ...],
     "covariance": {"names": [...], "matrix": [[...]]},      # in the listed units
     "provenance": {...}}

Values are converted to internal units on reading (µm -> mm, µrad -> rad, µm/m -> 1)
and back on writing; a unit whose dimension does not fit the parameter is an error.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from mtmetrology.io.documents import load_document
from mtmetrology.io.files import InputFileError, atomic_write
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameters import ParameterNameError, parse_parameter
from mtmetrology.units import UnitError, parse_unit

__all__ = ["ParameterSet"]


@dataclass(frozen=True)
class ParameterSet:
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
    """

    names: tuple[str, ...]
    values: np.ndarray
    units: tuple[str, ...]
    covariance: np.ndarray | None = None
    provenance: dict = field(default_factory=dict)

    @property
    def standard_uncertainties(self) -> np.ndarray | None:
        if self.covariance is None:
            return None
        return np.sqrt(np.diag(self.covariance))

    @classmethod
    def zeros(cls, machine: Machine) -> ParameterSet:
        return cls(machine.parameter_names, np.zeros(machine.n_params), machine.parameter_units)

    def machine(self, base: Machine) -> Machine:
        """``base`` with exactly these parameters active (same geometry and bases)."""
        if base.parameter_names == self.names:
            return base
        return base.with_parameters(self.names)

    def scales(self) -> np.ndarray:
        return np.array([parse_unit(u).factor for u in self.units])

    def to_document(self) -> dict:
        """The JSON-ready document with values in customary units."""
        f = self.scales()
        u = self.standard_uncertainties
        params = []
        for i, n in enumerate(self.names):
            entry = {"name": n, "value": float(self.values[i] / f[i]), "unit": self.units[i]}
            if u is not None:
                entry["u"] = float(u[i] / f[i])
            params.append(entry)
        doc: dict = {"kind": "parameter-set", "version": 1, "parameters": params}
        if self.covariance is not None:
            doc["covariance"] = {
                "names": list(self.names),
                "matrix": (self.covariance / np.outer(f, f)).tolist(),
            }
        if self.provenance:
            doc["provenance"] = self.provenance
        return doc

    def save(self, path: str | Path) -> None:
        """Write JSON (``.json``) or YAML (``.yaml``/``.yml``) atomically."""
        p = Path(path)
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
            Naming the file, the parameter and what is wrong.
        """
        if not isinstance(doc, dict):
            raise InputFileError(f"{source}: a parameter set must be a mapping")
        entries = doc.get("parameters")
        if not isinstance(entries, list) or not entries:
            raise InputFileError(f"{source}: 'parameters' must be a non-empty list")
        names, values, units = [], [], []
        for k, e in enumerate(entries):
            where = f"{source}: parameters[{k}]"
            if not isinstance(e, dict) or "name" not in e or "value" not in e:
                raise InputFileError(f"{where}: needs 'name', 'value' and 'unit'")
            try:
                p = parse_parameter(str(e["name"]))
            except ParameterNameError as err:
                raise InputFileError(f"{where}: {err}") from None
            if p.axis not in machine.topology.axes:
                raise InputFileError(
                    f"{where}: {p.name} refers to axis {p.axis}, not in {machine.name}"
                )
            expected = machine.unit_of(p)
            unit = str(e.get("unit", expected))
            try:
                declared = parse_unit(unit)
            except UnitError as err:
                raise InputFileError(f"{where} ({p.name}): {err}") from None
            if declared.dimension != parse_unit(expected).dimension:
                raise InputFileError(
                    f"{where} ({p.name}): unit {unit!r} does not fit this parameter "
                    f"(expected a unit like {expected!r})"
                )
            try:
                value = float(e["value"])
            except (TypeError, ValueError):
                raise InputFileError(
                    f"{where} ({p.name}): value {e['value']!r} is not a number"
                ) from None
            if not np.isfinite(value):
                raise InputFileError(f"{where} ({p.name}): value is not finite")
            names.append(p.name)
            values.append(value * declared.factor)
            units.append(expected)
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise InputFileError(f"{source}: parameter(s) listed twice: {', '.join(dup)}")
        cov = None
        if doc.get("covariance") is not None:
            cov = cls._covariance(doc["covariance"], names, entries, units, source)
        elif all("u" in e for e in entries):
            u = np.array([float(e["u"]) for e in entries])
            if np.any(u < 0) or not np.all(np.isfinite(u)):
                raise InputFileError(f"{source}: standard uncertainties u must be >= 0")
            declared_f = np.array(
                [parse_unit(str(e.get("unit", units[i]))).factor for i, e in enumerate(entries)]
            )
            cov = np.diag((u * declared_f) ** 2)
        return cls(
            tuple(names),
            np.array(values),
            tuple(units),
            cov,
            dict(doc.get("provenance") or {}),
        )

    @staticmethod
    def _covariance(block, names, entries, units, source):
        if not isinstance(block, dict) or "names" not in block or "matrix" not in block:
            raise InputFileError(f"{source}: covariance needs 'names' and 'matrix'")
        cnames = [parse_parameter(str(n)).name for n in block["names"]]
        if sorted(cnames) != sorted(names):
            raise InputFileError(f"{source}: covariance names differ from the parameter names")
        try:
            mat = np.array(block["matrix"], dtype=float)
        except (TypeError, ValueError):
            raise InputFileError(f"{source}: covariance matrix is not numeric") from None
        n = len(names)
        if mat.shape != (n, n) or not np.all(np.isfinite(mat)):
            raise InputFileError(f"{source}: covariance matrix must be finite and {n}x{n}")
        if not np.allclose(mat, mat.T, rtol=1e-9, atol=0):
            raise InputFileError(f"{source}: covariance matrix is not symmetric")
        order = [cnames.index(nm) for nm in names]
        mat = mat[np.ix_(order, order)]
        if np.linalg.eigvalsh(mat).min() < -1e-9 * np.abs(mat).max():
            raise InputFileError(f"{source}: covariance matrix is not positive semi-definite")
        # the matrix is in the units listed with the parameters
        listed = np.array(
            [parse_unit(str(e.get("unit", u))).factor for e, u in zip(entries, units, strict=True)]
        )
        return mat * np.outer(listed, listed)

    @classmethod
    def load(cls, path: str | Path, machine: Machine) -> ParameterSet:
        """Read a JSON or YAML parameter file."""
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
