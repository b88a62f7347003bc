"""Echoes beside a route: what Layers I, III and IV ask of the sonar and the route being driven.

Layer I wants the echoes in the strip the robot will sweep over the next
metres of its route; Layer IV wants the echoes near the whole path it
planned, to know when a re-plan is due; Layer III wants the echoes of an
obstacle. So: where a ring's echoes are (:func:`echo_points`), and how far
each point is from a polyline (:func:`distance_to_polyline`), vectorised.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from atlas_rap.model import Point


def echo_points(x: float, y: float, heading: float, ranges: np.ndarray, angles: np.ndarray, radius: float,
                within: float) -> tuple[np.ndarray, np.ndarray]:
    """World (x, y) of a ring's echoes nearer than ``within`` metres from the rim (the sonar's
    ``max_range``: every beam that came back), and the mask of the beams they are of."""
    hit = ranges < within - 1e-6
    reach = ranges[hit] + radius
    direction = heading + angles[hit]
    return np.column_stack([x + reach * np.cos(direction), y + reach * np.sin(direction)]), hit


def distance_to_polyline(points: np.ndarray, polyline: np.ndarray) -> np.ndarray:
    """For each point (N, 2), its distance in metres to the polyline (M, 2)."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    polyline = np.asarray(polyline, dtype=float).reshape(-1, 2)
    if len(polyline) == 1:
        return np.hypot(*(points - polyline[0]).T)
    a, b = polyline[:-1], polyline[1:]
    ab = b - a
    length2 = np.maximum((ab ** 2).sum(axis=1), 1e-12)
    ap = points[:, None, :] - a[None, :, :]
    t = np.clip((ap * ab[None]).sum(axis=2) / length2[None], 0.0, 1.0)
    closest = a[None] + t[..., None] * ab[None]
    return np.hypot(*(points[:, None, :] - closest).transpose(2, 0, 1)).min(axis=1)


def route_ahead(here: Point, waypoints: Sequence[Point], index: int, length: float) -> np.ndarray:
    """The next ``length`` metres of a route from ``here``: to waypoint ``index``, then on
    along the waypoints after it, cut where the length runs out (a polyline, (K, 2))."""
    points = [tuple(here)]
    left = length
    for point in waypoints[index:]:
        step = math.dist(points[-1], point)
        if step >= left:
            x0, y0 = points[-1]
            share = left / step if step > 0 else 0.0
            points.append((x0 + share * (point[0] - x0), y0 + share * (point[1] - y0)))
            break
        points.append(tuple(point))
        left -= step
    return np.asarray(points, dtype=float)
