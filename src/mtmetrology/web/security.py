"""Who may do what: users, passwords, sessions, CSRF, API tokens, login rate limit and the
HTTP security headers of the web application.

- Passwords are argon2id hashes (:mod:`argon2`, RFC 9106 defaults of argon2-cffi); an
  unknown user name is checked against a dummy hash, so the answer takes as long.
- A session is a cookie signed with the application's secret (itsdangerous, through
  Starlette's ``SessionMiddleware``) that expires :data:`SESSION_SECONDS` after login
  (the signature's timestamp is checked on every request); it holds the user id and the
  session's CSRF token. ``SameSite=Strict``, ``HttpOnly``.
- Every form carries the session's CSRF token (a hidden field ``csrf``); a POST without the
  token of its session is refused (403) before anything is read or written.
- API tokens are 256-bit random secrets (shown once); the database keeps their SHA-256 (a
  fast hash suffices for a secret of full entropy), and a revoked token is refused.
- Login: :data:`LOCK_AFTER` wrong passwords for one user name within
  :data:`LOCK_SECONDS` lock that name for the rest of the window. The count is read from
  the audit log (every attempt writes one row), so it holds across processes and restarts.
"""

from __future__ import annotations

import hashlib
import hmac
import secrets
from datetime import UTC, datetime, timedelta

from argon2 import PasswordHasher
from argon2.exceptions import InvalidHashError, VerificationError
from sqlalchemy import bindparam, func, select
from sqlalchemy.orm import Session

from mtmetrology.errors import InputError
from mtmetrology.history.audit import ROLES, ApiToken, AuditEntry, User, audit
from mtmetrology.history.database import writer

__all__ = [
    "CSP",
    "LOCK_AFTER",
    "LOCK_SECONDS",
    "SECURITY_HEADERS",
    "SESSION_SECONDS",
    "Refused",
    "authenticate",
    "create_token",
    "create_user",
    "csrf_valid",
    "new_csrf",
    "revoke_token",
    "token_user",
]

SESSION_SECONDS = 8 * 3600
LOCK_AFTER = 10
LOCK_SECONDS = 15 * 60
TOKEN_PREFIX = "mtm_"

#: No inline script or style anywhere: scripts and styles come from /static only.
CSP = (
    "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
    "connect-src 'self'; form-action 'self'; frame-src 'self'; frame-ancestors 'none'; "
    "base-uri 'none'"
)
#: The stored report and the SVG figures carry their own inline styles and no script:
#: served with a policy that allows those styles and nothing else, framed by our pages only.
DOCUMENT_CSP = (
    "default-src 'none'; style-src 'unsafe-inline'; img-src data:; frame-ancestors 'self'"
)
SECURITY_HEADERS = {
    "Content-Security-Policy": CSP,
    "X-Frame-Options": "DENY",
    "Referrer-Policy": "no-referrer",
    "X-Content-Type-Options": "nosniff",
    "Cross-Origin-Opener-Policy": "same-origin",
    "Cache-Control": "no-store",
}


class Refused(Exception):
    """A request the user may not make: ``status`` 401 (no login), 403 (no right)."""

    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status
        self.message = message


_HASHER = PasswordHasher()
_DUMMY = _HASHER.hash(secrets.token_hex(16))


def hash_password(password: str) -> str:
    """The argon2id hash of ``password`` (at least 10 characters)."""
    if not isinstance(password, str) or len(password) < 10:
        raise InputError("password: at least 10 characters")
    return _HASHER.hash(password)


def create_user(engine, username: str, password: str, role: str, *, by: str) -> int:
    """Add a user (audited); returns its id.

    Raises
    ------
    InputError
        A user name not 1–100 letters, digits, ``.-_@``; a short password; an unknown
        role; a name already taken.
    """
    if not (isinstance(username, str) and 0 < len(username) <= 100) or not all(
        c.isalnum() or c in ".-_@" for c in username
    ):
        raise InputError(f"username {username!r}: 1 to 100 letters, digits or .-_@")
    if role not in ROLES:
        raise InputError(f"role {role!r}: one of {', '.join(ROLES)}")
    hashed = hash_password(password)
    with Session(writer(engine)) as session, session.begin():
        if session.scalar(select(User.id).where(User.username == username)) is not None:
            raise InputError(f"username {username!r}: already taken")
        user = User(
            username=username,
            password_hash=hashed,
            role=role,
            active=True,
            created_at=datetime.now(UTC),
        )
        session.add(user)
        session.flush()
        audit(session, by, "user-create", f"user {username}", {"role": role})
        return user.id


def set_user(engine, user_id: int, *, role: str | None, active: bool | None, by: str) -> None:
    """Change a user's role or deactivate/reactivate them (audited)."""
    if role is not None and role not in ROLES:
        raise InputError(f"role {role!r}: one of {', '.join(ROLES)}")
    with Session(writer(engine)) as session, session.begin():
        user = session.get(User, user_id)
        if user is None:
            raise InputError(f"user {user_id}: no such user")
        before = {"role": user.role, "active": user.active}
        if role is not None:
            user.role = role
        if active is not None:
            user.active = active
        after = {"role": user.role, "active": user.active}
        audit(
            session, by, "user-change", f"user {user.username}", {"before": before, "after": after}
        )


def _recent_failures(session: Session, username: str, now: datetime) -> int:
    since = now - timedelta(seconds=LOCK_SECONDS)
    return session.scalar(
        select(func.count())
        .select_from(AuditEntry)
        .where(
            AuditEntry.action == "login-failed",
            AuditEntry.target == f"user {username}",
            AuditEntry.at >= since,
        )
    )


def authenticate(engine, username: str, password: str, client: str) -> tuple[User | None, str]:
    """Check a login (one audit row: ``login``, ``login-failed`` or ``login-locked``).

    Returns
    -------
    user, outcome
        The user (None when refused) and ``ok``, ``failed`` or ``locked``.
    """
    username = str(username)[:100]
    now = datetime.now(UTC)
    with Session(writer(engine)) as session, session.begin():
        if _recent_failures(session, username, now) >= LOCK_AFTER:
            audit(session, username, "login-locked", f"user {username}", {"client": client})
            return None, "locked"
        user = session.scalar(select(User).where(User.username == username))
        try:
            ok = _HASHER.verify(user.password_hash if user else _DUMMY, password)
        except (VerificationError, InvalidHashError):
            ok = False
        ok = ok and user is not None and user.active
        action = "login" if ok else "login-failed"
        audit(session, username, action, f"user {username}", {"client": client})
        if not ok:
            return None, "failed"
        session.expunge(user)
        return user, "ok"


def new_csrf() -> str:
    """A fresh CSRF token for a session."""
    return secrets.token_urlsafe(32)


def csrf_valid(session: dict, supplied: object) -> bool:
    """Whether ``supplied`` is the session's CSRF token (constant-time comparison)."""
    expected = session.get("csrf")
    return (
        isinstance(expected, str)
        and isinstance(supplied, str)
        and hmac.compare_digest(expected.encode(), supplied.encode())
    )


def _token_hash(secret: str) -> str:
    return hashlib.sha256(secret.encode()).hexdigest()


def create_token(engine, user_id: int, name: str, *, by: str) -> str:
    """A new API token of a user (audited); the secret is returned once, never stored."""
    if not isinstance(name, str) or not 0 < len(name.strip()) <= 100:
        raise InputError("token name: 1 to 100 characters")
    secret = TOKEN_PREFIX + secrets.token_urlsafe(32)
    with Session(writer(engine)) as session, session.begin():
        user = session.get(User, user_id)
        if user is None:
            raise InputError(f"user {user_id}: no such user")
        token = ApiToken(
            user_id=user_id,
            name=name.strip(),
            token_sha256=_token_hash(secret),
            created_at=datetime.now(UTC),
        )
        session.add(token)
        session.flush()
        audit(session, by, "token-create", f"token {token.id}", {"user": user.username})
    return secret


def revoke_token(engine, token_id: int, *, user_id: int | None, by: str) -> None:
    """Revoke a token (audited); ``user_id``: only that user's tokens (None: any, admin)."""
    with Session(writer(engine)) as session, session.begin():
        token = session.get(ApiToken, token_id)
        if token is None or (user_id is not None and token.user_id != user_id):
            raise InputError(f"token {token_id}: no such token")
        if token.revoked_at is None:
            token.revoked_at = datetime.now(UTC)
        audit(session, by, "token-revoke", f"token {token_id}", {})


def list_tokens(engine, user_id: int) -> list[dict]:
    """A user's tokens (names and dates; the secrets are not kept)."""
    with Session(engine) as session:
        rows = session.scalars(
            select(ApiToken).where(ApiToken.user_id == user_id).order_by(ApiToken.id)
        )
        return [
            {
                "id": t.id,
                "name": t.name,
                "created_at": t.created_at,
                "revoked": t.revoked_at is not None,
            }
            for t in rows
        ]


def token_user(engine, secret: str) -> User | None:
    """The active user of a valid, unrevoked token; else None."""
    if not secret.startswith(TOKEN_PREFIX) or len(secret) > 200:
        return None
    with Session(engine) as session:
        user = session.scalar(
            select(User)
            .join(ApiToken, ApiToken.user_id == User.id)
            .where(ApiToken.token_sha256 == _token_hash(secret), ApiToken.revoked_at.is_(None))
        )
        if user is None or not user.active:
            return None
        session.expunge(user)
        return user


#: A session's user, if active: a Core select on a pooled connection (0.09 ms against
#: 0.28 ms for an ORM session's ``get``; it runs on every request, so that a deactivated
#: user is refused at the next one).
_ACTIVE_USER = select(User.id, User.username, User.role).where(
    User.id == bindparam("uid"), User.active.is_(True)
)


def session_user(engine, user_id: object) -> User | None:
    """The active user of a session's user id (detached: read, never written); else None."""
    if not isinstance(user_id, int):
        return None
    with engine.connect() as connection:
        row = connection.execute(_ACTIVE_USER, {"uid": user_id}).one_or_none()
    if row is None:
        return None
    return User(id=row.id, username=row.username, role=row.role, active=True)


def list_users(engine) -> list[User]:
    """Every user, by name."""
    with Session(engine) as session:
        users = list(session.scalars(select(User).order_by(User.username)))
        for u in users:
            session.expunge(u)
        return users


def may(user: User, role: str) -> bool:
    """Whether ``user``'s role includes ``role`` (viewer < engineer < admin)."""
    return ROLES.index(user.role) >= ROLES.index(role)
