"""What the pages and the API show, from the same library calls as ``mtm history``.

A machine's status comes from :func:`~mtmetrology.history.parameter_trends` (the Shewhart
chart of each parameter: is the latest run out of control?) and
:func:`~mtmetrology.history.parameter_drift` (the drift model of each parameter with a
maximum permissible error: the date P(|x| > MPE) passes 1 − reliability); the machine is

- ``out of control`` when its latest calibration is outside a parameter's control limits,
- else ``overdue`` when the earliest due date has passed,
- else ``due soon`` when it falls within the laboratory's window (``due_soon_days``),
- else ``ok`` (with no MPE set there is no due date: ``ok`` says only "in control").

The results depend only on the stored runs, amendments and settings, so they are kept in
a small in-process cache under the history's *version*: the highest run ids and the last
audit row of an amendment, an MPE or a setting (a login, a token or a user
change does not change what the pages show). Any change gives a new
version and the next request recomputes. The version itself is read at most once a second
(a change by another process shows within a second; this process's own writes, every
request that is not a GET, forget it at once), or at every request (``version_seconds=0``,
``mtm serve --workers``: a write through one worker shows at the next request of any).
"""

from __future__ import annotations

import threading
import time
from collections import OrderedDict
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from mtmetrology.errors import InputError
from mtmetrology.history import schema
from mtmetrology.history.analysis import parameter_drift, parameter_trends
from mtmetrology.history.audit import AuditEntry
from mtmetrology.history.records import list_runs
from mtmetrology.history.series import machine_names
from mtmetrology.history.settings import lab_settings, machine_limits

__all__ = ["STATUSES", "Lab", "MachineOverview", "reading"]

STATUSES = ("ok", "due soon", "overdue", "out of control")
#: How long a read version of the history is trusted (seconds).
VERSION_SECONDS = 1.0
#: Cached values kept (least recently used dropped): a machine of 10⁴ runs of the
#: 84-coefficient model has about 370 (84 charts, 84 SVGs, 200 pages of runs, its tables).
_CACHE_SIZE = 2048
#: Audit actions that change what the pages show (runs are counted in their own tables);
#: a login, a token or a user change leaves the cached charts valid (a login would
#: otherwise recompute every chart: 10-20 s for 10⁴ runs of the 84-coefficient model).
_DATA_ACTIONS = ("amend", "set-limit", "settings")


@dataclass(frozen=True)
class MachineOverview:
    """One line of the machines page."""

    name: str
    topology: str | None
    model: str | None
    serial: str | None
    runs: int
    last_calibration: datetime | None
    due_date: datetime | None
    due_parameter: str | None
    reliability: float | None
    status: str
    out_of_control: tuple[str, ...]

    def to_dict(self) -> dict:
        """JSON form."""
        return {
            "name": self.name,
            "topology": self.topology,
            "model": self.model,
            "serial": self.serial,
            "calibrations": self.runs,
            "last_calibration": _iso(self.last_calibration),
            "due_date": _iso(self.due_date),
            "due_parameter": self.due_parameter,
            "reliability": self.reliability,
            "status": self.status,
            "out_of_control": list(self.out_of_control),
        }


def _iso(moment: datetime | None) -> str | None:
    return None if moment is None else moment.isoformat()


def _utc(moment: datetime) -> datetime:
    return moment if moment.tzinfo is not None else moment.replace(tzinfo=UTC)


#: The history's version as read once by the current request, per :class:`Lab` (a mutable
#: mapping: the request's synchronous endpoint runs in a worker thread with a copy of the
#: context, and the copy refers to the same mapping).
_REQUEST_VERSIONS: ContextVar[dict | None] = ContextVar("history_versions", default=None)


@contextmanager
def reading():
    """Within this block (one request that only reads) the history's version is read at
    most once by each :class:`Lab`: the page shows one state of the history."""
    token = _REQUEST_VERSIONS.set({})
    try:
        yield
    finally:
        _REQUEST_VERSIONS.reset(token)


class Lab:
    """The history as the web application reads it (one engine, a version-keyed cache)."""

    def __init__(self, engine, version_seconds: float = VERSION_SECONDS) -> None:
        self.engine = engine
        self.version_seconds = version_seconds
        self._cache: OrderedDict = OrderedDict()
        self._lock = threading.Lock()
        self._pending: dict[tuple, threading.Lock] = {}
        self._version: tuple = (None, -1.0)

    # -- cache ---------------------------------------------------------------------------
    def invalidate(self) -> None:
        """Forget the version read last (after a write of this process)."""
        self._version = (None, -1.0)

    def version(self) -> tuple:
        """Changes whenever a run, an amendment or a setting changes. Read from the database
        at most every ``version_seconds`` (a write of another process, ``mtm history add``,
        shows within that time; this process's writes call :meth:`invalidate`), and at most
        once in a reading request (:func:`reading`): a page asks for it once per cached
        value, six times for a machine page, which with ``version_seconds=0`` were six
        queries."""
        snapshot = _REQUEST_VERSIONS.get()
        if snapshot is not None and self in snapshot:
            return snapshot[self]
        value, read_at = self._version
        if value is None or time.monotonic() - read_at >= self.version_seconds:
            value = self._read_version()
            self._version = (value, time.monotonic())
        if snapshot is not None:
            snapshot[self] = value
        return value

    def _read_version(self) -> tuple:
        # One statement (one round trip), each part an index lookup: the highest id of
        # each result table and of the data-changing audit rows. Nothing removes a run
        # (the history has no delete; a correction is an amendment, audited), so the
        # highest ids change with every change the pages show. Row counts (an index scan,
        # 1.1 ms for 10^4 runs on SQLite against 0.13 ms for this) would add nothing.
        parts = [
            select(func.max(t.id)).scalar_subquery()
            for t in (schema.CalibrationRun, schema.TaskResult, schema.VerificationResult)
        ]
        parts.append(
            select(func.max(AuditEntry.id))
            .where(AuditEntry.action.in_(_DATA_ACTIONS))
            .scalar_subquery()
        )
        with self.engine.connect() as connection:
            return tuple(connection.execute(select(*parts)).one())

    def cached(self, key: tuple, compute):
        """``compute()`` under ``key`` and the current version (recomputed after a change).

        One request computes, the others asking for the same key meanwhile wait for its
        result: 50 readers arriving after an upload would otherwise each compute the 84
        charts (seconds each) at once, and all of them time out."""
        full = (self.version(), *key)
        with self._lock:
            if full in self._cache:
                self._cache.move_to_end(full)
                return self._cache[full]
            pending = self._pending.setdefault(full, threading.Lock())
        with pending:
            with self._lock:
                if full in self._cache:  # computed while this request waited
                    return self._cache[full]
            try:
                value = compute()
            except BaseException:
                with self._lock:
                    self._pending.pop(full, None)  # the next request tries again
                raise
            with self._lock:
                self._cache[full] = value
                self._pending.pop(full, None)
                while len(self._cache) > _CACHE_SIZE:
                    self._cache.popitem(last=False)
        return value

    # -- machines ------------------------------------------------------------------------
    def parameters(self, machine: str) -> list[str]:
        """Parameter names of a machine's calibrations (its first run's order)."""
        with Session(self.engine) as session:
            first = session.scalar(
                select(schema.CalibrationRun.id)
                .join(schema.Machine, schema.Machine.id == schema.CalibrationRun.machine_id)
                .where(schema.Machine.name == machine)
                .order_by(schema.CalibrationRun.id)
                .limit(1)
            )
            if first is None:
                return []
            return list(
                session.scalars(
                    select(schema.RunParameter.name)
                    .where(schema.RunParameter.run_id == first)
                    .order_by(schema.RunParameter.position)
                )
            )

    def parameter_table(self, machine: str) -> list[dict]:
        """Per parameter: its control chart (latest value, limits, points out of control)
        and, where an MPE is set, its drift and due date."""
        return self.cached(("parameters", machine), lambda: self._parameter_table(machine))

    def _parameter_table(self, machine: str) -> list[dict]:
        limits = machine_limits(self.engine, machine)
        rows = []
        # a control chart needs two runs; every parameter's from one read of the runs
        trends = parameter_trends(self.engine, machine) if self._runs(machine) > 1 else {}
        for name in self.parameters(machine):
            trend = trends.get(name)
            row = {"parameter": name, "trend": trend, "drift": None, "mpe": None, "why": None}
            if name in limits and trend is not None:
                mpe, reliability = limits[name]
                row["mpe"], row["reliability"] = mpe, reliability
                try:
                    row["drift"] = parameter_drift(
                        self.engine, machine, name, mpe=mpe, reliability=reliability
                    )
                except InputError as err:  # e.g. runs without u: the row says why
                    row["why"] = str(err)
            rows.append(row)
        return rows

    def _runs(self, machine: str) -> int:
        return len(list_runs(self.engine, machine=machine))

    def overview(self, now: datetime | None = None) -> list[MachineOverview]:
        """Every machine with its status (see the module notes)."""
        now = now or datetime.now(UTC)
        settings = self.cached(("settings",), lambda: lab_settings(self.engine))
        window = timedelta(days=int(settings["due_soon_days"]))
        return self.cached(("overview", now.date(), window), lambda: self._overview(now, window))

    def _overview(self, now: datetime, window: timedelta) -> list[MachineOverview]:
        out = []
        with Session(self.engine) as session:
            machines = {m.name: m for m in session.scalars(select(schema.Machine))}
            stats = dict(
                (row[0], row[1:])
                for row in session.execute(
                    select(
                        schema.CalibrationRun.machine_id,
                        func.count(schema.CalibrationRun.id),
                        func.max(schema.CalibrationRun.performed_at),
                    ).group_by(schema.CalibrationRun.machine_id)
                )
            )
        for name in machine_names(self.engine):
            m = machines[name]
            runs, last = stats.get(m.id, (0, None))
            table = self.parameter_table(name)
            flagged = tuple(
                r["parameter"]
                for r in table
                if r["trend"] is not None and bool(r["trend"].out_of_control[-1])
            )
            due = [(r["drift"].due_date, r) for r in table if r["drift"] is not None]
            due = [d for d in due if d[0] is not None]
            first = min(due, key=lambda d: d[0]) if due else None
            due_date = None if first is None else _utc(first[0])
            if flagged:
                status = "out of control"
            elif due_date is not None and due_date <= now:
                status = "overdue"
            elif due_date is not None and due_date <= now + window:
                status = "due soon"
            else:
                status = "ok"
            out.append(
                MachineOverview(
                    name=name,
                    topology=m.topology,
                    model=m.model,
                    serial=m.serial,
                    runs=runs,
                    last_calibration=None if last is None else _utc(last),
                    due_date=due_date,
                    due_parameter=None if first is None else first[1]["parameter"],
                    reliability=None if first is None else first[1]["reliability"],
                    status=status,
                    out_of_control=flagged,
                )
            )
        return out

    def machine(self, name: str) -> MachineOverview:
        """One machine's overview line; InputError when it is not in the history."""
        for m in self.overview():
            if m.name == name:
                return m
        raise InputError(f"machine {name!r}: not in the history")

    def trend_svg(self, machine: str, parameter: str) -> str:
        """The control chart of one parameter with its drift band, as SVG (cached)."""
        return self.cached(("svg", machine, parameter), lambda: self._svg(machine, parameter))

    def _svg(self, machine: str, parameter: str) -> str:
        from mtmetrology.report.document import figure_svg
        from mtmetrology.report.figures.monitoring import trend_chart

        row = next((r for r in self.parameter_table(machine) if r["parameter"] == parameter), None)
        if row is None or row["trend"] is None:
            raise InputError(f"parameter {parameter!r}: no control chart for {machine!r}")
        fig = trend_chart(row["trend"], row["drift"])
        try:
            return figure_svg(fig, prefix="trend")
        finally:
            import matplotlib.pyplot as plt

            plt.close(fig)
