"""Alembic environment of the calibration history: run on the connection it is given.

:func:`mtmetrology.history.database.open_history` passes the connection in
``config.attributes["connection"]``; nothing here reads a URL or an ini file.
"""

from alembic import context
from sqlalchemy import text

from mtmetrology.history.schema import Base


def run_migrations(connection) -> None:
    """Run the pending migrations in one transaction on ``connection``."""
    context.configure(connection=connection, target_metadata=Base.metadata)
    with context.begin_transaction():
        if connection.dialect.name == "postgresql":
            # two processes opening a new database at once: one migrates, the other waits
            connection.execute(text("SELECT pg_advisory_xact_lock(24024)"))
        context.run_migrations()


if getattr(context, "config", None) is not None:  # run by Alembic, not imported by a collector
    run_migrations(context.config.attributes["connection"])
