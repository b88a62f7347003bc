"""The skill bus's options: ``--connect`` and what goes with it on ``atlas run`` and ``atlas repl``,
and what every bus command shares (``--zenoh-config``, ``--max-message``).

:func:`bus_options` adds the sequencer's options to a command and hands the
command one ``bus`` argument instead: a
:class:`~atlas_rap.skillbus.remote.BusSettings`, or None without ``--connect``.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import click

from atlas_rap.cli.options import POSITIVE

MIB = 1 << 20

ZENOH_CONFIG = click.option(
    "--zenoh-config", "zenoh_config", type=click.Path(dir_okay=False, exists=True), metavar="FILE.json5",
    help="Zenoh's own configuration (JSON5): TLS, mutual TLS, user/password, access control. The bus keeps "
         "its own settings where the file leaves Zenoh's defaults, and adds the endpoints given here.")
"""``--zenoh-config``, on every command that opens the bus."""

MAX_MESSAGE = click.option(
    "--max-message", "max_message", type=click.IntRange(1024, 1 << 30), default=MIB, show_default=True,
    metavar="BYTES", help="The largest message taken from the bus; larger ones are dropped unread.")
"""``--max-message``, on every command that opens the bus."""


def bus_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """``--connect`` (run the sequencer against skill hosts on the Zenoh skill bus), ``--robot``,
    ``--token-file``, ``--zenoh-config``, ``--host-grace`` and ``--max-message``, given to the
    command as one ``bus`` argument (None without ``--connect``)."""

    @functools.wraps(command)
    def with_bus(*args: Any, connect: tuple[str, ...], robots: tuple[str, ...], token_files: tuple[str, ...],
                 zenoh_config: str | None, host_grace: float, max_message: int, **kwargs: Any) -> Any:
        from atlas_rap.skillbus.remote import BusSettings

        bus = None
        if connect:
            bus = BusSettings(tuple(connect), tuple(robots) or ("robot",), tuple(token_files), zenoh_config,
                              host_grace, max_message)
        else:
            ctx = click.get_current_context()
            given = [flag for flag, value in (("--robot", robots), ("--token-file", token_files),
                                              ("--zenoh-config", zenoh_config)) if value]
            given += [flag for flag, name in (("--host-grace", "host_grace"), ("--max-message", "max_message"))
                      if ctx.get_parameter_source(name) is click.core.ParameterSource.COMMANDLINE]
            if given:
                raise click.UsageError(f"{', '.join(given)} needs --connect (the robot's skill host on the bus)")
        return command(*args, bus=bus, **kwargs)

    options = [
        click.option("--connect", "connect", multiple=True, metavar="ENDPOINT",
                     help="Use the skills of a skill host (atlas skills serve) at this Zenoh endpoint, e.g. "
                          "tcp/127.0.0.1:7447, instead of simulating the world here (repeatable)."),
        click.option("--robot", "robots", multiple=True, metavar="NAME",
                     help="With --connect: the robot whose skill host to use (repeatable; default: robot). With "
                          "several, every skill takes the robot's name first: (navigate-to alice office)."),
        click.option("--token-file", "token_files", multiple=True, type=click.Path(dir_okay=False, exists=True),
                     metavar="FILE",
                     help="With --connect: a skill host's token file (atlas skills serve prints where it is); it "
                          "names its robot (repeatable). Default: ATLAS_BUS_TOKEN if set, else each robot's token "
                          "file on this machine."),
        ZENOH_CONFIG,
        click.option("--host-grace", "host_grace", type=POSITIVE, default=30.0, show_default=True,
                     metavar="SECONDS",
                     help="With --connect: how long a skill enabled while its host is lost waits for the host to "
                          "come back before it fails."),
        MAX_MESSAGE,
    ]
    for option in reversed(options):
        with_bus = option(with_bus)
    return with_bus


def check_bus_options(bus: Any, **others: object) -> None:
    """Usage errors for options that cannot go with ``--connect`` (``others``: flag name → value given)."""
    if bus is not None:
        given = [name for name, value in others.items() if value]
        if given:
            raise click.UsageError(f"{', '.join(given)} cannot go with --connect: the skill host runs the world "
                                   f"(not supported over the bus yet)")
