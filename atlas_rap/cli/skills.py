"""``atlas skills serve``: run a robot's world and skills as a skill host on the Zenoh skill bus."""

from __future__ import annotations

import sys

import click

from atlas_rap.cli.options import world_help


@click.group("skills")
def skills_group() -> None:
    """Skills on their own host: serve a robot's skills to a sequencer elsewhere (Eclipse Zenoh)."""


@skills_group.command("serve")
@click.option("--world", "world", metavar="W", default="lab-corridor-office", show_default=True,
              help=world_help("The world the host simulates."))
@click.option("--listen", "listen", metavar="ENDPOINT", multiple=True,
              help="Zenoh endpoint to listen on (repeatable). Default: tcp/127.0.0.1:7447.")
@click.option("--connect", "connect", metavar="ENDPOINT", multiple=True,
              help="Zenoh endpoint of another peer to connect to (repeatable).")
@click.option("--robot", default="robot", show_default=True, metavar="NAME",
              help="The robot's name on the bus: its keys (atlas/NAME/...) and the symbol its facts use.")
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of the simulation's random choices.")
def serve(world: str, listen: tuple[str, ...], connect: tuple[str, ...], robot: str, seed: int) -> None:
    """Run the simulation and the skill manager as a skill host for `atlas run --connect`.

    It serves one sequencer at a time, each with a fresh world, until
    Ctrl-C. Key expressions: atlas/NAME/skill/SKILL/enable|disable,
    atlas/NAME/event/** (facts, done), atlas/NAME/clock/**; liveliness
    token atlas/NAME/host.
    """
    from atlas_rap.errors import AtlasError
    from atlas_rap.layers.skill_host import SkillHostServer
    from atlas_rap.skillbus.keys import check_robot

    try:
        check_robot(robot)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--robot") from None
    endpoints = listen or (() if connect else ("tcp/127.0.0.1:7447",))
    try:
        server = SkillHostServer(world, robot=robot, seed=seed, listen=endpoints, connect=connect)
    except AtlasError:
        raise
    where = ", ".join(endpoints + connect)
    click.echo(f"skill host for robot {robot} in world {server.world.name} on {where} (Ctrl-C to stop)")
    sys.stdout.flush()

    def said(text: str) -> None:
        click.echo(f"robot {robot}: {text}")
        sys.stdout.flush()

    try:
        server.serve(on_session=said)
    except KeyboardInterrupt:
        server.close()
        click.echo("skill host stopped", err=True)
        sys.exit(130)
    server.close()
