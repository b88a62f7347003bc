"""Option types shared by the commands: output paths, positive numbers, the world option.

- :class:`OutputFile` / :class:`OutputFolder`: a path the command will
  write; its missing parent folders are made as the option is read, and a
  path that cannot be made is a one-line error (``atlas_rap.outputs``).
- :data:`POSITIVE` / :data:`NON_NEGATIVE`: click ranges for seconds, speeds
  and sizes, so ``--until -5`` is refused with a usage error; so are
  ``nan``, ``inf`` and numbers too large for a float (``1e400``).
- :data:`SEED`: a seed for the run's random numbers, a whole number from 0
  to 2**63 - 1 (numpy takes no negative seed).
- :func:`world_help`: the ``--world`` help text, naming the worlds read
  from the shipped ``worlds/`` folder (never a hand-kept list).
"""

from __future__ import annotations

import math
import click


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
    """A file the command writes; its parent folder is created if missing."""

    name = "file"

    def convert(self, value, param, ctx):
        from atlas_rap.outputs import output_file

        return str(output_file(value, _option(param)))


class OutputFolder(click.ParamType):
    """A folder the command writes into; created (with its parents) if missing."""

    name = "folder"

    def convert(self, value, param, ctx):
        from atlas_rap.outputs import output_folder

        return str(output_folder(value, _option(param)))


LIVE_PORT = click.option("--live-port", type=click.IntRange(0, 65535), default=8765, show_default=True,
                         metavar="PORT", help="The port --live listens on, on 127.0.0.1 (0: any free port).")
"""``--live-port``, for the commands that serve a run to Foxglove (``atlas run``, ``atlas skills serve``)."""


def world_help(default: str) -> str:
    """The help of a ``--world`` option: the shipped worlds by name, a file, or none."""
    from atlas_rap.shipped import shipped_worlds

    return (f"World to run in: a shipped world ({', '.join(shipped_worlds())}), a world file, "
            f"or 'none' for virtual skills and scripted events only. {default}")


def _option(param) -> str:
    if param is None:
        return "output"
    return param.opts[0] if getattr(param, "opts", None) else param.name


def layer_options(command):
    """The ATLAS layers' options of ``atlas run`` and ``atlas repl`` (README, "The ATLAS layers")."""
    options = [
        click.option("--no-prior-map", "no_prior_map", is_flag=True,
                     help="The robot knows only the names and points of the places: Layer IV maps while it drives."),
        click.option("--map-in", "map_in", type=click.Path(dir_okay=False, exists=True), metavar="GRID.npz",
                     help="Start from this occupancy grid (a --map-out of an earlier run, or atlas map build's)."),
        click.option("--map-out", "map_out", type=OutputFile(), metavar="GRID.npz",
                     help="Write the occupancy grid built while driving, even if the run fails or is interrupted."),
        click.option("--layers", "layers", default="I,II,III,IV", show_default=True, metavar="I,II,...",
                     callback=lambda ctx, param, value: parse_layers(value),
                     help="The ATLAS layers enabled (each can drive the robot alone)."),
        click.option("--layer-rules", "layer_rules", type=click.Path(dir_okay=False, exists=True),
                     metavar="RULES.rap",
                     help="Memory rules that choose the primary layer (default: the shipped rap_library/layers.rap)."),
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


def layer_engine_options(no_prior_map: bool, map_in: str | None, map_out: str | None, layers: tuple[str, ...],
                         layer_rules: str | None) -> dict:
    """The mission engine's keyword arguments for the layer options (``--map-out`` checked)."""
    if map_out and not (no_prior_map or map_in):
        raise click.UsageError("--map-out needs a map built while driving: add --no-prior-map or --map-in")
    return {"prior_map": not no_prior_map, "map_in": map_in, "layers": layers, "layer_rules": layer_rules}
