"""Output paths: every file or folder a command writes is prepared the same way.

``--trace``, ``--render``, ``--plan-file``, ``--out``, ``--map-out``, the
REPL's ``:save`` and ``:map``: a missing parent folder is created (as
``mkdir -p`` would), and when that cannot be done the user gets a one-line
:class:`~atlas_rap.errors.AtlasError` naming the option and the reason,
never a traceback. Prepare a path before the work that fills it starts, so
a long run does not end in a path error.
"""

from __future__ import annotations

import os
from pathlib import Path

from atlas_rap.errors import AtlasError


class OutputError(AtlasError):
    """An output file or folder that cannot be created or written."""


def output_file(path: str | os.PathLike, what: str = "output") -> Path:
    """``path`` as a file that can be written: its parent folder made if missing.

    ``what`` names the option or command in the error (``"--trace"``).
    """
    target = Path(path)
    if target.is_dir():
        raise OutputError(f"{what} {target}: is a folder; give a file name")
    _make_folder(target.parent, what, target)
    if target.exists() and not os.access(target, os.W_OK):
        raise OutputError(f"{what} {target}: cannot write it (permission denied)")
    return target


def output_folder(path: str | os.PathLike, what: str = "--out") -> Path:
    """``path`` as a folder that exists (made, with its parents, if missing)."""
    target = Path(path)
    if target.exists() and not target.is_dir():
        raise OutputError(f"{what} {target}: is a file, not a folder")
    _make_folder(target, what, target)
    return target


def _make_folder(folder: Path, what: str, target: Path) -> None:
    if folder == Path("") or folder.is_dir():
        return
    blocking = next((part for part in (folder, *folder.parents) if part.exists() and not part.is_dir()), None)
    if blocking is not None:
        raise OutputError(f"{what} {target}: cannot create the folder {folder}: {blocking} is a file")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        reason = exc.strerror or str(exc)
        raise OutputError(f"{what} {target}: cannot create the folder {folder} ({reason})") from None
