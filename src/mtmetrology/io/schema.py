"""Messages for schema (pydantic) validation errors of user files."""

from __future__ import annotations

from pydantic import ValidationError

__all__ = ["describe_validation_error"]


def describe_validation_error(source: str, what: str, err: ValidationError) -> str:
    """One line per problem, each naming the field path: ``axes.B.travel_deg: ...``.

    Parameters
    ----------
    source : str
        The file (or other origin) being read.
    what : str
        What the file should have been, e.g. ``"machine definition"``.
    err : pydantic.ValidationError
    """
    lines = [f"{source}: invalid {what}"]
    for e in err.errors():
        path = ".".join(str(p) for p in e["loc"]) or "(top level)"
        lines.append(f"  {path}: {e['msg']}")
    return "\n".join(lines)
