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
    bind = op.get_bind()
    for name in TABLES:
        with op.batch_alter_table(name) as batch:
            batch.add_column(sa.Column("content_sha256", sa.String(64), nullable=True))
        table = sa.table(
            name,
            sa.column("id", sa.Integer),
            sa.column("result", sa.JSON),
            sa.column("content_sha256", sa.String),
        )
        rows = bind.execute(sa.select(table.c.id, table.c.result)).all()
        for row_id, document in rows:
            bind.execute(
                table.update()
                .where(table.c.id == row_id)
                .values(content_sha256=canonical_sha256(document))
            )
        with op.batch_alter_table(name) as batch:
            batch.alter_column("content_sha256", existing_type=sa.String(64), nullable=False)
            batch.create_unique_constraint(f"uq_{name}_content_sha256", ["content_sha256"])
    op.create_index("ix_run_parameters_name_run", "run_parameters", ["name", "run_id"])


def downgrade() -> None:
    op.drop_index("ix_run_parameters_name_run", "run_parameters")
    for name in TABLES:
        with op.batch_alter_table(name) as batch:
            batch.drop_constraint(f"uq_{name}_content_sha256", type_="unique")
            batch.drop_column("content_sha256")
