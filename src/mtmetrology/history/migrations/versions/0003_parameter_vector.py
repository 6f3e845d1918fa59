"""Schema version 3: each calibration run carries its parameter values as one array
(``parameter_vector``: little-endian float64 bytes, customary units, in the order of
``run_parameters.position``), so that the long-term covariance of 10^4 runs reads 10^4
rows and decodes them with one ``np.frombuffer``, not 10^4 × P rows.

Existing runs get the array from their ``run_parameters`` rows.

Revision ID: 0003
"""

import numpy as np
import sqlalchemy as sa
from alembic import op

revision = "0003"
down_revision = "0002"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.add_column("calibration_runs", sa.Column("parameter_vector", sa.LargeBinary, nullable=True))
    bind = op.get_bind()
    runs = sa.table(
        "calibration_runs",
        sa.column("id", sa.Integer),
        sa.column("parameter_vector", sa.LargeBinary),
    )
    parameters = sa.table(
        "run_parameters",
        sa.column("run_id", sa.Integer),
        sa.column("position", sa.Integer),
        sa.column("value", sa.Float),
    )
    rows = bind.execute(
        sa.select(parameters.c.run_id, parameters.c.value).order_by(
            parameters.c.run_id, parameters.c.position
        )
    ).all()
    vectors: dict[int, list[float]] = {}
    for run_id, value in rows:
        vectors.setdefault(run_id, []).append(value)
    for run_id, vector in vectors.items():
        bind.execute(
            runs.update()
            .where(runs.c.id == run_id)
            .values(parameter_vector=np.asarray(vector, dtype="<f8").tobytes())
        )


def downgrade() -> None:
    op.drop_column("calibration_runs", "parameter_vector")
