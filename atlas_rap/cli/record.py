"""``atlas record``: look at a recording made with ``atlas run --record`` (MCAP for Foxglove) without Foxglove."""

from __future__ import annotations

import json

import click

from atlas_rap.cli.options import OutputFile


@click.group("record")
def record_group() -> None:
    """Recordings of runs for Foxglove (atlas run --record RUN.mcap)."""


@record_group.command("show")
@click.argument("recording", metavar="RUN.mcap", type=click.Path(dir_okay=False, exists=True))
@click.option("--out", type=OutputFile(), metavar="OUT.png",
              help="Draw the end of the run from the file: grid, walls, doors, places, topology, routes, "
                   "path, last sonar ring, robot.")
@click.option("--json", "as_json", is_flag=True, help="Print the channels as JSON lines.")
def show_command(recording: str, out: str | None, as_json: bool) -> None:
    """Print a recording's channels (topic, schema, messages, simulated time span); with --out, draw it.

    Reads the file with the mcap package (atlas-rap[foxglove]) and decodes
    its messages by the schemas it carries.
    """
    from atlas_rap.cli.console import console
    from atlas_rap.views.mcap_reader import read_recording

    printer = console()
    data = read_recording(recording)
    for topic, (schema, count) in data.channels().items():
        times = data.times(topic)
        if as_json:
            click.echo(json.dumps({"topic": topic, "schema": schema, "messages": count,
                                   "first_s": times[0], "last_s": times[-1]}))
        else:
            printer.print(f"{topic:<21} {schema:<24} {count:>6} messages  {times[0]:8.1f} … {times[-1]:.1f} s",
                          markup=False)
    if out:
        from atlas_rap.views.mcap_picture import render_recording
        from atlas_rap.outputs import naming

        with naming("--out"):
            render_recording(recording, out, click.format_filename(recording))
        if not as_json:
            printer.print(f"picture written to {out}", style="dim")
