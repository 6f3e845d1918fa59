"""Schema version 2: every stored result carries the SHA-256 of its canonical JSON, unique
per table (the same result is not recorded twice), and the parameter trend gets an index.

Existing rows get their hash computed from the stored document. A schema-1 database could
hold the same result twice, which the unique index cannot take: of each set of equal
documents the first (lowest id) is kept, the others (with their parameters) are moved to
the table ``duplicate_results`` (their fields and document, and the id kept), and the
upgrade says how many (``config.attributes["notices"]``, a warning of
:func:`mtmetrology.history.database.migrate`).

Revision ID: 0002
"""

from datetime import UTC, datetime

import sqlalchemy as sa
from alembic import context, op

from mtmetrology.history.database import canonical_sha256
from mtmetrology.history.schema import DuplicateResult

revision = "0002"
down_revision = "0001"
branch_labels = None
depends_on = None

TABLES = ("calibration_runs", "task_results", "verification_results")
CATEGORY = {"calibration_runs": "calibration", "task_results": "task"}


def _set_aside_duplicates(bind, name: str, table) -> int:
    """Move every row whose document equals an earlier row's to ``duplicate_results``;
    the number moved."""
    rows = bind.execute(sa.select(table.c.id, table.c.content_sha256).order_by(table.c.id)).all()
    first: dict[str, int] = {}
    moved = 0
    duplicates = DuplicateResult.__table__
    for row_id, sha in rows:
        if sha not in first:
            first[sha] = row_id
            continue
        run = bind.execute(
            sa.select(
                table.c.performed_at, table.c.recorded_at, table.c.operator_note, table.c.result
            ).where(table.c.id == row_id)
        ).one()
        bind.execute(
            duplicates.insert().values(
                category=CATEGORY.get(name, "verification"),
                kept_id=first[sha],
                duplicate_id=row_id,
                content_sha256=sha,
                performed_at=_aware(run.performed_at),
                recorded_at=_aware(run.recorded_at),
                operator_note=run.operator_note,
                result=run.result,
                set_aside_at=datetime.now(UTC),
            )
        )
        if name == "calibration_runs":
            bind.execute(sa.text("DELETE FROM run_parameters WHERE run_id = :i"), {"i": row_id})
        bind.execute(table.delete().where(table.c.id == row_id))
        moved += 1
    return moved


def _aware(moment):
    """A stored date as an instant (SQLite gives back the naive UTC text written)."""
    if moment is None or moment.tzinfo is not None:
        return moment
    return moment.replace(tzinfo=UTC)


def upgrade() -> None:
    # Only ADD COLUMN and CREATE INDEX: on SQLite nothing is rebuilt (a rebuilt
    # calibration_runs would cascade-delete run_parameters).
    bind = op.get_bind()
    # the table's form as of this revision, made from the model (a new table, not altered)
    DuplicateResult.__table__.create(bind, checkfirst=True)
    notices = context.config.attributes.get("notices") if context.config else None
    for name in TABLES:
        op.add_column(name, sa.Column("content_sha256", sa.String(64), nullable=True))
        table = sa.table(
            name,
            sa.column("id", sa.Integer),
            sa.column("result", sa.JSON),
            sa.column("content_sha256", sa.String),
            sa.column("performed_at", sa.DateTime(timezone=True)),
            sa.column("recorded_at", sa.DateTime(timezone=True)),
            sa.column("operator_note", sa.Text),
        )
        for row_id, document in bind.execute(sa.select(table.c.id, table.c.result)).all():
            bind.execute(
                table.update()
                .where(table.c.id == row_id)
                .values(content_sha256=canonical_sha256(document))
            )
        moved = _set_aside_duplicates(bind, name, table)
        if moved and notices is not None:
            notices.append(
                f"{moved} result(s) recorded twice in {name} set aside in duplicate_results "
                "(the first of each kept) by the upgrade to schema revision 0002"
            )
        op.create_index(f"uq_{name}_content_sha256", name, ["content_sha256"], unique=True)
    op.create_index("ix_run_parameters_name_run", "run_parameters", ["name", "run_id"])


def downgrade() -> None:
    op.drop_index("ix_run_parameters_name_run", "run_parameters")
    for name in TABLES:
        op.drop_index(f"uq_{name}_content_sha256", name)
        op.drop_column(name, "content_sha256")  # SQLite >= 3.35: no rebuild
    op.drop_table("duplicate_results")
