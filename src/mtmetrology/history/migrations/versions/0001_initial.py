"""Schema version 1: machines, calibration runs with their parameters, task and
verification results.

Revision ID: 0001
"""

import sqlalchemy as sa
from alembic import op

revision = "0001"
down_revision = None
branch_labels = None
depends_on = None


def _documents(name: str) -> None:
    op.create_table(
        name,
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("machine_id", sa.Integer, sa.ForeignKey("machines.id"), nullable=False),
        sa.Column("kind", sa.String(100), nullable=False),
        sa.Column("performed_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("recorded_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("software_version", sa.String(100), nullable=False),
        sa.Column("operator_note", sa.Text),
        sa.Column("input_hashes", sa.JSON, nullable=False),
        sa.Column("result", sa.JSON, nullable=False),
    )
    op.create_index(f"ix_{name}_machine_id", name, ["machine_id"])


def upgrade() -> None:
    op.create_table(
        "machines",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("name", sa.String(200), nullable=False, unique=True),
        sa.Column("topology", sa.String(200)),
        sa.Column("model", sa.String(200)),
        sa.Column("serial", sa.String(200)),
    )
    op.create_table(
        "calibration_runs",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("machine_id", sa.Integer, sa.ForeignKey("machines.id"), nullable=False),
        sa.Column("kind", sa.String(100), nullable=False),
        sa.Column("performed_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("recorded_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("software_version", sa.String(100), nullable=False),
        sa.Column("operator_note", sa.Text),
        sa.Column("artefact", sa.String(500)),
        sa.Column("temperature_c", sa.Float),
        sa.Column("residual_statistics", sa.JSON, nullable=False),
        sa.Column("input_hashes", sa.JSON, nullable=False),
        sa.Column("result", sa.JSON, nullable=False),
    )
    op.create_index("ix_calibration_runs_machine_id", "calibration_runs", ["machine_id"])
    op.create_index("ix_calibration_runs_performed_at", "calibration_runs", ["performed_at"])
    op.create_table(
        "run_parameters",
        sa.Column(
            "run_id",
            sa.Integer,
            sa.ForeignKey("calibration_runs.id", ondelete="CASCADE"),
            primary_key=True,
        ),
        sa.Column("position", sa.Integer, primary_key=True),
        sa.Column("name", sa.String(50), nullable=False),
        sa.Column("unit", sa.String(20), nullable=False),
        sa.Column("value", sa.Float, nullable=False),
        sa.Column("u", sa.Float),
    )
    _documents("task_results")
    _documents("verification_results")


def downgrade() -> None:
    for name in ("verification_results", "task_results", "run_parameters"):
        op.drop_table(name)
    op.drop_table("calibration_runs")
    op.drop_table("machines")
