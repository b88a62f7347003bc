"""The page layout every PNG of atlas-rap shares: map size in inches, metres kept 1:1, resolution.

Pictures of runs (``sim.render``) and of maps (``maps.render``) draw a map
in metres with equal aspect; :func:`map_layout` decides how big it is and
which range of metres it shows, so all pictures look alike.
"""

from __future__ import annotations

DPI = 110
MAX_MAP_W = 7.5  # inches for the map itself, at most...
MAX_MAP_H = 6.5  # ...and at most this tall
MIN_MAP_SIDE = 2.5  # a long thin map still gets this much on its short side


def map_layout(xmin: float, ymin: float, xmax: float, ymax: float
               ) -> tuple[tuple[float, float, float, float], float, float]:
    """((xmin, xmax, ymin, ymax) to show, map width, map height in inches) for an area in metres.

    The map is as large as fits in MAX_MAP_W × MAX_MAP_H at one scale;
    when MIN_MAP_SIDE widens a thin map, the range shown grows to keep
    metres square.
    """
    dx, dy = max(xmax - xmin, 1e-9), max(ymax - ymin, 1e-9)
    scale = min(MAX_MAP_W / dx, MAX_MAP_H / dy)  # inches per metre
    map_w, map_h = max(dx * scale, MIN_MAP_SIDE), max(dy * scale, MIN_MAP_SIDE)
    if map_w / map_h > dx / dy:
        extra = (map_w / map_h * dy - dx) / 2
        xmin, xmax = xmin - extra, xmax + extra
    else:
        extra = (map_h / map_w * dx - dy) / 2
        ymin, ymax = ymin - extra, ymax + extra
    return (xmin, xmax, ymin, ymax), map_w, map_h
