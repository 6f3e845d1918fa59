"""Schema version 2: every stored result carries the SHA-256 of its canonical JSON, unique
per table (the same result is not recorded twice), and the parameter trend gets an index.

Existing rows get their hash computed from the stored document.

Revision ID: 0002
"""

import sqlalchemy as sa
from alembic import op

from mtmetrology.history.database import canonical_sha256

revision = "0002"
down_revision = "0001"
branch_labels = None
depends_on = None

TABLES = ("calibration_runs", "task_results", "verification_results")


def upgrade() -> None:
    # Only ADD COLUMN and CREATE INDEX: on SQLite nothing is rebuilt (a rebuilt
    # calibration_runs would cascade-delete run_parameters).
    bind = op.get_bind()
    for name in TABLES:
        op.add_column(name, sa.Column("content_sha256", sa.String(64), nullable=True))
        table = sa.table(
            name,
            sa.column("id", sa.Integer),
            sa.column("result", sa.JSON),
            sa.column("content_sha256", sa.String),
        )
        for row_id, document in bind.execute(sa.select(table.c.id, table.c.result)).all():
            bind.execute(
                table.update()
                .where(table.c.id == row_id)
                .values(content_sha256=canonical_sha256(document))
            )
        op.create_index(f"uq_{name}_content_sha256", name, ["content_sha256"], unique=True)
    op.create_index("ix_run_parameters_name_run", "run_parameters", ["name", "run_id"])


def downgrade() -> None:
    op.drop_index("ix_run_parameters_name_run", "run_parameters")
    for name in TABLES:
        op.drop_index(f"uq_{name}_content_sha256", name)
        op.drop_column(name, "content_sha256")  # SQLite >= 3.35: no rebuild
