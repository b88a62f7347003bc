"""``atlas skills``: ``list`` the skills available (stock and plugins'); ``serve`` a robot's world and
skills as a skill host on the Zenoh skill bus."""

from __future__ import annotations

import json
import signal
import sys

import click

from atlas_rap.cli.bus_options import MAX_MESSAGE, ZENOH_CONFIG
from atlas_rap.cli.options import LIVE_PORT, PLUGIN, POSITIVE, SEED, OutputFile, world_help


@click.group("skills")
def skills_group() -> None:
    """The robot's skills: list those available (stock and plugins'); serve them to a sequencer
    elsewhere (Eclipse Zenoh)."""


@skills_group.command("list")
@PLUGIN
@click.option("--json", "as_json", is_flag=True, help="Print the skills as a JSON list, one object a skill.")
def list_skills(as_json: bool) -> None:
    """List every skill a simulated robot has, as declared, and where it came from.

    The stock skills, then the plugins' (installed packages' atlas_rap.skills
    entry points, then --plugin files): each with its parameters and their
    types, the predicates of the facts it posts (besides done and why), its
    rate, whether RAPs enable it or it is always on (sensors, monitors), and
    where it came from: stock, a distribution's name, or a plugin file.
    """
    from atlas_rap.skills.catalog import catalog

    skills = catalog()
    if as_json:
        click.echo(json.dumps([{"name": skill.name, "params": [{"name": p.name, "type": p.type} for p in skill.params],
                                "events": list(skill.events), "rate": skill.rate, "always_on": skill.always_on,
                                "origin": skill.origin} for skill in skills], indent=2))
        return
    rows = [("SKILL", "PARAMETERS", "POSTS", "RATE", "ENABLED", "FROM")]
    rows += [(skill.name, ", ".join(map(str, skill.params)) or "-", ", ".join(skill.events) or "-",
              f"{skill.rate:g} Hz", "always on" if skill.always_on else "by RAPs", skill.origin) for skill in skills]
    widths = [max(len(row[column]) for row in rows) for column in range(len(rows[0]) - 1)]
    for row in rows:
        click.echo("  ".join(cell.ljust(width) for cell, width in zip(row, widths)) + "  " + row[-1])


@skills_group.command("serve")
@PLUGIN
@click.option("--world", "world", metavar="W", default="lab-corridor-office", show_default=True,
              help=world_help("The world the host simulates."))
@click.option("--listen", "listen", metavar="ENDPOINT", multiple=True,
              help="Zenoh endpoint to listen on (repeatable). Default: tcp/127.0.0.1:7447.")
@click.option("--connect", "connect", metavar="ENDPOINT", multiple=True,
              help="Zenoh endpoint of another peer to connect to (repeatable).")
@click.option("--robot", default="robot", show_default=True, metavar="NAME",
              help="The robot's name on the bus: its keys (atlas/NAME/...) and the symbol its facts use.")
@click.option("--seed", type=SEED, default=0, show_default=True, help="Seed of the simulation's random choices.")
@click.option("--record", "record_file", type=OutputFile(), metavar="HOST.mcap",
              help="Record each session's world for Foxglove as MCAP (pose, tf, path, sonar, scene, topology, "
                   "route; in simulated time): the first session to HOST.mcap, later ones to HOST-2.mcap, ...; "
                   "each file is finished when its session ends, and on Ctrl-C or SIGTERM. "
                   "Needs atlas-rap[foxglove].")
@click.option("--live", is_flag=True,
              help="Serve the world live to Foxglove over WebSocket (prints the ws:// URL), session after "
                   "session; run the sequencer with --realtime to watch it. Needs atlas-rap[foxglove].")
@LIVE_PORT
@click.option("--token-file", "token_file", type=click.Path(dir_okay=False), metavar="FILE",
              help="Where the host keeps the bus's secret that every sequencer must hold: made at the first "
                   "start (readable only by you), kept across restarts. Default: a file per robot in your "
                   "runtime folder, printed at start. ATLAS_BUS_TOKEN, if set, is the secret instead.")
@ZENOH_CONFIG
@click.option("--lease", type=POSITIVE, default=10.0, show_default=True, metavar="SECONDS",
              help="A sequencer that sends nothing for this long loses the host (its link beats every second "
                   "while it thinks).")
@MAX_MESSAGE
def serve(world: str, listen: tuple[str, ...], connect: tuple[str, ...], robot: str, seed: int,
          record_file: str | None, live: bool, live_port: int, token_file: str | None, zenoh_config: str | None,
          lease: float, max_message: int) -> None:
    """Run the simulation and the skill manager as a skill host for `atlas run --connect`.

    It serves one sequencer at a time, each with a fresh world, until
    Ctrl-C or SIGTERM (exit 130, 143). Only a sequencer that holds the
    host's secret gets in: on this machine `atlas run --connect` finds it
    in the token file; elsewhere, copy the file and pass --token-file.
    Every frame is authenticated (HMAC-SHA256); for encryption across
    machines, listen on tls/ with --zenoh-config. Key expressions:
    atlas/NAME/skill/SKILL/enable|disable, atlas/NAME/event/** (facts,
    done), atlas/NAME/clock/**; liveliness token atlas/NAME/host.
    """
    from atlas_rap.layers.skill_host import SkillHostServer
    from atlas_rap.skillbus.auth import host_secret
    from atlas_rap.skillbus.keys import check_robot
    from atlas_rap.skillbus.zenoh_bus import exposure_warning, host_endpoints

    try:
        check_robot(robot)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--robot") from None
    endpoints = host_endpoints(listen, connect, zenoh_config)
    warning = exposure_warning(endpoints, zenoh_config)  # (the endpoints and the configuration checked)
    secret = host_secret(robot, token_file)
    if warning:
        click.echo(warning, err=True)
    recorder = None
    if record_file or live:
        from atlas_rap.views.recording import HostRecorder

        recorder = HostRecorder(path=record_file, live=live, port=live_port)
    try:
        server = SkillHostServer(world, robot=robot, secret=secret, seed=seed, listen=endpoints, connect=connect,
                                 zenoh_config=zenoh_config, lease=lease, max_message=max_message, recorder=recorder)
    except BaseException:
        if recorder is not None:
            recorder.close()
        raise
    from atlas_rap.skillbus.zenoh_bus import configured_endpoints

    where = ", ".join(dict.fromkeys([*configured_endpoints(zenoh_config, "listen"), *endpoints, *connect]))
    click.echo(f"skill host for robot {robot} in world {server.world.name} on {where} (Ctrl-C to stop)")
    click.echo(f"token: {secret.source} (a sequencer on another machine needs a copy: --token-file)")
    if recorder is not None and recorder.url:
        click.echo(f"live: {recorder.url} (Foxglove: Open connection, Foxglove WebSocket)")
    sys.stdout.flush()

    def said(text: str) -> None:
        click.echo(f"robot {robot}: {text}")
        sys.stdout.flush()

    previous = signal.signal(signal.SIGTERM, _terminated)
    try:
        server.serve(on_session=said)
    except (KeyboardInterrupt, _Terminated) as exc:
        signal.signal(signal.SIGTERM, signal.SIG_IGN)  # the files are being finished: a second one waits
        server.close()
        click.echo("skill host stopped", err=True)
        sys.exit(143 if isinstance(exc, _Terminated) else 130)
    except BaseException:  # an error (a recording that cannot be written): the files finished, the bus left
        server.close()
        raise
    finally:
        signal.signal(signal.SIGTERM, previous)
    server.close()


class _Terminated(BaseException):
    """SIGTERM came: the host stops as on Ctrl-C (its recording finished)."""


def _terminated(signum: int, frame: object) -> None:
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    raise _Terminated()
