"""Geometric maps (seed §4.1): edges of the occupied and empty regions, and the occupied region's polygons.

The cells of an occupancy grid are labelled with their maximum a posteriori
state: **occupied** when P(occ) > ``occupied_above``, **empty** when P(occ) <
``free_below`` (both 0.5 by default, the seed's "unknown state probability
level"), **unknown** otherwise (NaN, or exactly 0.5).

* The **edges** of a region are its cells that have a 4-neighbour outside it
  (a morphological boundary: the region minus its erosion by a cross). The
  occupied and the empty edges coincide where occupied meets empty, and each
  has extra edges where it meets unknown cells (seed Fig. 7). The grid's own
  border is not an edge: nothing was seen beyond it.
* The **polygons** are the outlines of the occupied region in world metres,
  traced with ``skimage.measure.find_contours`` along the cells' edges and
  simplified with ``approximate_polygon`` (:func:`outlines`; the simulator's
  :func:`atlas_rap.maps.rosmap.wall_segments` uses the same function).

Everything uses :class:`~atlas_rap.maps.frame.GridFrame` (row 0 at the top).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from atlas_rap.maps.frame import GridFrame

__all__ = ["GeometricMap", "geometric_map", "outlines", "region_edges"]


@dataclass(frozen=True, eq=False)
class GeometricMap:
    """Edge cells of the occupied and empty regions (boolean masks) and the occupied region's polygons.

    ``polygons`` are closed (first point == last point) (N, 2) arrays of
    world (x, y) in metres, one per connected outline (holes included).
    """

    occupied_edges: np.ndarray
    empty_edges: np.ndarray
    polygons: tuple[np.ndarray, ...]


def region_edges(mask: np.ndarray) -> np.ndarray:
    """Cells of ``mask`` with a 4-neighbour outside it (the grid's border does not count)."""
    mask = np.asarray(mask, dtype=bool)
    inner = mask.copy()
    inner[1:, :] &= mask[:-1, :]
    inner[:-1, :] &= mask[1:, :]
    inner[:, 1:] &= mask[:, :-1]
    inner[:, :-1] &= mask[:, 1:]
    return mask & ~inner


def outlines(mask: np.ndarray, frame: GridFrame, tolerance: float | None = None) -> list[np.ndarray]:
    """Outlines of the True cells of ``mask`` as closed polygons of world (x, y), in metres.

    ``mask`` is padded with False (so regions touching the border still
    close), outlined with ``find_contours`` at level 0.5, i.e. along the
    cells' edges, half a cell from the centres of boundary cells (corners
    are cut by half a cell at 45 degrees), and simplified with
    ``approximate_polygon`` to within ``tolerance`` metres (default a third
    of a cell: straight runs stay on the cells' edges; 0 keeps every point).
    """
    from skimage.measure import approximate_polygon, find_contours

    grid = np.pad(np.asarray(mask, dtype=bool), 1, constant_values=False)
    if not grid.any():
        return []
    cells = tolerance / frame.resolution if tolerance is not None else 0.3
    polygons = []
    for contour in find_contours(grid.astype(np.float32), 0.5, fully_connected="high"):
        simple = approximate_polygon(contour, tolerance=cells) if cells > 0 else contour
        xs, ys = frame.cell_to_world(simple[:, 0] - 1.0, simple[:, 1] - 1.0)
        polygons.append(np.column_stack([np.atleast_1d(xs), np.atleast_1d(ys)]))
    return polygons


def geometric_map(p_occ: np.ndarray, frame: GridFrame, *, free_below: float = 0.5, occupied_above: float = 0.5,
                  tolerance: float | None = None) -> GeometricMap:
    """The :class:`GeometricMap` of an occupancy grid ``p_occ`` (NaN = unknown) placed by ``frame``."""
    p = np.asarray(p_occ, dtype=float)
    if p.shape != frame.shape:
        raise ValueError(f"p_occ has shape {p.shape}, but the frame is {frame.height} x {frame.width}")
    with np.errstate(invalid="ignore"):
        occupied = p > occupied_above
        empty = p < free_below
    return GeometricMap(region_edges(occupied), region_edges(empty), tuple(outlines(occupied, frame, tolerance)))
