"""Settings a laboratory keeps with its history: each machine parameter's maximum
permissible error (MPE) and the reliability target of its due date, and the laboratory's
identity for certificates. Every change writes one audit row in the same transaction.
"""

from __future__ import annotations

import math
import re

from sqlalchemy import JSON, Float, ForeignKey, String, select
from sqlalchemy.orm import Mapped, Session, mapped_column

from mtmetrology.errors import InputError
from mtmetrology.history import schema
from mtmetrology.history.audit import audit
from mtmetrology.history.database import writer

__all__ = [
    "DEFAULTS",
    "LabSetting",
    "MachineLimit",
    "lab_settings",
    "machine_limits",
    "set_lab_settings",
    "set_machine_limit",
]

#: Laboratory settings and their defaults (``due_soon_days``: the "due soon" window;
#: ``responsible_person`` and ``manufacturer``: who signs the certificates and the maker
#: of the laboratory's machines, as the DCC states them).
DEFAULTS = {
    "laboratory": "",
    "email": "",
    "country": "",
    "responsible_person": "",
    "manufacturer": "",
    "due_soon_days": 30,
}


class MachineLimit(schema.Base):
    """MPE of |parameter| (its customary unit) and the in-tolerance probability target."""

    __tablename__ = "machine_limits"
    machine_id: Mapped[int] = mapped_column(ForeignKey("machines.id"), primary_key=True)
    parameter: Mapped[str] = mapped_column(String(50), primary_key=True)
    mpe: Mapped[float] = mapped_column(Float)
    reliability: Mapped[float] = mapped_column(Float)


class LabSetting(schema.Base):
    """One laboratory setting (JSON value)."""

    __tablename__ = "lab_settings"
    key: Mapped[str] = mapped_column(String(50), primary_key=True)
    value: Mapped[object] = mapped_column(JSON)


def machine_limits(engine, machine: str) -> dict[str, tuple[float, float]]:
    """``{parameter: (mpe, reliability)}`` of a machine (empty when none is set)."""
    with Session(engine) as session:
        rows = session.execute(
            select(MachineLimit.parameter, MachineLimit.mpe, MachineLimit.reliability)
            .join(schema.Machine, schema.Machine.id == MachineLimit.machine_id)
            .where(schema.Machine.name == machine)
            .order_by(MachineLimit.parameter)
        ).all()
    return {p: (m, r) for p, m, r in rows}


def set_machine_limit(
    engine, machine: str, parameter: str, mpe: float, reliability: float, *, by: str
) -> None:
    """Set the MPE and reliability target of one parameter of a machine (audited).

    Raises
    ------
    InputError
        Unknown machine, an MPE not finite and positive, a reliability outside (0, 1).
    """
    if not (math.isfinite(mpe) and mpe > 0):
        raise InputError(f"mpe {mpe!r}: must be a positive number")
    if not (math.isfinite(reliability) and 0 < reliability < 1):
        raise InputError(f"reliability {reliability!r}: must be between 0 and 1")
    with Session(writer(engine)) as session, session.begin():
        row = session.scalar(select(schema.Machine).where(schema.Machine.name == machine))
        if row is None:
            raise InputError(f"machine {machine!r}: not in the history")
        limit = session.get(MachineLimit, (row.id, parameter))
        before = None if limit is None else [limit.mpe, limit.reliability]
        if limit is None:
            session.add(
                MachineLimit(
                    machine_id=row.id, parameter=parameter, mpe=mpe, reliability=reliability
                )
            )
        else:
            limit.mpe, limit.reliability = mpe, reliability
        audit(
            session,
            by,
            "set-limit",
            f"machine {machine}",
            {"parameter": parameter, "before": before, "after": [mpe, reliability]},
        )


def lab_settings(engine) -> dict:
    """The laboratory settings (:data:`DEFAULTS` where unset)."""
    with Session(engine) as session:
        stored = dict(session.execute(select(LabSetting.key, LabSetting.value)).all())
    return {**DEFAULTS, **{k: v for k, v in stored.items() if k in DEFAULTS}}


def set_lab_settings(engine, values: dict, *, by: str) -> dict:
    """Change laboratory settings (audited); returns them all.

    Raises
    ------
    InputError
        An unknown key, a malformed e-mail address or country code, a negative window.
    """
    unknown = sorted(set(values) - set(DEFAULTS))
    if unknown:
        raise InputError(f"setting {unknown[0]!r}: not one of {', '.join(DEFAULTS)}")
    if values.get("email") and not re.fullmatch(r"[^@\s]+@[^@\s]+\.[^@\s]+", values["email"]):
        raise InputError(f"email {values['email']!r}: not an e-mail address")
    if values.get("country") and not re.fullmatch(r"[A-Z]{2}", values["country"]):
        raise InputError(f"country {values['country']!r}: an ISO 3166-1 alpha-2 code (DE)")
    days = values.get("due_soon_days", 0)
    if not isinstance(days, int) or isinstance(days, bool) or not 0 <= days <= 3650:
        raise InputError(f"due_soon_days {days!r}: a whole number of days, 0 to 3650")
    with Session(writer(engine)) as session, session.begin():
        before = {}
        for key, value in values.items():
            row = session.get(LabSetting, key)
            before[key] = None if row is None else row.value
            if row is None:
                session.add(LabSetting(key=key, value=value))
            else:
                row.value = value
        audit(session, by, "settings", "laboratory", {"before": before, "after": values})
    return lab_settings(engine)
