"""Option types shared by the commands: output paths, positive numbers, the world option.

- :class:`OutputFile` / :class:`OutputFolder`: a path the command will
  write; its missing parent folders are made and the path tried as the
  option is read, and a path that cannot be written is a one-line error
  (``atlas_rap.outputs``). :func:`check_outputs` then refuses an output
  that is one of the command's input files or another output; the CLI
  calls it for every command before the command starts
  (:func:`outputs_checked`, applied in ``cli/main.py``).
- :data:`POSITIVE` / :data:`NON_NEGATIVE`: click ranges for seconds, speeds
  and sizes, so ``--until -5`` is refused with a usage error; so are
  ``nan``, ``inf`` and numbers too large for a float (``1e400``).
- :data:`SEED`: a seed for the run's random numbers, a whole number from 0
  to 2**63 - 1 (numpy takes no negative seed).
- :func:`world_help`: the ``--world`` help text, naming the worlds read
  from the shipped ``worlds/`` folder (never a hand-kept list).
- :data:`PLUGIN`: ``--plugin FILE.py``, loaded before the other options;
  :class:`LayerRules`: ``--layer-rules`` as a file or a plugin's name.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING

import click

if TYPE_CHECKING:  # downward only; imported when a run is built, so every command starts quickly
    from atlas_rap.layers import RunOptions
    from atlas_rap.skillbus.remote import BusSettings


class FiniteRange(click.FloatRange):
    """A click float range that refuses ``nan`` and infinities (``inf``, ``1e400``), which
    ``click.FloatRange`` lets through (``nan`` compares false with every bound)."""

    def convert(self, value, param, ctx):
        number = super().convert(value, param, ctx)
        if not math.isfinite(number):
            what = "not a number" if number != number else "not a finite number"
            self.fail(f"{value!r} is {what}; give an amount such as 10 or 2.5", param, ctx)
        return number


POSITIVE = FiniteRange(min=0, min_open=True)
"""A finite number greater than zero (seconds, speeds, radii)."""

NON_NEGATIVE = FiniteRange(min=0)
"""A finite number at least zero."""

SEED = click.IntRange(0, 2 ** 63 - 1)
"""A seed: a whole number from 0 to 2**63 - 1."""


class OutputFile(click.ParamType):
    """A file the command writes; its parent folder is created if missing.

    ``suffix``: the ending the writer gives a file name without it (``.npz``: ``--map-out m``
    writes ``m.npz``), added here so that the path checked is the path written; a device
    (``/dev/null``) is written as it is named.
    """

    name = "file"

    def __init__(self, suffix: str = "") -> None:
        self.suffix = suffix

    def convert(self, value, param, ctx):
        import os

        from atlas_rap.outputs import output_file

        if self.suffix and not str(value).endswith(self.suffix) and (os.path.isfile(value) or
                                                                     not os.path.exists(value)):
            value = f"{value}{self.suffix}"
        return str(output_file(value, _option(param)))


class OutputFolder(click.ParamType):
    """A folder the command writes into; created (with its parents) if missing.

    ``writes``: a function giving the names (glob patterns) of the files the
    command writes in it, so that :func:`check_outputs` can refuse a folder
    where one of them is an input of the command (a function: the names live
    in modules the CLI imports only when a command runs).
    """

    name = "folder"

    def __init__(self, writes: Callable[[], Iterable[str]] = tuple) -> None:
        self.writes = writes

    def convert(self, value, param, ctx):
        from atlas_rap.outputs import output_folder

        return str(output_folder(value, _option(param)))


INPUT_NAMES = ("world", "layer_rules")
"""Options that take a name (a shipped world, a plugin's world or layer rules) or a file: an input when
they name a file."""

PLUGIN_FILES = "atlas_rap.plugin_files"
"""Where ``--plugin`` keeps its files in the click context's ``meta``: inputs of the command."""


def check_outputs(ctx: click.Context, more: dict | None = None) -> None:
    """Refuse (exit 2) an output option of the command that is one of its input files (a
    ``click.Path`` parameter, a world file) or another of its outputs (``atlas_rap.outputs.check_apart``).

    ``more``: inputs the command found while loading (what is read -> paths), checked
    by the command itself once it knows them (the files a mission includes).
    """
    outputs, folders, inputs = {}, {}, {}
    for param in ctx.command.params:
        value = ctx.params.get(param.name)
        if value is None or value == ():
            continue
        label = _option(param) if isinstance(param, click.Option) else (param.metavar or param.name.upper())
        simple = label.replace(".", "").replace("-", "").isalnum()  # MISSION.rap, --map-in; not [FILE...]
        named = f"the input {label}" if simple else "an input"
        if isinstance(param.type, (OutputFile, OutputFolder)):
            outputs[label] = value
            if isinstance(param.type, OutputFolder):
                folders[label] = tuple(param.type.writes())
        elif isinstance(param.type, click.Path) or param.name in INPUT_NAMES:
            inputs[f"{named} of this command"] = value if isinstance(value, tuple) else (value,)
    if ctx.meta.get(PLUGIN_FILES):
        inputs["a plugin file of this command"] = ctx.meta[PLUGIN_FILES]
    if outputs:  # (atlas check writes nothing: its cold start stays as it was)
        from atlas_rap.outputs import check_apart

        check_apart(outputs, {**inputs, **(more or {})}, folders=folders)


def engine_inputs(engine) -> dict[str, list]:
    """What a loaded mission engine read besides the command's own arguments (the files its
    programs include, the layer rules, the world file), as :func:`check_outputs` takes them."""
    return {"a file the mission reads": sorted(engine.library.files), "the world file": [engine.world_file]}


def outputs_checked(command: click.Command) -> None:
    """Make ``command`` (and every command of a group) call :func:`check_outputs` before it starts."""
    import functools

    if isinstance(command, click.Group):
        for sub in command.commands.values():
            outputs_checked(sub)
        return
    callback = command.callback
    if callback is None or getattr(callback, "outputs_checked", False):
        return

    @functools.wraps(callback)
    def checked(*args, **kwargs):
        check_outputs(click.get_current_context())
        return callback(*args, **kwargs)

    checked.outputs_checked = True  # type: ignore[attr-defined]
    command.callback = checked


LIVE_PORT = click.option("--live-port", type=click.IntRange(0, 65535), default=8765, show_default=True,
                         metavar="PORT", help="The port --live listens on, on 127.0.0.1 (0: any free port).")
"""``--live-port``, for the commands that serve a run to Foxglove (``atlas run``, ``atlas skills serve``)."""


def _load_plugins(ctx: click.Context, param: click.Parameter, files: tuple[str, ...]) -> tuple[str, ...]:
    """Import each plugin file, then check what every plugin gives (skills' declarations, worlds' and
    layer rules' files), so that a wrong plugin named here is reported before the command starts."""
    if not files:
        return files
    from atlas_rap.plugins import load_file, named_files
    from atlas_rap.skills.catalog import plugin_specs

    for path in files:
        load_file(path)
    ctx.meta[PLUGIN_FILES] = files
    plugin_specs()
    named_files("worlds")
    named_files("layer_rules")
    return files


PLUGIN = click.option("--plugin", "plugins", multiple=True, metavar="FILE.py", is_eager=True, expose_value=False,
                      type=click.Path(dir_okay=False), callback=_load_plugins,
                      help="Load a plugin file first (repeatable): the skills, worlds and layer rules it gives "
                           "in ATLAS_SKILLS, ATLAS_WORLDS and ATLAS_LAYER_RULES join the installed plugins' "
                           "(see atlas skills list).")
"""``--plugin FILE.py`` (:mod:`atlas_rap.plugins`), read before the other options so that ``--world`` and
``--layer-rules`` can name what the file gives; for the commands that load skills, worlds or missions."""


class LayerRules(click.ParamType):
    """``--layer-rules``: a ``.rap`` file of layer-switching rules, or the name a plugin gives one
    (the ``atlas_rap.layer_rules`` entry points, a ``--plugin`` file's ``ATLAS_LAYER_RULES``)."""

    name = "RULES.rap"

    def convert(self, value, param, ctx):
        from pathlib import Path

        from atlas_rap.plugins import named_files

        if Path(value).is_file():
            return value
        given = named_files("layer_rules")
        if value in given:
            return str(given[value][0])
        names = f"; the plugins' layer rules: {', '.join(sorted(given))}" if given else ""
        self.fail(f"{value!r} is neither a file nor the name of a plugin's layer rules{names}", param, ctx)


def world_help(default: str) -> str:
    """The help of a ``--world`` option: the shipped worlds by name, a file, or none."""
    from atlas_rap.shipped import shipped_worlds

    return (f"World to run in: a shipped world ({', '.join(shipped_worlds())}), a plugin's world by name, "
            f"a world file, "
            f"or 'none' for virtual skills and scripted events only. {default}")


def _option(param) -> str:
    if param is None:
        return "output"
    return param.opts[0] if getattr(param, "opts", None) else param.name


def layer_options(command):
    """The ATLAS layers' options of ``atlas run`` and ``atlas repl`` (docs/how-to/layers.md)."""
    options = [
        click.option("--no-prior-map", "no_prior_map", is_flag=True,
                     help="The robot knows only the names and points of the places: Layer IV maps while it drives."),
        click.option("--map-in", "map_in", type=click.Path(dir_okay=False, exists=True), metavar="GRID.npz",
                     help="Start from this occupancy grid (a --map-out of an earlier run, or atlas map build's)."),
        click.option("--map-out", "map_out", type=OutputFile(suffix=".npz"), metavar="GRID.npz",
                     help="Write the occupancy grid built while driving, even if the run fails or is interrupted."),
        click.option("--localisation", "localisation", type=click.Choice(["mcl", "odometry"]), default="mcl",
                     show_default=True,
                     help="How the robot knows where it is: Monte Carlo localisation on its prior map, or "
                          "without one its odometry corrected against the map it builds (mcl); or its "
                          "odometry alone (dead reckoning, to compare)."),
        click.option("--layers", "layers", default="I,II,III,IV", show_default=True, metavar="I,II,...",
                     callback=lambda ctx, param, value: parse_layers(value),
                     help="The ATLAS layers enabled (each can drive the robot alone)."),
        click.option("--layer-rules", "layer_rules", type=LayerRules(), metavar="RULES.rap",
                     help="Memory rules that choose the primary layer: a file, or the name of a plugin's "
                          "(default: the shipped rap_library/layers.rap)."),
    ]
    for option in reversed(options):
        command = option(command)
    return command


def parse_layers(value: str) -> tuple[str, ...]:
    """``--layers I,II``: the roman numerals, checked."""
    from atlas_rap.layers import LAYER_NAMES

    names = tuple(part.strip().upper() for part in value.split(",") if part.strip())
    wrong = [name for name in names if name not in LAYER_NAMES]
    if wrong or not names:
        raise click.BadParameter(f"{', '.join(wrong) or 'none given'}: the layers are I, II, III and IV",
                                 param_hint="--layers")
    return names


def run_options(*, world: str | None = None, seed: int = 0, default_world: str | None = None,
                topology: str | None = None, mapping: bool = False, realtime: bool = False,
                bus: BusSettings | None = None, no_prior_map: bool = False, map_in: str | None = None,
                map_out: str | None = None, layers: tuple[str, ...] | None = None,
                layer_rules: str | None = None, localisation: str = "mcl") -> RunOptions:
    """What a run is asked for, from a command's options, built once (``--map-out`` checked)."""
    from atlas_rap.layers import RunOptions

    if map_out and not (no_prior_map or map_in):
        raise click.UsageError("--map-out needs a map built while driving: add --no-prior-map or --map-in")
    defaults = RunOptions()
    return RunOptions(world=world, default_world=default_world or defaults.default_world, seed=seed,
                      topology=topology, mapping=mapping, prior_map=not no_prior_map, map_in=map_in, map_out=map_out,
                      layers=tuple(layers) if layers is not None else defaults.layers, layer_rules=layer_rules,
                      realtime=realtime, bus=bus, localisation=localisation)