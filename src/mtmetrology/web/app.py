"""The ASGI application: :func:`create_app` over one history database.

Layers, outermost first: the security headers (:data:`~mtmetrology.web.security.
SECURITY_HEADERS` on every response that does not set its own policy), the request-size
limit (413 before a byte of an oversized body is parsed), the signed session cookie, the
history's version for the request (:class:`HistoryVersion`), then the pages
(:mod:`mtmetrology.web.pages`) and the JSON API (:mod:`mtmetrology.web.api`). The
interactive API documentation pages of FastAPI are off (they load scripts from a CDN); the
OpenAPI schema is served to authenticated clients at ``/api/v1/openapi.json``.
"""

from __future__ import annotations

import os
import secrets
from contextlib import asynccontextmanager
from importlib import resources
from pathlib import Path

import jinja2
from fastapi import FastAPI, Request
from fastapi.responses import HTMLResponse, JSONResponse, RedirectResponse
from fastapi.staticfiles import StaticFiles
from fastapi.templating import Jinja2Templates
from starlette.middleware.sessions import SessionMiddleware

from mtmetrology.errors import InputError
from mtmetrology.history.database import open_history
from mtmetrology.web import api, pages
from mtmetrology.web.lab import VERSION_SECONDS, Lab, reading
from mtmetrology.web.security import SECURITY_HEADERS, SESSION_SECONDS, Refused

__all__ = ["MAX_UPLOAD_BYTES", "SECRET_ENV", "create_app"]

#: Largest request body accepted (a result document with its covariance is well below).
MAX_UPLOAD_BYTES = 8 * 1024 * 1024
#: Environment variable holding the session-signing secret (else a file beside the data).
SECRET_ENV = "MTMETROLOGY_WEB_SECRET"


class SecurityHeaders:
    """Pure ASGI middleware: the security headers on every response (a response that
    sets its own Content-Security-Policy or X-Frame-Options keeps it)."""

    def __init__(self, app) -> None:
        self.app = app
        self.headers = [(k.lower().encode(), v.encode()) for k, v in SECURITY_HEADERS.items()]

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)

        async def sending(message):
            if message["type"] == "http.response.start":
                present = {k.lower() for k, _ in message.get("headers", [])}
                extra = [(k, v) for k, v in self.headers if k not in present]
                message["headers"] = list(message.get("headers", [])) + extra
            await send(message)

        return await self.app(scope, receive, sending)


class HistoryVersion:
    """Pure ASGI middleware around the history's version (:class:`~mtmetrology.web.lab.Lab`):
    a request that reads (GET, HEAD) sees one version, read at most once
    (:func:`~mtmetrology.web.lab.reading`); after any other request, which may write, the
    version read last is forgotten as its response starts, before the client can ask again
    (the write is committed by then), so the next read sees the change. (A
    ``BaseHTTPMiddleware`` did the second part at about 0.5 ms a request: a task group and
    memory streams around every response.)"""

    def __init__(self, app, lab: Lab) -> None:
        self.app = app
        self.lab = lab

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        if scope["method"] in ("GET", "HEAD"):
            with reading():
                return await self.app(scope, receive, send)

        async def sending(message):
            if message["type"] == "http.response.start":
                self.lab.invalidate()
            await send(message)

        return await self.app(scope, receive, sending)


class BodyLimit:
    """Pure ASGI middleware: refuse a request body over ``limit`` bytes with 413, by its
    Content-Length before reading, or as soon as a streamed body passes the limit."""

    def __init__(self, app, limit: int) -> None:
        self.app = app
        self.limit = limit

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        headers = dict(scope.get("headers", []))
        length = headers.get(b"content-length")
        if length is not None and (not length.isdigit() or int(length) > self.limit):
            return await _too_large(scope, receive, send, self.limit)
        seen = 0

        async def receiving():
            nonlocal seen
            message = await receive()
            seen += len(message.get("body", b""))
            if seen > self.limit:
                raise _TooLarge
            return message

        try:
            return await self.app(scope, receiving, send)
        except _TooLarge:
            return await _too_large(scope, receive, send, self.limit)


class _TooLarge(Exception):
    pass


async def _too_large(scope, receive, send, limit: int):
    response = JSONResponse({"error": f"request body over {limit} bytes"}, status_code=413)
    await response(scope, receive, send)


def _secret(url: str) -> str:
    """The session-signing secret: ``$MTMETROLOGY_WEB_SECRET``, else a random one kept in
    ``web-secret`` (mode 0600) beside a SQLite database or in the user's data directory."""
    if os.environ.get(SECRET_ENV):
        return os.environ[SECRET_ENV]
    from mtmetrology.history.database import default_location

    folder = (
        Path(url.removeprefix("sqlite:///")).parent
        if url.startswith("sqlite:///")
        else default_location().parent
    )
    path = folder / "web-secret"
    if not path.exists():
        folder.mkdir(parents=True, exist_ok=True)
        # written whole under another name, then linked: a process starting at the same time
        # (a worker) reads either no file or the whole secret, and one secret wins
        spare = folder / f".web-secret-{os.getpid()}-{secrets.token_hex(4)}"
        fd = os.open(spare, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        with os.fdopen(fd, "w") as fh:
            fh.write(secrets.token_urlsafe(48))
        try:
            os.link(spare, path)
        except FileExistsError:
            pass
        finally:
            spare.unlink()
    return path.read_text().strip()


def create_app(
    db: str | os.PathLike | None = None,
    *,
    secret: str | None = None,
    max_upload_bytes: int = MAX_UPLOAD_BYTES,
    https_only: bool = False,
    version_seconds: float = VERSION_SECONDS,
) -> FastAPI:
    """The web application over the history database ``db`` (as ``mtm history --db``).

    Parameters
    ----------
    db : str or path, optional
        SQLite file or URL; default ``$MTMETROLOGY_DB`` or the user's history file.
    secret : str, optional
        Key that signs the session cookies (default: :func:`_secret`).
    max_upload_bytes : int
        Largest request body.
    https_only : bool
        Mark the session cookie ``Secure`` (behind a TLS proxy).
    version_seconds : float
        How long the history's version is trusted before it is read again
        (:class:`~mtmetrology.web.lab.Lab`); 0 when several processes serve the history.
    """
    from mtmetrology.history.database import database_url

    engine = open_history(db, pooled=True)

    @asynccontextmanager
    async def lifespan(_app):
        yield
        engine.dispose()  # the pooled connections: no file handle outlives the server

    app = FastAPI(
        lifespan=lifespan,
        title="mtmetrology laboratory",
        version="1",
        docs_url=None,
        redoc_url=None,
        openapi_url=None,
    )
    app.state.engine = engine
    app.state.lab = Lab(engine, version_seconds)
    app.state.max_upload = max_upload_bytes
    # every template escapes what it shows (select_autoescape would miss the .j2 suffix)
    templates = Jinja2Templates(
        env=jinja2.Environment(
            loader=jinja2.FileSystemLoader(str(resources.files("mtmetrology.web") / "templates")),
            autoescape=True,
        )
    )
    app.state.templates = templates
    app.mount(
        "/static",
        StaticFiles(directory=str(resources.files("mtmetrology.web") / "static")),
        name="static",
    )
    app.include_router(pages.router)
    app.include_router(api.router)

    @app.exception_handler(Refused)
    async def refused(request: Request, exc: Refused):
        if request.url.path.startswith("/api/"):
            headers = {"WWW-Authenticate": "Bearer"} if exc.status == 401 else {}
            return JSONResponse({"error": exc.message}, exc.status, headers=headers)
        if exc.status == 401:
            return RedirectResponse("/login", status_code=303)
        return _error_page(request, exc.status, exc.message)

    @app.exception_handler(PermissionError)
    async def forbidden(request: Request, exc: PermissionError):
        return await refused(request, Refused(403, str(exc)))

    @app.exception_handler(InputError)
    async def input_error(request: Request, exc: InputError):
        if request.url.path.startswith("/api/"):
            return JSONResponse({"error": str(exc)}, 400)
        return _error_page(request, 400, str(exc))

    app.add_middleware(HistoryVersion, lab=app.state.lab)
    app.add_middleware(
        SessionMiddleware,
        secret_key=secret or _secret(database_url(db)),
        session_cookie="mtm_session",
        max_age=SESSION_SECONDS,
        same_site="strict",
        https_only=https_only,
    )
    app.add_middleware(BodyLimit, limit=max_upload_bytes)
    app.add_middleware(SecurityHeaders)
    return app


def worker_app() -> FastAPI:
    """The application of one of several uvicorn worker processes (``mtm serve --workers``):
    the database from ``$MTMETROLOGY_DB``, the secret shared through its file (or
    ``$MTMETROLOGY_WEB_SECRET``), the history's version read at every request (each process
    has its own cache; a write through one must show at the next request of any)."""
    return create_app(version_seconds=0.0)


def _error_page(request: Request, status: int, message: str) -> HTMLResponse:
    templates = request.app.state.templates
    return templates.TemplateResponse(
        request,
        "error.html.j2",
        {"status": status, "message": message, "user": None, "csrf": ""},
        status_code=status,
    )
