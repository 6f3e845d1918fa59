"""``mtm formats [NAME]``: the file formats mtm reads and writes, from the package itself.

The text is :mod:`mtmetrology.io.formats`' (the same as docs/file-formats.md).
"""

from __future__ import annotations

from typing import Annotated

import typer

from mtmetrology.cli._common import user_errors

__all__ = ["formats"]


@user_errors
def formats(
    name: Annotated[
        str | None, typer.Argument(help="A format's name (mtm formats lists them).")
    ] = None,
) -> None:
    """The file formats mtm reads and writes: list them, or describe one.

    Without NAME: each format's name and title. With NAME: its description (Markdown),
    shipped with the package, the same text as the documentation's File formats page.
    """
    from mtmetrology.io.formats import describe_format, file_formats

    if name is None:
        known = file_formats()
        width = max(len(f.name) for f in known)
        for fmt in known:
            typer.echo(f"{fmt.name:<{width}}  {fmt.title}")
        return
    typer.echo(describe_format(name).text, nl=False)
