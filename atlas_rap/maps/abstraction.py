"""The whole abstraction of an occupancy grid, level by level (seed §4.2): one straight pipeline.

:func:`abstract` runs it on an occupancy grid (P(occ), NaN unknown) and
returns every level as an :class:`Abstraction`:

1. free space and the distance transform, with its feature transform
   (:mod:`atlas_rap.maps.sdt`);
2. the skeleton of the robot's configuration space, traced into segments;
3. the topological graph (:mod:`atlas_rap.maps.topology`), whose building
   also finds the places (:mod:`atlas_rap.maps.rooms`) and every edge's
   probability of being empty;
4. with ``geometry``, the geometric map (:mod:`atlas_rap.maps.geometry`).

Each stage is a function of its own that can be called alone; this module
only joins them, so that no stage imports the pipeline.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from atlas_rap.errors import MapError
from atlas_rap.maps.frame import GridFrame
from atlas_rap.maps.geometry import GeometricMap, geometric_map
from atlas_rap.maps.rooms import RoomSettings
from atlas_rap.maps.sdt import (
    SDT,
    distance_transform,
    free_space,
    skeleton,
    trace_skeleton,
)
from atlas_rap.maps.topology import Topology, build_topology

__all__ = ["Abstraction", "abstract"]


@dataclass(frozen=True, eq=False)
class Abstraction:
    """Every level computed from one occupancy grid by :func:`abstract`."""

    frame: GridFrame
    free: np.ndarray
    sdt: SDT
    topology: Topology
    geometry: GeometricMap | None = None

    @property
    def dt(self) -> np.ndarray:
        return self.sdt.dt

    @property
    def skeleton(self) -> np.ndarray:
        return self.sdt.skeleton

    @property
    def places(self) -> np.ndarray:
        return self.sdt.places


def abstract(p_occ: np.ndarray, frame: GridFrame, robot_radius: float = 0.2, free_below: float = 0.5, *,
             rooms: RoomSettings | None = None, reachable: np.ndarray | None = None, spur_ratio: float = 1.0,
             merge_cells: float = 3.0, geometry: bool = False) -> Abstraction:
    """Run the whole pipeline on ``p_occ`` (NaN = unknown): free space, DT, skeleton, segments, places, topology.

    ``robot_radius`` (metres) is the clearance the skeleton keeps and the
    half-width of the band each segment's probability is computed over.
    ``rooms`` are the settings of the places (doors, room sizes;
    :mod:`atlas_rap.maps.rooms`), ``reachable`` the cells a robot that
    mapped the space could reach (None on a drawn map); ``spur_ratio`` and
    ``merge_cells`` are :func:`atlas_rap.maps.topology.build_topology`'s.
    With ``geometry`` the geometric map (edges, polygons;
    :func:`atlas_rap.maps.geometry.geometric_map`) is computed too.
    """
    p = np.asarray(p_occ)
    if p.shape != frame.shape:
        raise ValueError(f"p_occ has shape {p.shape}, but the frame is {frame.height} x {frame.width}")
    free = free_space(p, free_below)
    dt, nearest = distance_transform(free, frame, nearest=True)
    skel = skeleton(dt, free, robot_radius)
    if reachable is not None:
        skel &= reachable
    trace = trace_skeleton(skel, dt)
    topology = build_topology(trace, dt, p, frame, robot_radius=robot_radius, spur_ratio=spur_ratio,
                              merge_cells=merge_cells, free=free, nearest=nearest, reachable=reachable,
                              rooms=rooms or RoomSettings())
    geo = None
    if geometry:
        geo = geometric_map(p, frame, free_below=free_below)
    return Abstraction(frame, free, SDT(dt, skel, topology.segments(), topology.place_labels), topology, geo)


def abstract_map(p_occ: np.ndarray, frame: GridFrame, robot_radius: float = 0.2, *, geometry: bool = True,
                 source: str = "the map", rooms: RoomSettings | None = None, reachable: np.ndarray | None = None,
                 places: Mapping[str, Any] | None = None) -> Abstraction:
    """The whole abstraction, or a clear error when the map has no room for the robot.

    ``rooms`` are the settings of the places (doors, room sizes, walls: in
    metres), ``reachable`` the cells a robot that mapped the space could
    reach (maps built from sonar), ``places`` the world's named places
    (name -> region or point) that name the map's places.
    """
    free = np.asarray(p_occ) < 0.5
    if not free.any():
        raise MapError(f"{source} has no free space (no cell with an occupancy below 0.5): "
                         f"is it a map, and is its negate setting right?")
    if robot_radius > max(free.shape) * frame.resolution:  # wider than the map: not even its disc fits
        raise MapError(f"{source} has no free space wide enough for a robot of radius {robot_radius:g} m")
    result = abstract(p_occ, frame, robot_radius, geometry=geometry, rooms=rooms, reachable=reachable)
    if places:
        result.topology.name_places(places)
    if result.topology.graph.number_of_nodes() == 0:
        raise MapError(f"{source} has no free space wide enough for a robot of radius {robot_radius:g} m")
    return result
