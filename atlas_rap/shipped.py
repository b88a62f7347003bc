"""Files that ship with atlas-rap: ``rap_library/``, ``operators/``, ``worlds/``.

In a checkout they sit at the top of the repository; installed, they are
package data (``atlas_rap.rap_library`` and friends). Use
:func:`resolve_user_path` on a path a user typed: an existing file is taken
as it is; a path such as ``rap_library/missions/site-visit.rap`` that does
not exist here falls back to the installed copy, so the docs' commands
work from any directory.
"""

from __future__ import annotations

from pathlib import Path

SHIPPED_FOLDERS = ("rap_library", "operators", "worlds")


def shipped_root(folder: str) -> Path | None:
    """The folder of shipped files: installed package data, else the checkout's."""
    if folder not in SHIPPED_FOLDERS:
        raise ValueError(f"not a shipped folder: {folder}")
    package = Path(__file__).resolve().parent
    for root in (package / folder, package.parent / folder):
        if root.is_dir():
            return root
    return None


def resolve_user_path(path: str | Path) -> Path:
    """``path`` if it exists, else its shipped copy if there is one, else ``path``."""
    given = Path(path)
    if given.exists() or given.is_absolute() or not given.parts:
        return given
    folder = given.parts[0]
    if folder in SHIPPED_FOLDERS:
        root = shipped_root(folder)
        if root is not None:
            candidate = root.joinpath(*given.parts[1:])
            if candidate.exists():
                return candidate
    return given


def shipped_worlds() -> list[str]:
    """Names of the worlds that ship with atlas-rap (``worlds/*.yaml``), sorted."""
    root = shipped_root("worlds")
    if root is None:
        return []
    return sorted(p.stem for p in root.glob("*.yaml"))
