"""Plugins: a user's own skills, sensors, worlds and layer rules, found without editing atlas-rap.

A plugin is a Python module. atlas-rap finds plugins in two ways:

- **Installed packages, through entry points** (``importlib.metadata``), one
  group per kind of thing a plugin gives:

  ======================  ============================================================
  group                   what each entry point names
  ======================  ============================================================
  ``atlas_rap.skills``    a :class:`~atlas_rap.skills.skill.Skill` subclass; the entry
                          point's name is the skill's ``name``. A *sensor* is a skill
                          (usually always on, posting facts): it goes here too.
  ``atlas_rap.worlds``    the path of a world file (a ``str`` or ``os.PathLike``
                          module attribute); the entry point's name is the world's
                          name for ``--world NAME``.
  ``atlas_rap.layer_rules``  the path of a ``.rap`` file of layer-switching memory
                          rules; its name is what ``--layer-rules NAME`` takes.
  ======================  ============================================================

  For example, in a plugin package's ``pyproject.toml``::

      [project.entry-points."atlas_rap.skills"]
      thermometer = "my_robot.skills:Thermometer"
      [project.entry-points."atlas_rap.worlds"]
      greenhouse = "my_robot.worlds:GREENHOUSE"

- **A file named on the command line**: ``--plugin FILE.py`` (repeatable) on
  ``atlas run``, ``atlas check``, ``atlas repl``, ``atlas skills list`` and
  ``atlas skills serve``. The file is imported as a module and gives its
  things in module attributes, one per entry-point group: ``ATLAS_SKILLS`` (a
  sequence of Skill classes), ``ATLAS_WORLDS`` and ``ATLAS_LAYER_RULES``
  (dicts name -> path; a relative path is relative to the file). We chose a
  command-line option over a ``(plugins ...)`` form in the mission: a
  mission stays plain RAP, which ``atlas check`` can read without running
  Python, and the same file serves every command.

Each contribution remembers where it came from (:attr:`Contribution.origin`):
the distribution's name for an entry point, the file as given for
``--plugin``. A plugin that cannot be loaded (a syntax error, an import that
fails, an exception while importing, an entry point that names nothing, a
file that gives nothing) raises :class:`PluginError`, which names the plugin
and the last line of the traceback (and where in the plugin it happened);
``atlas`` prints it and exits 2, with no traceback.

Entry points are read once per process, each group when it is first asked
for, so a command that needs no worlds does not import the plugins' world
modules; ``atlas check`` imports the skill plugins (their declarations are
their classes). This module only finds and imports plugins; what a skill
declaration must say is checked where skills are registered
(:mod:`atlas_rap.skills.catalog`).
"""

from __future__ import annotations

import importlib.util
import os
import sys
import traceback
from dataclasses import dataclass
from functools import cache
from importlib.metadata import EntryPoint, entry_points
from pathlib import Path
from types import ModuleType

from atlas_rap.errors import AtlasError, shown_path

__all__ = ["GROUPS", "Contribution", "PluginError", "contributions", "failure", "load_file", "named_files",
           "plugin_path"]

GROUPS: dict[str, str] = {"skills": "atlas_rap.skills", "worlds": "atlas_rap.worlds",
                          "layer_rules": "atlas_rap.layer_rules"}
"""Each kind of contribution and the entry-point group that gives it."""

FILE_ATTRIBUTES: dict[str, str] = {"skills": "ATLAS_SKILLS", "worlds": "ATLAS_WORLDS",
                                   "layer_rules": "ATLAS_LAYER_RULES"}
"""Each kind of contribution and the module attribute of a ``--plugin`` file that gives it."""


class PluginError(AtlasError):
    """A plugin that cannot be loaded, or whose contribution is wrong: a usage error (exit 2)."""

    exit_code = 2


@dataclass(frozen=True)
class Contribution:
    """One thing a plugin gives: its ``kind`` (a key of :data:`GROUPS`), its ``name`` (the entry
    point's, or a key of the file's dict; for a file's skill, its class's name), the object itself,
    where it came from (``origin``: a distribution's name, or the plugin file) and the ``plugin`` as
    messages name it."""

    kind: str
    name: str
    value: object
    origin: str
    plugin: str


_files: list[tuple[str, ModuleType]] = []
"""The plugin files loaded in this process, in the order given, with their modules."""


def load_file(path: str | os.PathLike[str]) -> None:
    """Import the plugin file ``path`` (``--plugin``), once; its contributions join :func:`contributions`."""
    shown = os.fspath(path)
    resolved = Path(shown).resolve()
    if any(Path(module.__file__ or "").resolve() == resolved for _, module in _files):
        return
    if not resolved.is_file():
        raise PluginError(f"plugin {shown}: no such file")
    name = f"atlas_rap_plugin_{len(_files)}_{''.join(c if c.isalnum() else '_' for c in resolved.stem)}"
    spec = importlib.util.spec_from_file_location(name, resolved)
    if spec is None or spec.loader is None:
        raise PluginError(f"plugin {shown}: not a Python file")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses and pickling look a class's module up by name
    try:
        spec.loader.exec_module(module)
    except BaseException as exc:  # noqa: BLE001 - a plugin's failure, whatever it is, is reported as the plugin's
        del sys.modules[name]
        if isinstance(exc, KeyboardInterrupt):
            raise
        raise PluginError(failure(f"plugin {shown} failed to load", exc, resolved.parent)) from None
    if not any(hasattr(module, attribute) for attribute in FILE_ATTRIBUTES.values()):
        del sys.modules[name]
        raise PluginError(f"plugin {shown}: gives nothing: define {', '.join(FILE_ATTRIBUTES.values())} "
                          f"(a list of Skill classes, dicts of name -> path)")
    _files.append((shown, module))


def contributions(kind: str) -> list[Contribution]:
    """Every ``kind`` of thing the plugins give: installed packages' entry points (by distribution
    and name), then the ``--plugin`` files in the order loaded. Raises :class:`PluginError`."""
    if kind not in GROUPS:
        raise ValueError(f"not a kind of plugin contribution: {kind}")
    return [*_installed(kind), *(item for shown, module in _files for item in _of_file(kind, shown, module))]


def named_files(kind: str) -> dict[str, tuple[Path, Contribution]]:
    """The files the plugins give as ``kind`` (``worlds``, ``layer_rules``) by name, each with its
    contribution. Two plugins that give the same name are a :class:`PluginError`."""
    found: dict[str, tuple[Path, Contribution]] = {}
    for contribution in contributions(kind):
        if contribution.name in found:
            other = found[contribution.name][1]
            raise PluginError(f"{contribution.plugin}: {_what(contribution)} '{contribution.name}' is given by "
                              f"{other.plugin} too; rename one")
        found[contribution.name] = (plugin_path(contribution), contribution)
    return found


def plugin_path(contribution: Contribution) -> Path:
    """The file a world or layer-rules contribution names (a relative path is relative to its plugin file)."""
    value = contribution.value
    if not isinstance(value, (str, os.PathLike)):
        raise PluginError(f"{contribution.plugin}: {_what(contribution)} '{contribution.name}' "
                          f"must be the path of a file, not {type(value).__name__}")
    path = Path(value)
    module = next((module for shown, module in _files if shown == contribution.origin), None)
    if not path.is_absolute() and module is not None and module.__file__:
        path = Path(module.__file__).parent / path
    if not path.is_file():
        raise PluginError(f"{contribution.plugin}: {_what(contribution)} '{contribution.name}': "
                          f"no such file {path}")
    return path


@cache
def _installed(kind: str) -> tuple[Contribution, ...]:
    """The entry points of ``kind``'s group, loaded, sorted by distribution and name (deterministic)."""
    points = sorted(entry_points(group=GROUPS[kind]), key=lambda point: (_distribution(point), point.name))
    return tuple(_load_entry_point(kind, point) for point in points)


def _load_entry_point(kind: str, point: EntryPoint) -> Contribution:
    origin = _distribution(point)
    plugin = f"plugin {origin} (entry point {point.group}: {point.name} = {point.value})"
    try:
        value = point.load()
    except BaseException as exc:  # noqa: BLE001 - see load_file
        if isinstance(exc, KeyboardInterrupt):
            raise
        module = sys.modules.get(point.module.partition(".")[0])
        where = Path(module.__file__).parent if module is not None and module.__file__ else None
        raise PluginError(failure(f"{plugin} failed to load", exc, where)) from None
    return Contribution(kind, point.name, value, origin, plugin)


def _of_file(kind: str, shown: str, module: ModuleType) -> list[Contribution]:
    attribute = FILE_ATTRIBUTES[kind]
    given = getattr(module, attribute, None)
    plugin = f"plugin {shown}"
    if given is None:
        return []
    if kind == "skills":
        if isinstance(given, (str, bytes, dict)) or not hasattr(given, "__iter__"):
            raise PluginError(f"{plugin}: {attribute} must be a list of Skill classes")
        return [Contribution(kind, getattr(item, "name", "") or "", item, shown, plugin) for item in given]
    if not isinstance(given, dict):
        raise PluginError(f"{plugin}: {attribute} must be a dict of name -> path")
    return [Contribution(kind, str(name), value, shown, plugin) for name, value in given.items()]


def _what(contribution: Contribution) -> str:
    return {"worlds": "world", "layer_rules": "layer rules", "skills": "skill"}[contribution.kind]


def _distribution(point: EntryPoint) -> str:
    dist = getattr(point, "dist", None)
    return dist.name if dist is not None else point.module.partition(".")[0]


def failure(plugin: str, exc: BaseException, folder: Path | None) -> str:
    """What a user reads when a plugin fails (to load, or a plugin's skill as it runs): the plugin, the
    traceback's last line, and
    where in the plugin's own files it happened (the deepest frame under ``folder``)."""
    last = traceback.format_exception_only(type(exc), exc)[-1].strip()
    where = ""
    if isinstance(exc, SyntaxError) and exc.filename:
        last = f"{type(exc).__name__}: {exc.msg}"
        where = f"{shown_path(exc.filename)}, line {exc.lineno}"
        if exc.text:
            where += f": {exc.text.strip()}"
    elif folder is not None:
        frames = [frame for frame in traceback.extract_tb(exc.__traceback__)
                  if Path(frame.filename).resolve().is_relative_to(folder.resolve())]
        if frames:
            where = f"{shown_path(frames[-1].filename)}, line {frames[-1].lineno}"
            if frames[-1].line:
                where += f": {frames[-1].line.strip()}"
    return f"{plugin}: {last}" + (f"\n  at {where}" if where else "")
