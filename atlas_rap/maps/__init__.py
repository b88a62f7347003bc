"""Maps: occupancy grids from sonar and their abstractions (docs/how-to/maps.md), and map files.

- ``grid``: :class:`OccupancyGrid` (Bayesian sonar updates, entropy, quality);
  ``inference``: :class:`InferenceGrid` (reachability, what has been explored);
  ``frame``: :class:`GridFrame`, where a grid lies in the world.
- ``geometry``, ``sdt``, ``topology``, ``abstraction``: edges and polygons, the
  (stochastic) skeleton of the distance transform, the topological graph, and
  all of them from a grid (:func:`abstract`, :func:`abstract_map`). The levels
  written as files and their pictures are :mod:`atlas_rap.views` (``map_levels``,
  ``map_render``).
- ``rooms``: rooms and doorways; ``gridpath``: shortest paths on a grid.
- ``localisation``: Monte Carlo localisation on a known map; ``scan_matching``: the
  pose of a robot that maps, corrected against its map; ``wall_compass``: its heading held
  to the directions its building's walls run in; ``agreement``: how well a
  built map agrees with the true walls.
- ``rosmap``: ROS map_server files.

The names below are imported from their modules at first use (``atlas_rap.exports``).
"""

from atlas_rap.exports import lazy_exports, public_names

_EXPORTS = {
    "abstraction": ("Abstraction", "abstract", "abstract_map"),
    "frame": ("GridFrame",),
    "geometry": ("GeometricMap", "geometric_map", "outlines"),
    "grid": ("OccupancyGrid", "SonarModel"),
    "gridpath": ("GridPlanner", "shortest_route_length"),
    "inference": ("InferenceGrid", "explored_quality"),
    "rooms": ("RoomSettings", "segment_rooms"),
    "rosmap": ("FREE", "OCCUPIED", "UNKNOWN", "RosMap", "load_ros_map", "write_ros_map"),
    "topology": ("Topology", "build_topology"),
}

__all__ = public_names(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
