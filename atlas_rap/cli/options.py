"""Option types shared by the commands: output paths, positive numbers, the world option.

- :class:`OutputFile` / :class:`OutputFolder`: a path the command will
  write; its missing parent folders are made as the option is read, and a
  path that cannot be made is a one-line error (``atlas_rap.outputs``).
- :data:`POSITIVE` / :data:`NON_NEGATIVE`: click ranges for seconds, speeds
  and sizes, so ``--until -5`` is refused with a usage error.
- :func:`world_help`: the ``--world`` help text, naming the worlds read
  from the shipped ``worlds/`` folder (never a hand-kept list).
"""

from __future__ import annotations

import click

POSITIVE = click.FloatRange(min=0, min_open=True)
"""A number greater than zero (seconds, speeds, radii)."""

NON_NEGATIVE = click.FloatRange(min=0)
"""A number at least zero."""


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


def world_help(default: str) -> str:
    """The help of a ``--world`` option: the shipped worlds by name, a file, or none."""
    from atlas_rap.shipped import shipped_worlds

    return (f"World to run in: a shipped world ({', '.join(shipped_worlds())}), a world file, "
            f"or 'none' for virtual skills and scripted events only. {default}")


def _option(param) -> str:
    if param is None:
        return "output"
    return param.opts[0] if getattr(param, "opts", None) else param.name
