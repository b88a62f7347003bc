"""``atlas map``: build maps from sonar, abstract any map into every level, draw them."""

from __future__ import annotations

import click

from atlas_rap.cli.options import POSITIVE, SEED, OutputFile, OutputFolder, check_outputs, engine_inputs


@click.group("map")
def map_group() -> None:
    """Occupancy grids and their abstractions: build, abstract, render."""


def room_options(command):
    """The options that say what the building's doors, rooms and walls are like (``RoomSettings``)."""
    command = click.option("--wall-thickness", type=POSITIVE, default=None, metavar="M",
                           help="Walls are at most this thick (default 0.45 m); thicker is furniture.")(command)
    command = click.option("--min-room-area", type=POSITIVE, default=None, metavar="M2",
                           help="Places smaller than this join a neighbour (default 2 m²).")(command)
    command = click.option("--core-area", type=POSITIVE, default=None, metavar="M2",
                           help="A narrowing is a door where the space beyond it on each side holds this much "
                                "room for the robot's centre at the door's clearance (default 2 m²).")(command)
    return click.option("--door-width", type=(POSITIVE, POSITIVE), default=None, metavar="MIN MAX",
                        help="The free width of the building's doorways (default 0.55 1.7 m).")(command)


def _room_settings(door_width, min_room_area, wall_thickness, core_area):
    from dataclasses import replace

    from atlas_rap.maps.rooms import RoomSettings

    if door_width is not None and door_width[0] >= door_width[1]:
        raise click.BadParameter("MIN must be below MAX", param_hint="--door-width")
    given = {"door_width": door_width, "min_room_area": min_room_area, "wall_thickness": wall_thickness,
             "core_area": core_area}
    return replace(RoomSettings(), **{k: v for k, v in given.items() if v is not None})


@map_group.command("build")
@click.option("--world", "world", default="lab-corridor-office", show_default=True, metavar="W",
              help="The world to map (a shipped world's name or a world file).")
@click.option("--mission", "mission_file", type=click.Path(dir_okay=False), metavar="MISSION.rap",
              help="What the robot does while mapping; default: visit every place of the world in turn.")
@click.option("--out", "out_dir", required=True, type=OutputFolder(writes=lambda: _built_files()),
              help="Folder for the maps.")
@click.option("--seed", type=SEED, default=0, show_default=True, help="Seed of the run.")
@click.option("--until", type=POSITIVE, default=1800.0, show_default=True, metavar="SECONDS",
              help="Simulated time limit.")
@room_options
def build_command(world: str, mission_file: str | None, out_dir: str, seed: int, until: float,
                  door_width, min_room_area, wall_thickness, core_area) -> None:
    """Drive the robot in a world, build an occupancy grid from its sonar, and write every level.

    Writes the grid (npz, ROS map) and, from it, the same levels as
    `atlas map abstract`, even when the mission fails or is interrupted
    (Ctrl-C: the map is written, then the exit code is 130). Places and the
    topology cover only the space the robot could reach, and take the names
    of the world's places.
    """
    import sys
    from pathlib import Path

    from rich.progress import Progress

    from atlas_rap.cli.console import console
    from atlas_rap.errors import AtlasError
    from atlas_rap.layers import MissionEngine, RunOptions
    from atlas_rap.maps.inference import InferenceGrid
    from atlas_rap.maps.abstraction import abstract_map
    from atlas_rap.views.map_levels import write_levels
    from atlas_rap.outputs import naming, write_all
    from atlas_rap.shipped import resolve_user_path
    from atlas_rap.skills.beliefs import POSE, POSES

    if world == "none":
        raise click.UsageError("atlas map build needs a world to drive in, not 'none'")
    out = Path(out_dir)
    engine = MissionEngine(RunOptions(world=world, seed=seed, mapping=True))
    path = resolve_user_path(mission_file) if mission_file else _tour_mission(world, out)
    engine.load_file(path)
    check_outputs(click.get_current_context(), engine_inputs(engine))
    ended = "interrupted"
    try:
        click.echo(f"driving in {engine.world.name} with {click.format_filename(str(path))} "
                   f"(Ctrl-C stops and still writes the map)")
        with Progress(transient=True, console=console(err=True)) as progress:
            bar = progress.add_task("mapping (simulated s)", total=until)
            ended = engine.run_mission(until, pace=lambda t: progress.update(bar, completed=t)).ended_by
    except KeyboardInterrupt:  # in the instant before or after the run itself
        engine.halt_live("the run was interrupted")
    finally:  # the map is written also when the run fails or is interrupted
        grid = engine.grid
        poses = engine.manager.context.beliefs[POSES]
        failed = write_all({"--out": lambda: _save_grid(grid, out)})
    sim, radius = engine.simulation, engine.world.robot.radius
    here = engine.manager.context.beliefs[POSE][:2]  # where the robot believes it is: the map is in its frame
    inference = InferenceGrid(grid, here, radius, engine.world.sonar.max_range, poses)
    quality = inference.quality()
    click.echo(f"mission {ended} at {sim.time:.1f} s simulated; map quality {quality:.3f}")
    if failed:  # after the line that says how the run went
        raise failed["--out"]
    p_occ = grid.probabilities()
    p_occ[~grid.updated] = float("nan")
    path_xy = [(x, y) for x, y, _ in poses]  # the believed poses the grid was built from
    grid_files = [out / "occupancy.npz", out / "occupancy.yaml"]
    try:
        result = abstract_map(p_occ, grid.frame, radius, source=f"the map of {world}",
                              rooms=_room_settings(door_width, min_room_area, wall_thickness, core_area),
                              reachable=inference.reachable, places=engine.world.place_shapes())
    except AtlasError as exc:
        if ended != "interrupted":
            raise
        click.echo(f"the grid has too little in it to abstract yet: {exc}")
        _report(None, grid_files)
        sys.exit(130)
    places = [place.point for place in engine.world.places.values()]
    ends = (places[0], places[-1]) if len(places) > 1 else None
    with naming("--out"):
        levels = write_levels(p_occ, result, out, path_xy=path_xy, title=engine.world.name, route_ends=ends)
    _report(result, grid_files + levels)
    if ended == "interrupted":
        sys.exit(130)


def _save_grid(grid, out) -> None:
    grid.save_npz(out / "occupancy.npz")
    grid.to_ros_map(out / "occupancy.yaml")


def _tour_mission(world: str, out) -> str:
    """A mission that visits every place of ``world`` in file order, with the shipped navigation RAPs."""
    from atlas_rap.outputs import write_text
    from atlas_rap.shipped import shipped_root
    from atlas_rap.sim.world import load_world

    places = list(load_world(world).places)
    navigation = shipped_root("rap_library") / "navigation.rap"
    steps = " ".join(f"(t{i} (go-to {place}))" for i, place in enumerate(places + places[:1], 1))
    path = write_text(out / "tour.rap", f'(include "{navigation}")\n'
                                        f"(define-rap (tour) (method (task-net (sequence {steps}))))\n"
                                        f"(post (tour))\n", "--out")
    return str(path)


@map_group.command("abstract")
@click.argument("map_yaml", metavar="MAP.yaml", type=click.Path(dir_okay=False))
@click.option("--out", "out_dir", required=True, type=OutputFolder(writes=lambda: _level_files()),
              help="Folder for the levels.")
@click.option("--robot-radius", type=POSITIVE, default=0.2, show_default=True,
              help="Metres; the clearance routes keep.")
@click.option("--world", metavar="W", help="A world whose named places name the map's places "
                                           "(its regions: the place covering most of one takes its name).")
@room_options
def abstract_command(map_yaml: str, out_dir: str, robot_radius: float, world: str | None,
                     door_width, min_room_area, wall_thickness, core_area) -> None:
    """Run the whole abstraction on a ROS map_server map and write every level as data and PNG.

    Levels: occupancy grid, edges and polygons, distance transform, places
    (rooms and corridors, cut at the doorways in the walls), stochastic SDT,
    topological graph (JSON, GraphML, PNG).
    """
    from atlas_rap.maps.abstraction import abstract_map
    from atlas_rap.views.map_levels import write_levels
    from atlas_rap.maps.rosmap import load_ros_map
    from atlas_rap.outputs import naming

    rooms = _room_settings(door_width, min_room_area, wall_thickness, core_area)
    places = None
    if world is not None:
        from atlas_rap.sim.world import load_world

        places = load_world(world).place_shapes()
    from atlas_rap.shipped import resolve_user_path

    rosmap = load_ros_map(resolve_user_path(map_yaml))  # worlds/maps/... from any folder, as atlas run finds worlds
    check_outputs(click.get_current_context(), {"the map's image": [rosmap.image]})
    result = abstract_map(rosmap.occupancy, rosmap.frame, robot_radius, source=map_yaml, rooms=rooms, places=places)
    with naming("--out"):
        written = write_levels(rosmap.occupancy, result, out_dir, title=click.format_filename(map_yaml))
    _report(result, written)


@map_group.command("render")
@click.argument("map_file", metavar="MAP", type=click.Path(dir_okay=False))
@click.option("--out", "out_png", required=True, type=OutputFile(), help="The PNG to write.")
@click.option("--survey", is_flag=True,
              help="Draw the survey a grid carries (`atlas run --map-out`, `atlas map build`'s occupancy.npz): "
                   "the rings read far enough apart, which the map quality is measured on.")
def render_command(map_file: str, out_png: str, survey: bool) -> None:
    """Draw a map: a ROS map_server YAML, or a grid.npz written by `atlas map build`/`abstract`
    or `atlas run --map-out`."""
    from atlas_rap.maps.grid import load_grid_arrays
    from atlas_rap.views.map_render import render_grid
    from atlas_rap.maps.rosmap import load_ros_map
    from atlas_rap.outputs import naming

    title = click.format_filename(map_file)
    if survey:
        p_occ, frame = _survey_arrays(map_file)
        title += " (survey)"
    elif map_file.endswith(".npz"):
        p_occ, frame = load_grid_arrays(map_file)
    else:
        from atlas_rap.shipped import resolve_user_path

        rosmap = load_ros_map(resolve_user_path(map_file))
        check_outputs(click.get_current_context(), {"the map's image": [rosmap.image]})
        p_occ, frame = rosmap.occupancy, rosmap.frame
    with naming("--out"):
        written = render_grid(p_occ, frame, out_png, title=title)
    click.echo(f"wrote {written}")


def _survey_arrays(map_file: str):
    """The survey's probabilities and frame of a run's grid file (``--survey``); a MapError for any other file."""
    from atlas_rap.errors import MapError
    from atlas_rap.maps.grid import OccupancyGrid

    try:
        grid = OccupancyGrid.load_npz(map_file)
    except ValueError as exc:
        raise MapError(f"{map_file}: not a grid written by atlas run --map-out ({exc})") from None
    if grid.survey is None:
        raise MapError(f"{map_file}: this grid carries no survey; the grids of atlas run --map-out, atlas "
                       f"experiment and atlas map build (occupancy.npz) have one (drop --survey to draw the grid)")
    return grid.survey.probabilities(), grid.frame


def _built_files() -> tuple[str, ...]:
    from atlas_rap.views.map_levels import LEVEL_FILES

    return ("occupancy.npz", "occupancy.yaml", "occupancy.pgm", *LEVEL_FILES)


def _level_files() -> tuple[str, ...]:
    from atlas_rap.views.map_levels import LEVEL_FILES

    return LEVEL_FILES


def _report(result, written) -> None:
    if result is not None:
        click.echo(f"{len(result.sdt.segments)} skeleton segments, {int(result.sdt.places.max())} places, "
                   f"nodes {result.topology.kinds()}")
    for path in written:
        click.echo(f"wrote {path}")
