"""``mtm serve``: the laboratory's web application over the calibration history (issue 34).

``mtm serve`` runs it (uvicorn); ``mtm serve create-admin`` adds an administrator from the
terminal; ``mtm serve demo-lab`` fills a history with a demonstration laboratory built from
the output of ``mtm demo`` (``make serve``).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated

import typer

from mtmetrology.cli._common import user_errors
from mtmetrology.errors import InputError

app = typer.Typer(
    help="The laboratory's web application: machines, due dates, trends, audit trail.",
    invoke_without_command=True,
)

Db = Annotated[
    str | None,
    typer.Option("--db", help="SQLite file or URL (postgresql://...) [$MTMETROLOGY_DB]."),
]
#: How long the uvicorn supervisor waits for a busy worker's answer before killing it.
WORKER_HEALTHCHECK_SECONDS = 120
Workers = Annotated[
    int,
    typer.Option(
        "--workers",
        help="Server processes (one per core; each keeps its own cache of the charts).",
    ),
]
#: Environment variable with the administrator's password (scripts; else a prompt).
PASSWORD_ENV = "MTM_ADMIN_PASSWORD"


def _run(db: str | None, host: str, port: int, workers: int = 1) -> None:
    import uvicorn

    from mtmetrology.web import create_app

    if workers < 1:
        raise InputError(f"--workers {workers}: at least 1")
    # opens (upgrades) the history and makes the session secret before any worker starts
    application = create_app(db)
    typer.echo(f"serving the history on http://{host}:{port} (Ctrl-C stops)", err=True)
    if workers == 1:
        uvicorn.run(application, host=host, port=port, log_level="warning", proxy_headers=False)
        return
    if db is not None:
        os.environ["MTMETROLOGY_DB"] = str(db)  # the workers' history
    uvicorn.run(
        "mtmetrology.web.app:worker_app",
        factory=True,
        workers=workers,
        # a worker computing the charts after a change (10-20 s for 10^4 runs of the
        # 84-coefficient model) answers the supervisor's ping late; at uvicorn's 5 s it was
        # killed mid-computation and its connections reset
        timeout_worker_healthcheck=WORKER_HEALTHCHECK_SECONDS,
        host=host,
        port=port,
        log_level="warning",
        proxy_headers=False,
    )


@app.callback()
@user_errors
def serve(
    ctx: typer.Context,
    db: Db = None,
    host: Annotated[str, typer.Option("--host", help="Address to listen on.")] = "127.0.0.1",
    port: Annotated[int, typer.Option("--port", help="TCP port.")] = 8000,
    workers: Workers = 1,
) -> None:
    """Run the web application (machines, due dates, trends, reports, audit trail)."""
    if ctx.invoked_subcommand is None:
        _run(db, host, port, workers)
    else:
        ctx.obj = {"db": db, "host": host, "port": port}


@app.command("run")
@user_errors
def run(
    db: Db = None,
    host: Annotated[str, typer.Option("--host", help="Address to listen on.")] = "127.0.0.1",
    port: Annotated[int, typer.Option("--port", help="TCP port.")] = 8000,
    workers: Workers = 1,
) -> None:
    """Run the web application (the same as mtm serve)."""
    _run(db, host, port, workers)


@app.command("create-admin")
@user_errors
def create_admin(
    username: Annotated[str, typer.Argument(help="The administrator's user name.")],
    db: Db = None,
) -> None:
    """Add an administrator (password from $MTM_ADMIN_PASSWORD or a prompt)."""
    import getpass

    from mtmetrology.history import open_history
    from mtmetrology.web.security import create_user

    password = os.environ.get(PASSWORD_ENV) or typer.prompt(
        "password", hide_input=True, confirmation_prompt=True
    )
    create_user(open_history(db), username, password, "admin", by=f"cli:{getpass.getuser()}")
    typer.echo(f"administrator {username} created", err=True)


@app.command("demo-lab")
@user_errors
def demo_lab(
    demo: Annotated[Path, typer.Option("--from", help="Folder written by mtm demo.")],
    db: Db = None,
) -> None:
    """Fill a new history with a demonstration laboratory from mtm demo's calibration."""
    from mtmetrology.history import open_history
    from mtmetrology.web.demo import build_demo_lab

    if db is None:
        raise InputError("--db: name the demonstration database (not your own history)")
    summary = build_demo_lab(open_history(db), demo)
    typer.echo(summary, err=True)
