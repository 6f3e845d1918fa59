"""The analyses' reads of the calibration history: a machine's runs as arrays.

The control charts, the long-term covariance, the drift models and the export
(:mod:`mtmetrology.history.analysis`, :mod:`mtmetrology.history.dcc`) read through these
functions, on the ORM (:mod:`mtmetrology.history.schema`); recording, listing and showing a
run (:mod:`mtmetrology.history.records`) need none of them and import neither SQLAlchemy
nor numpy.
"""

from __future__ import annotations

from datetime import datetime

import numpy as np
from sqlalchemy import Engine, select
from sqlalchemy.orm import Session

from mtmetrology.errors import InputError
from mtmetrology.history import schema
from mtmetrology.history.records import as_instant
from mtmetrology.io.covariance import symmetric_covariance
from mtmetrology.units import parse_unit

__all__ = [
    "document_covariance",
    "export_rows",
    "machine_model",
    "machine_names",
    "parameter_matrix",
    "parameter_series",
    "run_covariances",
]


def machine_names(engine: Engine) -> list[str]:
    """Names of the machines in the history."""
    with Session(engine) as session:
        return list(session.scalars(select(schema.Machine.name).order_by(schema.Machine.name)))


def machine_model(engine: Engine, machine: str) -> str | None:
    """The error model of a machine's recorded calibrations."""
    with Session(engine) as session:
        return session.scalar(select(schema.Machine.model).where(schema.Machine.name == machine))


def _machine_id(session: Session, machine: str) -> int:
    row = session.scalar(select(schema.Machine.id).where(schema.Machine.name == machine))
    if row is None:
        known = ", ".join(session.scalars(select(schema.Machine.name))) or "none"
        raise InputError(f"machine {machine!r}: not in the history (machines: {known})")
    return row


def parameter_matrix(
    engine: Engine, machine: str, *, since: datetime | None = None
) -> tuple[list[int], list[datetime], list[str], list[str], np.ndarray]:
    """A machine's calibrations, oldest first, as arrays (one row read per run).

    Returns
    -------
    ids, dates, names, units, values
        Run ids, dates (UTC), parameter names and units (the machine's first run's order)
        and the (K, P) values in those units.
    """
    cal, par = schema.CalibrationRun, schema.RunParameter
    with Session(engine) as session:
        machine_id = _machine_id(session, machine)
        runs = select(cal.id, cal.performed_at, cal.parameter_vector).where(
            cal.machine_id == machine_id
        )
        if since is not None:
            runs = runs.where(cal.performed_at >= as_instant(since))
        runs = session.execute(runs.order_by(cal.performed_at, cal.id)).all()
        if not runs:
            return [], [], [], [], np.empty((0, 0))
        first = session.execute(
            select(par.name, par.unit).where(par.run_id == runs[0][0]).order_by(par.position)
        ).all()
    matrix = np.frombuffer(b"".join(r[2] for r in runs), dtype="<f8").reshape(len(runs), -1)
    ids = [r[0] for r in runs]
    return ids, [r[1] for r in runs], [f[0] for f in first], [f[1] for f in first], matrix


def parameter_series(
    engine: Engine, machine: str, parameter: str, *, since: datetime | None = None
) -> tuple[list[int], list[datetime], str, np.ndarray, np.ndarray]:
    """One parameter of a machine's calibrations, oldest first (one indexed query).

    Returns
    -------
    ids, dates, unit, values, u
        Run ids, dates (UTC), the unit, the (K,) values and standard uncertainties in it
        (NaN where a run has none).
    """
    cal, par = schema.CalibrationRun, schema.RunParameter
    with Session(engine) as session:
        machine_id = _machine_id(session, machine)
        query = (
            select(cal.id, cal.performed_at, par.unit, par.value, par.u)
            .join(cal, cal.id == par.run_id)
            .where(par.name == parameter, cal.machine_id == machine_id)
        )
        if since is not None:
            query = query.where(cal.performed_at >= as_instant(since))
        rows = session.execute(query.order_by(cal.performed_at, cal.id)).all()
        if not rows:
            first = session.scalar(
                select(cal.id).where(cal.machine_id == machine_id).order_by(cal.id).limit(1)
            )
            names = (
                []
                if first is None
                else list(
                    session.scalars(
                        select(par.name).where(par.run_id == first).order_by(par.position)
                    )
                )
            )
            if parameter in names:
                raise InputError(
                    f"--since {since.isoformat()}: no calibration of {machine!r} on or after it"
                )
            shown = f" ({', '.join(names[:6])}{' ...' if len(names) > 6 else ''})" if names else ""
            raise InputError(
                f"parameter {parameter!r}: not a parameter of the runs of {machine!r}{shown}"
            )
    values = np.array([r[3] for r in rows], dtype=float)
    u = np.array([np.nan if r[4] is None else r[4] for r in rows], dtype=float)
    return [r[0] for r in rows], [r[1] for r in rows], rows[0][2], values, u


def document_covariance(
    doc: dict, names: list[str], source: str = "recorded calibration"
) -> np.ndarray | None:
    """A recorded document's parameter covariance (internal units) in ``names``' order: its
    ``covariance`` block (in the units listed with the parameters), else diag(u²), else
    None.

    The block is checked and symmetrised by the one rule of every covariance reader
    (:func:`mtmetrology.io.covariance.symmetric_covariance`: ``max |C − Cᵀ| ≤ 1e-9 max |C|``,
    then ``(C + Cᵀ)/2``); an asymmetric one raises InputFileError naming ``source``.
    """
    declared = {e["name"]: parse_unit(e["unit"]).factor for e in doc["parameters"]}
    block = doc.get("covariance")
    if block is not None:
        position = [block["names"].index(n) for n in names]
        f = np.array([declared[n] for n in names])
        matrix = symmetric_covariance(block["matrix"], f"{source}: covariance.matrix")
        return matrix[np.ix_(position, position)] * np.outer(f, f)
    entries = {e["name"]: e for e in doc["parameters"]}
    if all("u" in entries[n] for n in names):
        return np.diag([(entries[n]["u"] * declared[n]) ** 2 for n in names])
    return None


def run_covariances(engine: Engine, ids: list[int], names: list[str]) -> list[np.ndarray | None]:
    """Each calibration run's own parameter covariance (internal units, ``names``' order),
    None where its document has none."""
    cal = schema.CalibrationRun
    with Session(engine) as session:
        documents = dict(session.execute(select(cal.id, cal.result).where(cal.id.in_(ids))).all())
    return [document_covariance(documents[i], names, f"run {i}") for i in ids]


def export_rows(engine: Engine, machine: str, *, since: datetime | None = None) -> list[dict]:
    """One row per calibration of ``machine``: id, date, then each parameter's value
    (column ``NAME [unit]``), oldest first — the CSV of ``mtm history export``."""
    ids, dates, names, units, matrix = parameter_matrix(engine, machine, since=since)
    columns = [f"{n} [{u}]" for n, u in zip(names, units, strict=True)]
    return [
        {
            "run": i,
            "performed_at": d.isoformat(),
            **dict(zip(columns, map(float, row), strict=True)),
        }
        for i, d, row in zip(ids, dates, matrix, strict=True)
    ]
