"""Where a grid's cells are in the world: the one cell ↔ metre convention of every map.

The convention is ROS map_server's (and an image's): row 0 is the TOP row,
``origin`` = (x, y, yaw) is the lower-left corner of the lower-left cell,
``resolution`` is metres per cell. Occupancy grids, ROS map files, the
distance transform, the skeleton and the topological graph all use it, so
a cell index means the same place everywhere.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from atlas_rap.errors import MapError

MAX_CELLS = 16_000_000
"""The most cells of a grid made to cover a world (:meth:`GridFrame.covering`): 64 MB a float32 layer, a
world of 200 m x 200 m at 5 cm (the shipped ones have at most 0.25 million); a world asking for more has
a coordinate wrong, and would take gigabytes."""


@dataclass(frozen=True, slots=True)
class GridFrame:
    """A grid of ``height`` × ``width`` cells of ``resolution`` metres placed at ``origin``."""

    height: int
    width: int
    resolution: float
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @classmethod
    def covering(cls, bounds: tuple[float, float, float, float], resolution: float) -> GridFrame:
        """The smallest frame (yaw 0) that covers (xmin, ymin, xmax, ymax)."""
        xmin, ymin, xmax, ymax = bounds
        width = max(1, math.ceil((xmax - xmin) / resolution))
        height = max(1, math.ceil((ymax - ymin) / resolution))
        if width * height > MAX_CELLS:
            raise MapError(f"a grid over this world ({xmax - xmin:g} m x {ymax - ymin:g} m at {resolution:g} m a "
                             f"cell) would have {width * height:,} cells; the most is {MAX_CELLS:,}: "
                             f"is a coordinate in the world file far off?")
        return cls(height, width, resolution, (xmin, ymin, 0.0))

    def to_array(self) -> np.ndarray:
        """[height, width, resolution, origin x, origin y, origin yaw]: how a frame is stored in ``.npz`` files."""
        return np.array([self.height, self.width, self.resolution, *self.origin], dtype=np.float64)

    @classmethod
    def from_array(cls, values: Any) -> GridFrame:
        """The frame stored by :meth:`to_array`; ``ValueError`` saying what is wrong with anything else
        (not six numbers, a size that is not a whole number from 1, a resolution not above 0)."""
        try:
            numbers = [float(v) for v in np.ravel(np.asarray(values, dtype=object))]
        except (OverflowError, TypeError):
            numbers = []
        if len(numbers) != 6 or not all(map(math.isfinite, numbers)):
            raise ValueError("frame must be six finite numbers: height, width, resolution, origin x, y, yaw")
        height, width, resolution, ox, oy, yaw = numbers
        if not (height.is_integer() and width.is_integer() and 1 <= height <= 1e7 and 1 <= width <= 1e7
                and resolution > 0):
            raise ValueError(f"frame {height:g} x {width:g} cells of {resolution:g} m is not a grid's")
        return cls(int(height), int(width), resolution, (ox, oy, yaw))

    @property
    def shape(self) -> tuple[int, int]:
        return self.height, self.width

    def cell_to_world(self, row: Any, col: Any) -> tuple[Any, Any]:
        """World (x, y) of the centre of cell (row, col); numbers or numpy arrays (fractions allowed)."""
        r, c = np.asarray(row, dtype=float), np.asarray(col, dtype=float)
        lx = (c + 0.5) * self.resolution
        ly = (self.height - r - 0.5) * self.resolution
        ox, oy, yaw = self.origin
        if yaw == 0.0:
            x, y = lx + ox, ly + oy
        else:
            cos, sin = math.cos(yaw), math.sin(yaw)
            x, y = ox + cos * lx - sin * ly, oy + sin * lx + cos * ly
        if x.ndim == 0:
            return float(x), float(y)
        return x, y

    def world_to_cell(self, x: Any, y: Any) -> tuple[Any, Any]:
        """The cell (row, col) containing world point (x, y); may be outside (see :meth:`contains_cell`)."""
        ox, oy, yaw = self.origin
        dx, dy = np.asarray(x, dtype=float) - ox, np.asarray(y, dtype=float) - oy
        cos, sin = math.cos(yaw), math.sin(yaw)
        lx, ly = cos * dx + sin * dy, -sin * dx + cos * dy
        col = np.floor(lx / self.resolution).astype(int)
        row = self.height - 1 - np.floor(ly / self.resolution).astype(int)
        if row.ndim == 0:
            return int(row), int(col)
        return row, col

    def contains_cell(self, row: int, col: int) -> bool:
        """Whether (row, col) is a cell of this grid."""
        return 0 <= row < self.height and 0 <= col < self.width

    def disc(self, x: float, y: float, radius: float) -> tuple[tuple[slice, slice], np.ndarray] | None:
        """The cells within ``radius`` metres of world (x, y), measured between cell indices:
        the window of the grid that holds them and a boolean mask over that window
        (``array[window][mask]``), or None when none of them is on the grid."""
        row, col = self.world_to_cell(x, y)
        cells = radius / self.resolution
        span = int(math.ceil(cells))
        r0, r1 = max(row - span, 0), min(row + span + 1, self.height)
        c0, c1 = max(col - span, 0), min(col + span + 1, self.width)
        if r0 >= r1 or c0 >= c1:
            return None
        rows, cols = np.ogrid[r0:r1, c0:c1]
        return (slice(r0, r1), slice(c0, c1)), (rows - row) ** 2 + (cols - col) ** 2 <= cells ** 2

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the grid's area in the world (axis-aligned, yaw included)."""
        corners_r = np.array([-0.5, -0.5, self.height - 0.5, self.height - 0.5])
        corners_c = np.array([-0.5, self.width - 0.5, -0.5, self.width - 0.5])
        xs, ys = self.cell_to_world(corners_r, corners_c)
        return float(xs.min()), float(ys.min()), float(xs.max()), float(ys.max())
