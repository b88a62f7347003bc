"""Where the CLI prints, and whether it styles what it prints.

Colours and styles (bold, dim) go only to a terminal, and never when the
``NO_COLOR`` environment variable is set to anything but the empty string
(https://no-color.org). Every command prints through :func:`console` (rich)
or :func:`secho` (click), so that one rule holds everywhere.
"""

from __future__ import annotations

import os
import sys

from typing import TYPE_CHECKING

import click

if TYPE_CHECKING:
    from rich.console import Console


def styles_on(err: bool = False) -> bool:
    """True when output to stdout (or stderr with ``err``) may carry colours and styles."""
    if os.environ.get("NO_COLOR"):
        return False
    stream = sys.stderr if err else sys.stdout
    return bool(getattr(stream, "isatty", lambda: False)())


def console(err: bool = False, **options) -> Console:
    """A rich console for stdout (stderr with ``err``), styled only where :func:`styles_on` says."""
    from rich.console import Console  # not at import: `atlas check` starts without rich

    styled = styles_on(err)
    options.setdefault("highlight", False)
    options.setdefault("soft_wrap", True)
    if not styled:
        options.setdefault("color_system", None)
        options.setdefault("no_color", True)
    return Console(stderr=err, **options)


def secho(message: str, err: bool = False, **styles) -> None:
    """``click.secho`` under the same rule: styles only where :func:`styles_on` says."""
    click.secho(message, err=err, color=styles_on(err), **styles)
