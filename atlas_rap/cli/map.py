"""``atlas map``: build maps from sonar, abstract any map into every level, draw them."""

from __future__ import annotations

import click


@click.group("map")
def map_group() -> None:
    """Occupancy grids and their abstractions: build, abstract, render."""


@map_group.command("abstract")
@click.argument("map_yaml", metavar="MAP.yaml", type=click.Path(dir_okay=False))
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False), help="Folder for the levels.")
@click.option("--robot-radius", type=float, default=0.2, show_default=True, help="Metres; the clearance routes keep.")
def abstract_command(map_yaml: str, out_dir: str, robot_radius: float) -> None:
    """Run the whole abstraction on a ROS map_server map and write every level as data and PNG.

    Levels: occupancy grid, edges and polygons, distance transform, places,
    stochastic SDT, topological graph (JSON, GraphML, PNG).
    """
    from atlas_rap.maps.levels import abstract_map, write_levels
    from atlas_rap.maps.rosmap import load_ros_map

    rosmap = load_ros_map(map_yaml)
    result = abstract_map(rosmap.occupancy, rosmap.frame, robot_radius, source=map_yaml)
    _report(result, write_levels(rosmap.occupancy, result, out_dir, title=click.format_filename(map_yaml)))


@map_group.command("render")
@click.argument("map_file", metavar="MAP", type=click.Path(dir_okay=False))
@click.option("--out", "out_png", required=True, type=click.Path(dir_okay=False), help="The PNG to write.")
def render_command(map_file: str, out_png: str) -> None:
    """Draw a map: a ROS map_server YAML, or a grid.npz written by `atlas map build`/`abstract`."""
    import numpy as np

    from atlas_rap.errors import AtlasError
    from atlas_rap.maps.frame import GridFrame
    from atlas_rap.maps.render import render_grid
    from atlas_rap.maps.rosmap import load_ros_map

    if map_file.endswith(".npz"):
        try:
            data = np.load(map_file)
            height, width, resolution, *origin = data["frame"]
            p_occ, frame = data["p_occ"], GridFrame(int(height), int(width), float(resolution), tuple(origin))
        except (OSError, KeyError, ValueError) as exc:
            raise AtlasError(f"{map_file}: not a grid written by atlas map ({exc})") from None
    else:
        rosmap = load_ros_map(map_file)
        p_occ, frame = rosmap.occupancy, rosmap.frame
    click.echo(f"wrote {render_grid(p_occ, frame, out_png, title=click.format_filename(map_file))}")


def _report(result, written) -> None:
    kinds = result.topology.kinds() if hasattr(result.topology, "kinds") else {}
    click.echo(f"{len(result.sdt.segments)} skeleton segments, {int(result.sdt.places.max())} places, "
               f"nodes {kinds}")
    for path in written:
        click.echo(f"wrote {path}")
