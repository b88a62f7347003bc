"""``atlas run MISSION.rap``: run a mission and show what happens."""

from __future__ import annotations

import sys
import time
from typing import TYPE_CHECKING

import click

from atlas_rap.cli.bus_options import bus_options, check_bus_options
from atlas_rap.cli.options import (LIVE_PORT, PLUGIN, POSITIVE, SEED, OutputFile, check_outputs, engine_inputs,
                                   layer_options, run_options, world_help)

if TYPE_CHECKING:  # downward only
    from collections.abc import Mapping

    from rich.console import Console

    from atlas_rap.layers import MissionEngine, RunResult
    from atlas_rap.outputs import OutputError
    from atlas_rap.skillbus.remote import BusSettings
    from atlas_rap.views.recording import RunRecorder


@click.command()
@PLUGIN
@click.argument("mission_file", metavar="MISSION.rap", type=click.Path(dir_okay=False))
@click.option("--world", "world", metavar="W",
              help=world_help("Default: the mission's (world ...) form, else lab-corridor-office."))
@click.option("--seed", type=SEED, default=0, show_default=True,
              help="Seed for every random choice of the run (same files and seed, same trace).")
@click.option("--trace", "trace_file", type=OutputFile(), metavar="FILE",
              help="Write the trace as JSON lines (the language reference, docs/language/trace.md), even if the run fails or is interrupted.")
@click.option("--quiet", "-q", is_flag=True, help="No live trace; only warnings and the summary.")
@click.option("--verbose", "-v", is_flag=True, help="Also show task selections and skill disables.")
@click.option("--until", type=POSITIVE, default=3600.0, show_default=True, metavar="SECONDS",
              help="Simulated time limit; tasks still running then fail.")
@click.option("--realtime/--no-realtime", default=None,
              help="Pace simulated time to the wall clock (default: only with --live).")
@click.option("--agenda", "show_agenda", is_flag=True, help="Print the task tree at the end.")
@click.option("--memory", "show_memory", is_flag=True, help="Print memory at the end.")
@click.option("--map", "topology_file", type=click.Path(dir_okay=False, exists=True), metavar="TOPOLOGY.json",
              help="A topological map built from sonar (atlas map build): navigate-to plans its routes on it.")
@click.option("--render", type=OutputFile(), metavar="OUT.png",
              help="Draw the world, the robot's path, the places and where each task started and ended "
                   "(with no world: a timeline of the plan steps, re-plans and tasks).")
@click.option("--record", "record_file", type=OutputFile(), metavar="RUN.mcap",
              help="Record the run for Foxglove as MCAP (pose, path, sonar, grid, scene, topology, route, "
                   "primary layer, trace; in simulated time), even if the run fails or is interrupted. With "
                   "--connect: the trace and primary layer (the host records the world: atlas skills serve "
                   "--record). Needs atlas-rap[foxglove].")
@click.option("--live", is_flag=True,
              help="Serve the run live to Foxglove over WebSocket (prints the ws:// URL); paced to the wall "
                   "clock unless --no-realtime. Needs atlas-rap[foxglove].")
@LIVE_PORT
@layer_options
@bus_options
def run(mission_file: str, world: str | None, seed: int, trace_file: str | None, quiet: bool, verbose: bool,
        until: float, realtime: bool | None, show_agenda: bool, show_memory: bool, topology_file: str | None,
        render: str | None, record_file: str | None, live: bool, live_port: int, no_prior_map: bool,
        map_in: str | None, map_out: str | None, localisation: str, layers: tuple[str, ...],
        layer_rules: str | None, bus: BusSettings | None) -> None:
    """Run a mission: post its tasks, run the RAPs, print a live trace and a summary.

    Exits 0 when every posted task succeeded, 1 when one failed (the
    summary gives the chain of failures down to the skill or event that
    caused it) or the input is bad, 130 when interrupted.
    """
    from atlas_rap.cli.console import console
    from atlas_rap.cli.views import LiveTrace
    from atlas_rap.layers import MissionEngine
    from atlas_rap.layers.observers import MapFile, PictureFile, observing
    from atlas_rap.layers.running import RunEnd
    from atlas_rap.sequencer import JsonlSink
    from atlas_rap.shipped import resolve_user_path
    from atlas_rap.views import RunPicture

    out, err = console(), console(err=True)
    options = run_options(world=world, seed=seed, topology=topology_file, bus=bus, no_prior_map=no_prior_map,
                          realtime=live if realtime is None else realtime, map_in=map_in, map_out=map_out,
                          layers=layers, layer_rules=layer_rules, localisation=localisation)
    check_bus_options(bus, **{
        "--world": world, "--map": topology_file, "--render": render,
        "--live (the host serves the world live: atlas skills serve --live)": live, "--no-prior-map": no_prior_map,
        "--map-in": map_in, "--layers": tuple(layers) != ("I", "II", "III", "IV"),
        "--seed (the host's: atlas skills serve --seed)": seed,
        "--localisation (the host's localiser runs beside its sensors)": localisation != "mcl"})
    engine = MissionEngine(options)
    recorder = _recorder(engine, record_file, live, live_port, out)
    name = click.format_filename(mission_file)
    picture = PictureFile(RunPicture(engine), render, name) if render else None
    sink = JsonlSink(trace_file) if trace_file else None
    for observer in (sink, None if quiet else LiveTrace(out, verbose=verbose)):
        if observer is not None:
            engine.trace.add_sink(observer)
    with observing({"--trace": sink, "--record": recorder, "--map-out": MapFile(engine, map_out) if map_out else None,
                    "--render": picture}) as run:
        loaded = engine.load_file(resolve_user_path(mission_file), require_post=True)
        check_outputs(click.get_current_context(), engine_inputs(engine))
        run.started()
        for warning in loaded.warnings:
            err.print(warning.render(), style="yellow", markup=False)
        started = time.perf_counter()
        result = engine.run_mission(until, pace=recorder.pace if recorder is not None else None)
    written = {"--map-out": (map_out if engine.grid is not None else None, "map"), "--trace": (trace_file, "trace"),
               "--render": (render, "picture"), "--record": (record_file, "recording")}
    _report(out, err, engine, result, name, time.perf_counter() - started, written, run.failed,
            agenda=show_agenda, memory=show_memory)
    if result.ended_by == RunEnd.INTERRUPTED:
        sys.exit(130)
    sys.exit(1 if run.failed or not result.ok else 0)


def _report(out: Console, err: Console, engine: MissionEngine, result: RunResult, name: str, seconds: float,
            written: dict[str, tuple[str | None, str]], failed: Mapping[str, OutputError], *, agenda: bool,
            memory: bool) -> None:
    """What ``atlas run`` prints when the run has ended: the agenda and memory when asked, the summary,
    the outputs written (option -> (path, what)), then the outputs that could not be."""
    from atlas_rap.cli.views import memory_table, summary, task_tree
    from atlas_rap.sequencer import agenda_tree
    from atlas_rap.views.pose_error import pose_errors

    if agenda:
        out.print(task_tree(agenda_tree(engine.sequencer)))
    if memory:
        out.print(memory_table(engine.sequencer.memory))
    for line in summary(result, name, seconds):
        out.print(line)
    drove = engine.stack.primary_summary(result.time) if engine.stack is not None and engine.stack.timeline else ""
    if drove:  # (a run that ends at 0 s, its task already done, had no layer drive)
        out.print("  primary layer: " + drove, style="dim")
    errors = pose_errors(engine.system)
    if errors is not None:
        out.print("  " + errors.line(), style="dim")
    for option, (path, what) in written.items():
        if path and option not in failed:
            out.print(f"{what} written to {path}", style="dim")
    for error in failed.values():  # after the summary: the run's outcome is not lost
        err.print(str(error), markup=False)


def _recorder(engine: MissionEngine, record_file: str | None, live: bool, port: int,
              out: Console) -> RunRecorder | None:
    """The MCAP recorder and live server of ``--record`` / ``--live`` (None when neither is asked for)."""
    if not (record_file or live):
        return None
    from atlas_rap.views.recording import RunRecorder

    recorder = RunRecorder(engine, path=record_file, live=live, port=port)
    if recorder.url:
        out.print(f"live: {recorder.url} (Foxglove: Open connection, Foxglove WebSocket)")
        sys.stdout.flush()
    return recorder
