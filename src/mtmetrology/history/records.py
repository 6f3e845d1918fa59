"""Recording results in the calibration history and reading them back.

:func:`add_result` takes a result document of any application through its documented JSON
form (``kind`` and ``version``): a calibration (``parameter-set``, ``samba-calibration``,
``ballplate-calibration``), a task uncertainty (``uncertainty-result``) or a verification
(``length-check``, ``conformity-decision``). A calibration is checked against the machine's
definition (:meth:`ParameterSet.from_document`) and against the machine's earlier runs (the
same error model and parameter names), then stored with its parameters in one transaction,
together with one row of the audit log per result (:mod:`mtmetrology.history.audit`: who
recorded it, from which file), so that no result is recorded without its audit row.

:func:`add_results`, :func:`list_runs` and :func:`show_run` are SQL text run by
:mod:`mtmetrology.history.sql`: through :mod:`sqlite3` on a SQLite file at the current
schema (``mtm history list``, ``show`` and ``add`` import no SQLAlchemy), through
SQLAlchemy on PostgreSQL or on an engine given. They take an engine or the database itself
(a file or URL). The analyses' reads (:mod:`mtmetrology.history.series`) use the ORM.
"""

from __future__ import annotations

import hashlib
import math
import os
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta, timezone
from pathlib import Path
from typing import TYPE_CHECKING

import mtmetrology
from mtmetrology.errors import InputError
from mtmetrology.history.opening import canonical_sha256, database_fault
from mtmetrology.history.sql import Conflict, Json, connect, instant, write_audit

if TYPE_CHECKING:  # list, show and add import no SQLAlchemy; list and show no numpy
    from sqlalchemy import Engine

    from mtmetrology.kinematics.machine import Machine

__all__ = [
    "CALIBRATION_KINDS",
    "TASK_KINDS",
    "TEMPERATURE_RANGE_C",
    "VERIFICATION_KINDS",
    "RunRecord",
    "add_result",
    "add_results",
    "as_instant",
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
#: The table of each category.
TABLES = {
    "calibration": "calibration_runs",
    "task": "task_results",
    "verification": "verification_results",
}
#: The JSON columns of a run.
_JSON = ("residual_statistics", "input_hashes", "result")


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


def as_instant(moment: datetime | None) -> datetime:
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


def _machine_row(c, machine: Machine, serial: str | None) -> tuple[int, bool]:
    """The machine's row id, inserted on its first result; whether it is new."""
    row = c.first("SELECT id, serial FROM machines WHERE name = :name", name=machine.name)
    if row is None:
        created = c.insert(
            "INSERT INTO machines (name, topology, model, serial) "
            "VALUES (:name, :topology, NULL, :serial)",
            name=machine.name,
            topology=machine.topology.string,
            serial=serial,
        )
        return created, True
    if serial is not None and row[1] not in (None, serial):
        raise InputError(
            f"--serial {serial!r}: machine {machine.name!r} is recorded with serial {row[1]!r}"
        )
    return row[0], False


def _check_against_history(c, machine_id: int, machine: str, pset, source: str) -> list[str]:
    """The machine's first run's parameter order; refuse another model or other names (the
    machine takes the model of its first calibration)."""
    (model,) = c.first("SELECT model FROM machines WHERE id = :id", id=machine_id)
    if model is not None and pset.model != model:
        raise InputError(
            f"{source}: error model {pset.model!r}; the history of {machine!r} holds "
            f"calibrations of model {model!r}"
        )
    if model != pset.model:
        c.execute(
            "UPDATE machines SET model = :model WHERE id = :id", model=pset.model, id=machine_id
        )
    first = c.first(
        "SELECT id FROM calibration_runs WHERE machine_id = :machine ORDER BY id LIMIT 1",
        machine=machine_id,
    )
    if first is None:
        return list(pset.names)
    names = [
        r[0]
        for r in c.rows(
            "SELECT name FROM run_parameters WHERE run_id = :run ORDER BY position", run=first[0]
        )
    ]
    if sorted(names) != sorted(pset.names):
        extra = sorted(set(names) ^ set(pset.names))
        raise InputError(
            f"{source}: parameters differ from the runs of machine {machine!r} in the history "
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
    when = as_instant(performed_at)
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


def _insert(c, item: _Prepared, by: str, action: str) -> int:
    """Insert one prepared result (a calibration's parameters) and its audit row; its id."""
    machine_id, new_machine = _machine_row(c, item.machine, item.serial)
    run = _insert_run(c, item, machine_id)
    write_audit(
        c,
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


def _insert_run(c, item: _Prepared, machine_id: int) -> int:
    columns = {"machine_id": machine_id, **item.columns}
    if item.category == "calibration":
        pset = item.pset
        order = _check_against_history(c, machine_id, item.machine.name, pset, item.source)
        index = [pset.names.index(name) for name in order]
        f = pset.scales()[index]
        values = pset.values[index] / f
        u = pset.standard_uncertainty
        u = [None] * len(order) if u is None else (u[index] / f).tolist()
        columns["parameter_vector"] = values.astype("<f8").tobytes()
    table = TABLES[item.category]
    # under the write lock: the unique index would refuse it, this names the run
    earlier = c.first(
        f"SELECT id FROM {table} WHERE content_sha256 = :sha", sha=columns["content_sha256"]
    )
    if earlier is not None:
        raise InputError(f"{item.source}: already recorded as {item.category} run {earlier[0]}")
    names = ", ".join(columns)
    run = c.insert(
        f"INSERT INTO {table} ({names}) VALUES ({', '.join(f':{k}' for k in columns)})",
        **{k: Json(v) if k in _JSON else v for k, v in columns.items()},
    )
    if item.category == "calibration":
        for k, (name, i) in enumerate(zip(order, index, strict=True)):
            c.execute(
                "INSERT INTO run_parameters (run_id, position, name, unit, value, u) "
                "VALUES (:run, :position, :name, :unit, :value, :u)",
                run=run,
                position=k,
                name=name,
                unit=pset.units[i],
                value=float(values[k]),
                u=u[k],
            )
    return run


def add_results(
    engine: Engine | str | os.PathLike | None,
    items: list[dict],
    *,
    by: str,
    action: str = "add",
) -> list[RunRecord]:
    """Record several results in ONE transaction: all of them and their audit rows, or none.

    Every document is checked (:func:`add_result`'s rules) before anything is written; a
    refusal of any (a document, a result recorded earlier or twice in ``items``) leaves
    the history as it was, without an audit row, and names the file. Each recorded result
    writes one audit row in the same transaction: a crash between the two cannot record a
    result nobody is answerable for.

    Parameters
    ----------
    engine : Engine, str, path or None
        An engine (:func:`~mtmetrology.history.database.open_history`), or the database
        (a SQLite file or URL; None: ``$MTMETROLOGY_DB`` or the default file), opened as a
        writer (:func:`mtmetrology.history.sql.connect`: an older schema is upgraded).
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
        In the order of ``items``, as stored.

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
    with connect(engine) as history:
        try:
            with history.transaction(write=True) as c:
                ids = [_insert(c, item, by, action) for item in prepared]
        except Conflict as err:
            raise database_fault(c.shown, err.original) from None
        with history.transaction() as c:
            return [run_record(c, i, item.category) for item, i in zip(prepared, ids, strict=True)]


#: A run's fields as :class:`RunRecord` reads them (a calibration's own columns, NULL for
#: the task and verification results, which have none).
_RUN = (
    "SELECT r.id, m.name, r.kind, r.performed_at, r.performed_at_offset_min, r.recorded_at, "
    "r.software_version, r.operator_note, {calibration}, r.input_hashes, r.content_sha256, "
    "r.result FROM {table} r JOIN machines m ON m.id = r.machine_id WHERE r.id = :id"
)


def run_record(c, run_id: int, category: str = "calibration") -> RunRecord:
    """One stored run, read on an open connection (:func:`mtmetrology.history.sql.connect`).

    Raises
    ------
    InputError
        An unknown category, or no such run.
    """
    if category not in TABLES:
        raise InputError(f"category {category!r}: not one of {', '.join(TABLES)}")
    own = "r.artefact, r.temperature_c, r.residual_statistics"
    row = c.first(
        _RUN.format(
            calibration=own if category == "calibration" else "NULL, NULL, NULL",
            table=TABLES[category],
        ),
        id=run_id,
    )
    if row is None:
        raise InputError(f"run {run_id}: no {category} run of that number in the history")
    parameters: tuple[dict, ...] = ()
    if category == "calibration":
        parameters = tuple(
            {"name": name, "unit": unit, "value": value, "u": u}
            for name, unit, value, u in c.rows(
                "SELECT name, unit, value, u FROM run_parameters WHERE run_id = :run "
                "ORDER BY position",
                run=run_id,
            )
        )
    return RunRecord(
        id=row[0],
        category=category,
        machine=row[1],
        kind=row[2],
        performed_at=_as_given(instant(row[3]), row[4]),
        recorded_at=instant(row[5]),
        software_version=row[6],
        operator_note=row[7],
        artefact=row[8],
        temperature_c=row[9],
        residual_statistics=c.json(row[10]) or {},
        input_hashes=c.json(row[11]),
        content_sha256=row[12],
        parameters=parameters,
        result=c.json(row[13]),
    )


def show_run(
    engine: Engine | str | os.PathLike | None, run_id: int, category: str = "calibration"
) -> RunRecord:
    """One stored run (``engine``: an engine or the database, opened as a reader, see
    :func:`add_results`). Raises InputError when there is no such run."""
    if category not in TABLES:
        raise InputError(f"category {category!r}: not one of {', '.join(TABLES)}")
    with connect(engine, read_only=True) as history, history.transaction() as c:
        return run_record(c, run_id, category)


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
    engine: Engine | str | os.PathLike | None,
    *,
    machine: str | None = None,
    category: str = "calibration",
    since: datetime | None = None,
) -> tuple[RunSummary, ...]:
    """The stored runs of a category, oldest first (optionally of one machine, since a
    date); ``engine``: an engine or the database, opened as a reader (see
    :func:`add_results`)."""
    if category not in TABLES:
        raise InputError(f"category {category!r}: not one of {', '.join(TABLES)}")
    where, params = [], {}
    if machine is not None:
        where.append("m.name = :machine")
        params["machine"] = machine
    if since is not None:
        where.append("r.performed_at >= :since")
        params["since"] = as_instant(since)
    query = (
        "SELECT r.id, m.name, r.kind, r.performed_at, r.performed_at_offset_min, "
        f"r.operator_note FROM {TABLES[category]} r JOIN machines m ON m.id = r.machine_id"
        + "".join(f" {'AND' if k else 'WHERE'} {w}" for k, w in enumerate(where))
        + " ORDER BY r.performed_at, r.id"
    )
    with connect(engine, read_only=True) as history, history.transaction() as c:
        rows = c.rows(query, **params)
    return tuple(
        RunSummary(r[0], category, r[1], r[2], _as_given(instant(r[3]), r[4]), r[5]) for r in rows
    )
