"""Schema version 4: dates are instants, stored in UTC on every backend, with the offset
they were given in kept beside them (``performed_at_offset_min``, minutes east of UTC).

Existing rows keep their dates: PostgreSQL's already are instants; on SQLite a date
recorded with an offset before this version lost it (the wall-clock time was stored as
UTC) and cannot be recovered, so those rows get a NULL offset ("not recorded").
Databases that passed revision 0002 before it set duplicates aside get the (empty)
``duplicate_results`` table.

Revision ID: 0004
"""

import sqlalchemy as sa
from alembic import op

from mtmetrology.history.schema import DuplicateResult

revision = "0004"
down_revision = "0003"
branch_labels = None
depends_on = None

TABLES = ("calibration_runs", "task_results", "verification_results")


def upgrade() -> None:
    # ADD COLUMN only: on SQLite nothing is rebuilt (see 0002)
    for name in TABLES:
        op.add_column(name, sa.Column("performed_at_offset_min", sa.Integer, nullable=True))
    DuplicateResult.__table__.create(op.get_bind(), checkfirst=True)


def downgrade() -> None:
    for name in TABLES:
        op.drop_column(name, "performed_at_offset_min")
