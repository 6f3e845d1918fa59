"""Recording results in the calibration history and reading them back.

:func:`add_result` takes a result document of any application through its documented JSON
form (``kind`` and ``version``): a calibration (``parameter-set``, ``samba-calibration``,
``ballplate-calibration``), a task uncertainty (``uncertainty-result``) or a verification
(``length-check``, ``conformity-decision``). A calibration is checked against the machine's
definition (:meth:`ParameterSet.from_document`) and against the machine's earlier runs (the
same error model and parameter names), then stored with its parameters in one transaction,
together with one row of the audit log per result (:mod:`mtmetrology.history.audit`: who
recorded it, from which file), so that no result is recorded without its audit row.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta, timezone
from pathlib import Path
from typing import TYPE_CHECKING

from sqlalchemy import Engine, select, text
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

import mtmetrology
from mtmetrology.errors import InputError
from mtmetrology.history import schema
from mtmetrology.history.audit import audit
from mtmetrology.history.database import canonical_sha256, database_fault, writer

if TYPE_CHECKING:  # the read path (list, show) imports no machine model and no numpy
    import numpy as np

    from mtmetrology.kinematics.machine import Machine

__all__ = [
    "CALIBRATION_KINDS",
    "TASK_KINDS",
    "TEMPERATURE_RANGE_C",
    "VERIFICATION_KINDS",
    "RunRecord",
    "add_result",
    "add_results",
    "list_runs",
    "offset_minutes",
    "show_run",
]

#: mtmetrology.kinematics.parameter_set KIND and RESULT_KINDS, spelled here so that reading
#: the history does not import the kinematics (test_history_records checks they agree).
CALIBRATION_KINDS = (
    "parameter-set",
    "samba-calibration",
    "ballplate-calibration",
    "tracker-calibration",
    "iso230-2-positioning",
    "iso230-4-calibration",
    "r-test",
)
TASK_KINDS = ("uncertainty-result",)
VERIFICATION_KINDS = ("length-check", "conformity-decision", "iso230-4-circular")
#: Plausible workshop temperatures, °C (issue 32: a value outside is a unit or a typo).
TEMPERATURE_RANGE_C = (-50.0, 100.0)
_TABLES = {
    "calibration": schema.CalibrationRun,
    "task": schema.TaskResult,
    "verification": schema.VerificationResult,
}


@dataclass(frozen=True)
class RunRecord:
    """One stored result: where it sits in the history and what it said.

    Attributes
    ----------
    id : int
        The run's number in its table (``category``).
    category : {"calibration", "task", "verification"}
    machine, kind : str
    performed_at, recorded_at : datetime (UTC)
    software_version : str
    operator_note : str or None
    artefact : str or None
    temperature_c : float or None
    residual_statistics, input_hashes : dict
    content_sha256 : str
        SHA-256 of the stored document (canonical JSON).
    parameters : tuple of dict
        ``{name, unit, value, u}`` in customary units (calibrations; empty otherwise).
    result : dict
        The result document as recorded.
    """

    id: int
    category: str
    machine: str
    kind: str
    performed_at: datetime
    recorded_at: datetime
    software_version: str
    operator_note: str | None
    artefact: str | None
    temperature_c: float | None
    residual_statistics: dict
    input_hashes: dict
    content_sha256: str
    parameters: tuple[dict, ...] = ()
    result: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """The JSON form (``kind: history-run``, version 1)."""
        return {
            "kind": "history-run",
            "version": 1,
            "id": self.id,
            "category": self.category,
            "machine": self.machine,
            "result_kind": self.kind,
            "performed_at": self.performed_at.isoformat(),
            "recorded_at": self.recorded_at.isoformat(),
            "software_version": self.software_version,
            "operator_note": self.operator_note,
            "artefact": self.artefact,
            "temperature_c": self.temperature_c,
            "residual_statistics": self.residual_statistics,
            "input_hashes": self.input_hashes,
            "content_sha256": self.content_sha256,
            "parameters": list(self.parameters),
            "result": self.result,
        }

    @classmethod
    def from_dict(cls, doc: dict) -> RunRecord:
        """Inverse of :meth:`to_dict`."""
        return cls(
            id=doc["id"],
            category=doc["category"],
            machine=doc["machine"],
            kind=doc["result_kind"],
            performed_at=datetime.fromisoformat(doc["performed_at"]),
            recorded_at=datetime.fromisoformat(doc["recorded_at"]),
            software_version=doc["software_version"],
            operator_note=doc["operator_note"],
            artefact=doc["artefact"],
            temperature_c=doc["temperature_c"],
            residual_statistics=doc["residual_statistics"],
            input_hashes=doc["input_hashes"],
            content_sha256=doc["content_sha256"],
            parameters=tuple(doc["parameters"]),
            result=doc["result"],
        )


def category_of(kind: object, source: str) -> str:
    """``calibration``, ``task`` or ``verification`` for a result kind; else InputError
    (a mapping without a ``kind`` is not a result document at all)."""
    if not isinstance(kind, str):
        raise InputError(
            f"{source}: not a result document (no kind; the history records the results of "
            "the calibrate, task and verify commands)"
        )
    for category, kinds in (
        ("calibration", CALIBRATION_KINDS),
        ("task", TASK_KINDS),
        ("verification", VERIFICATION_KINDS),
    ):
        if kind in kinds:
            return category
    known = ", ".join((*CALIBRATION_KINDS, *TASK_KINDS, *VERIFICATION_KINDS))
    raise InputError(f"{source}: kind: {kind!r} is not a result the history records ({known})")


def file_sha256(path: str | Path) -> str:
    """SHA-256 of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _utc(moment: datetime | None) -> datetime:
    """``moment`` as an instant: now when None, UTC when naive (the documented rule of a
    date given without an offset)."""
    if moment is None:
        return datetime.now(UTC)
    return moment if moment.tzinfo is not None else moment.replace(tzinfo=UTC)


def offset_minutes(moment: datetime) -> int:
    """Minutes east of UTC of an aware datetime."""
    return round(moment.utcoffset().total_seconds() / 60)


def _as_given(instant: datetime, offset_min: int | None) -> datetime:
    """A stored instant in the offset it was given in (UTC when not recorded)."""
    if offset_min is None:
        return instant
    return instant.astimezone(timezone(timedelta(minutes=offset_min)))


def _check_document(document: object, machine: Machine, source: str) -> str:
    """The category of a result document for ``machine``; refuse what it cannot be.

    A result document says what it is: ``kind`` (which sets the category), ``machine``
    (required of task and verification results: a generic ``uncertainty-result`` of
    ``mtm uncertainty`` is no machine's) and, when present, ``category``.
    """
    if not isinstance(document, dict):
        raise InputError(f"{source}: not a result document (a JSON mapping with a kind)")
    kind = document.get("kind")
    category = category_of(kind, source)
    stated = document.get("category")
    if stated is not None and stated != category:
        raise InputError(f"{source}: category: {stated!r}, but a {kind!r} is a {category} result")
    named = document.get("machine")
    if named is not None and named != machine.name:
        raise InputError(
            f"{source}: a result of machine {named!r}, not of machine {machine.name!r} (--machine)"
        )
    if named is None and category != "calibration":
        raise InputError(
            f"{source}: a result of kind {kind!r} that names no machine (no machine field) "
            f"is not a {category} result of machine {machine.name!r}"
        )
    return category


def check_temperature(temperature_c: float | None, option: str = "temperature") -> None:
    """Refuse a workshop temperature that is not a number within :data:`TEMPERATURE_RANGE_C`."""
    if temperature_c is None:
        return
    low, high = TEMPERATURE_RANGE_C
    if not (math.isfinite(temperature_c) and low <= temperature_c <= high):
        raise InputError(
            f"{option} {temperature_c} °C: not a workshop temperature ({low:g} to {high:g} °C)"
        )


def _residual_statistics(doc: dict) -> dict:
    stats: dict = {}
    unexplained = (doc.get("volumetric_error") or {}).get("unexplained")
    if isinstance(unexplained, dict):
        stats.update({f"unexplained_{k}": v for k, v in unexplained.items()})
    ident = doc.get("identification")
    if isinstance(ident, dict):
        for key in ("variance_factor", "dof", "rank", "status"):
            if key in ident:
                stats[key] = ident[key]
    iso = doc.get("iso230_2")  # an ISO 230-2 laser run: its axis parameters trend over time
    if isinstance(iso, dict):
        stats.update({f"iso230_2_{k}_um": iso[k] for k in ("E", "A", "R", "B", "M") if k in iso})
    records = doc.get("records")
    if isinstance(records, dict) and "indications" in records:
        stats["indications"] = records["indications"]
    return stats


def _machine_row(session: Session, machine: Machine, serial: str | None) -> schema.Machine:
    row = session.scalar(select(schema.Machine).where(schema.Machine.name == machine.name))
    if row is None:
        row = schema.Machine(
            name=machine.name,
            topology=machine.topology.string,
            model=None,
            serial=serial,
        )
        session.add(row)
        session.flush()
    elif serial is not None and row.serial not in (None, serial):
        raise InputError(
            f"--serial {serial!r}: machine {machine.name!r} is recorded with serial {row.serial!r}"
        )
    return row


def _check_against_history(session: Session, row: schema.Machine, pset, source: str):
    """The machine's first run's parameter order; refuse another model or other names."""
    first = session.scalar(
        select(schema.CalibrationRun.id)
        .where(schema.CalibrationRun.machine_id == row.id)
        .order_by(schema.CalibrationRun.id)
        .limit(1)
    )
    if row.model is not None and pset.model != row.model:
        raise InputError(
            f"{source}: error model {pset.model!r}; the history of {row.name!r} holds "
            f"calibrations of model {row.model!r}"
        )
    row.model = pset.model
    if first is None:
        return list(pset.names)
    names = list(
        session.scalars(
            select(schema.RunParameter.name)
            .where(schema.RunParameter.run_id == first)
            .order_by(schema.RunParameter.position)
        )
    )
    if sorted(names) != sorted(pset.names):
        extra = sorted(set(names) ^ set(pset.names))
        raise InputError(
            f"{source}: parameters differ from the runs of machine {row.name!r} in the history "
            f"(not in both: {', '.join(extra[:5])}{' ...' if len(extra) > 5 else ''})"
        )
    return names


def add_result(
    engine: Engine,
    document: dict,
    machine: Machine,
    *,
    source: str = "<result>",
    performed_at: datetime | None = None,
    note: str | None = None,
    artefact: str | None = None,
    temperature_c: float | None = None,
    serial: str | None = None,
    input_files: tuple[str | Path, ...] = (),
    by: str,
    action: str = "add",
    detail: dict | None = None,
) -> RunRecord:
    """Record one result document in the history and its audit row (one transaction).

    Parameters
    ----------
    engine : Engine
        From :func:`mtmetrology.history.database.open_history`.
    document : dict
        The result as its application wrote it (a JSON mapping with ``kind``).
    machine : Machine
        The machine it belongs to; a result of another machine is refused.
    source : str
        The file it came from (messages, and its SHA-256 when it exists).
    performed_at : datetime, optional
        When the measurement was made (default: now); UTC when naive. Stored as the UTC
        instant, with the offset it was given in.
    note, artefact, temperature_c, serial
        Operator note, artefact identification, workshop temperature (°C), the machine's
        serial number (recorded with the machine on its first run).
    input_files : tuple of path
        Input files whose SHA-256 is recorded with the run (records, artefact file).
    by : str
        Who records it, the audit row's actor (a web user's name, ``cli:LOGIN``).
    action : str
        The audit row's action (``add`` from the command line, ``upload`` from the web).
    detail : dict, optional
        Added to the audit row's detail (which names the file, kind, machine, the
        result's SHA-256 and whether the machine is new to the history).

    Returns
    -------
    RunRecord

    Raises
    ------
    InputError
        Not a result document, an unknown kind, a result of another machine or category
        (naming both), a task or verification result that names no machine, a calibration
        of another error model, parameters that differ from the machine's earlier runs, a
        temperature outside -50...100 °C, a result already recorded, or no ``by``.
    """
    return add_results(
        engine,
        [
            {
                "document": document,
                "machine": machine,
                "source": source,
                "performed_at": performed_at,
                "note": note,
                "artefact": artefact,
                "temperature_c": temperature_c,
                "serial": serial,
                "input_files": input_files,
                "detail": detail,
            }
        ],
        by=by,
        action=action,
    )[0]


@dataclass(frozen=True)
class _Prepared:
    """A result checked and ready to insert."""

    category: str
    machine: Machine
    serial: str | None
    source: str
    pset: object
    columns: dict
    detail: dict


def _prepare(
    document,
    machine: Machine,
    *,
    source: str = "<result>",
    performed_at: datetime | None = None,
    note: str | None = None,
    artefact: str | None = None,
    temperature_c: float | None = None,
    serial: str | None = None,
    input_files: tuple[str | Path, ...] = (),
    detail: dict | None = None,
) -> _Prepared:
    category = _check_document(document, machine, source)
    check_temperature(temperature_c, "temperature")
    pset = None
    columns = {}
    if category == "calibration":
        from mtmetrology.kinematics.parameter_set import ParameterSet

        pset = ParameterSet.from_document(document, machine, source)
        columns = {
            "artefact": artefact,
            "temperature_c": temperature_c,
            "residual_statistics": _residual_statistics(document),
        }
    when = _utc(performed_at)
    hashes = {str(p): file_sha256(p) for p in input_files}
    if Path(source).is_file():
        hashes[str(source)] = file_sha256(source)
    columns.update(
        kind=document["kind"],
        performed_at=when,
        performed_at_offset_min=offset_minutes(when),
        recorded_at=datetime.now(UTC),
        software_version=mtmetrology.__version__,
        operator_note=note,
        input_hashes=hashes,
        result=document,
        content_sha256=canonical_sha256(document),
    )
    return _Prepared(category, machine, serial, source, pset, columns, detail or {})


def _insert(session: Session, item: _Prepared, by: str, action: str) -> int:
    """Insert one prepared result (a calibration's parameters) and its audit row; its id."""
    table = _TABLES[item.category]
    new_machine = (
        session.scalar(select(schema.Machine.id).where(schema.Machine.name == item.machine.name))
        is None
    )
    row = _machine_row(session, item.machine, item.serial)
    run = _insert_run(session, item, table, row)
    audit(
        session,
        by,
        action,
        f"{item.category} run {run}",
        {
            "file": item.source,
            "kind": item.columns["kind"],
            "machine": item.machine.name,
            "content_sha256": item.columns["content_sha256"],
            "new_machine": new_machine,
            **item.detail,
        },
    )
    return run


def _insert_run(session: Session, item: _Prepared, table, row: schema.Machine) -> int:
    if item.category != "calibration":
        run = table(machine_id=row.id, **item.columns)
        session.add(run)
        session.flush()
        return run.id
    pset = item.pset
    order = _check_against_history(session, row, pset, item.source)
    index = [pset.names.index(name) for name in order]
    f = pset.scales()[index]
    values = pset.values[index] / f
    u = pset.standard_uncertainty
    u = [None] * len(order) if u is None else (u[index] / f).tolist()
    run = table(machine_id=row.id, parameter_vector=values.astype("<f8").tobytes(), **item.columns)
    session.add(run)
    session.flush()
    session.add_all(
        schema.RunParameter(
            run_id=run.id,
            position=k,
            name=name,
            unit=pset.units[i],
            value=float(values[k]),
            u=u[k],
        )
        for k, (name, i) in enumerate(zip(order, index, strict=True))
    )
    session.flush()
    return run.id


def add_results(
    engine: Engine, items: list[dict], *, by: str, action: str = "add"
) -> list[RunRecord]:
    """Record several results in ONE transaction: all of them and their audit rows, or none.

    Every document is checked (:func:`add_result`'s rules) before anything is written; a
    refusal of any (a document, a result recorded earlier or twice in ``items``) leaves
    the history as it was, without an audit row, and names the file. Each recorded result
    writes one audit row in the same transaction: a crash between the two cannot record a
    result nobody is answerable for.

    Parameters
    ----------
    engine : Engine
    items : list of dict
        The keyword arguments of :func:`add_result` for each result (``document``,
        ``machine`` and the optional ones, ``detail`` included).
    by : str
        Who records them (the audit rows' actor).
    action : str
        The audit rows' action.

    Returns
    -------
    list of RunRecord
        In the order of ``items``.

    Raises
    ------
    InputError
        As :func:`add_result`, naming the file refused.
    """
    if not isinstance(by, str) or not by.strip():
        raise InputError("history add: name who records the results (by)")
    prepared = [_prepare(**item) for item in items]
    seen: dict[tuple[str, str], str] = {}
    for item in prepared:
        key = (item.category, item.columns["content_sha256"])
        if key in seen:
            raise InputError(f"{item.source}: the same result as {seen[key]} (given twice)")
        seen[key] = item.source
    try:
        with Session(writer(engine)) as session, session.begin():
            if engine.dialect.name == "postgresql":
                # writers queue (SQLite's BEGIN IMMEDIATE does the same): two first runs of
                # a new machine would otherwise both insert it
                session.execute(text("SELECT pg_advisory_xact_lock(24025)"))
            ids = [_insert(session, item, by, action) for item in prepared]
    except IntegrityError as err:
        with Session(engine) as session:
            for item in prepared:
                table = _TABLES[item.category]
                sha = item.columns["content_sha256"]
                earlier = session.scalar(select(table.id).where(table.content_sha256 == sha))
                if earlier is not None:
                    raise InputError(
                        f"{item.source}: already recorded as {item.category} run {earlier}"
                    ) from None
        raise database_fault(str(engine.url), err) from None
    with Session(engine) as session:
        return [
            _record(session, session.get(_TABLES[item.category], i), item.category)
            for item, i in zip(prepared, ids, strict=True)
        ]


def _record(session: Session, run, category: str) -> RunRecord:
    machine = session.get(schema.Machine, run.machine_id)
    parameters: tuple[dict, ...] = ()
    if category == "calibration":
        parameters = tuple(
            {"name": p.name, "unit": p.unit, "value": p.value, "u": p.u}
            for p in session.scalars(
                select(schema.RunParameter)
                .where(schema.RunParameter.run_id == run.id)
                .order_by(schema.RunParameter.position)
            )
        )
    return RunRecord(
        id=run.id,
        category=category,
        machine=machine.name,
        kind=run.kind,
        performed_at=_as_given(run.performed_at, run.performed_at_offset_min),
        recorded_at=run.recorded_at,
        software_version=run.software_version,
        operator_note=run.operator_note,
        artefact=getattr(run, "artefact", None),
        temperature_c=getattr(run, "temperature_c", None),
        residual_statistics=getattr(run, "residual_statistics", {}) or {},
        input_hashes=run.input_hashes,
        content_sha256=run.content_sha256,
        parameters=parameters,
        result=run.result,
    )


def show_run(engine: Engine, run_id: int, category: str = "calibration") -> RunRecord:
    """One stored run. Raises InputError when there is no such run."""
    if category not in _TABLES:
        raise InputError(f"category {category!r}: not one of {', '.join(_TABLES)}")
    with Session(engine) as session:
        run = session.get(_TABLES[category], run_id)
        if run is None:
            raise InputError(f"run {run_id}: no {category} run of that number in the history")
        return _record(session, run, category)


@dataclass(frozen=True)
class RunSummary:
    """One line of :func:`list_runs`."""

    id: int
    category: str
    machine: str
    kind: str
    performed_at: datetime
    operator_note: str | None

    def to_dict(self) -> dict:
        """JSON form."""
        return {
            "id": self.id,
            "category": self.category,
            "machine": self.machine,
            "result_kind": self.kind,
            "performed_at": self.performed_at.isoformat(),
            "operator_note": self.operator_note,
        }


def list_runs(
    engine: Engine,
    *,
    machine: str | None = None,
    category: str = "calibration",
    since: datetime | None = None,
) -> tuple[RunSummary, ...]:
    """The stored runs of a category, oldest first (optionally of one machine, since a date)."""
    if category not in _TABLES:
        raise InputError(f"category {category!r}: not one of {', '.join(_TABLES)}")
    table = _TABLES[category]
    query = (
        select(
            table.id,
            schema.Machine.name,
            table.kind,
            table.performed_at,
            table.performed_at_offset_min,
            table.operator_note,
        )
        .join(schema.Machine, schema.Machine.id == table.machine_id)
        .order_by(table.performed_at, table.id)
    )
    if machine is not None:
        query = query.where(schema.Machine.name == machine)
    if since is not None:
        query = query.where(table.performed_at >= _utc(since))
    with Session(engine) as session:
        rows = session.execute(query).all()
    return tuple(RunSummary(r[0], category, r[1], r[2], _as_given(r[3], r[4]), r[5]) for r in rows)


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
    import numpy as np  # here, not at the top: the read path needs no numpy

    cal, par = schema.CalibrationRun, schema.RunParameter
    with Session(engine) as session:
        machine_id = _machine_id(session, machine)
        runs = select(cal.id, cal.performed_at, cal.parameter_vector).where(
            cal.machine_id == machine_id
        )
        if since is not None:
            runs = runs.where(cal.performed_at >= _utc(since))
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
    import numpy as np  # here, not at the top: the read path needs no numpy

    cal, par = schema.CalibrationRun, schema.RunParameter
    with Session(engine) as session:
        machine_id = _machine_id(session, machine)
        query = (
            select(cal.id, cal.performed_at, par.unit, par.value, par.u)
            .join(cal, cal.id == par.run_id)
            .where(par.name == parameter, cal.machine_id == machine_id)
        )
        if since is not None:
            query = query.where(cal.performed_at >= _utc(since))
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
    import numpy as np  # here, not at the top: the read path needs no numpy

    from mtmetrology.io.covariance import symmetric_covariance
    from mtmetrology.units import parse_unit

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
