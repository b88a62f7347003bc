"""Pictures of each map level, for people: PNGs in metres, one function per level.

Every picture is drawn the same way: the grid's area (``frame.extent``) in
metres with equal aspect, a title on the left and the grid's size on the
right, a horizontal colorbar under the map when a colour means a number,
and a legend beside the map when symbols mean things.

* :func:`render_grid` -- occupancy probability in grey (white free, black
  occupied, unknown = NaN in a blue-grey tint), optionally a robot path;
* :func:`render_edges` -- occupied and empty edge cells (boolean masks) or
  edge polylines in metres;
* :func:`render_polygons` -- polygons in metres, filled even-odd (outlines
  inside others are holes) and numbered;
* :func:`render_distance_transform` -- distances in metres (magma: obstacles
  black, far from them bright);
* :func:`render_places` -- a label image, each place its own colour and
  named at its centroid;
* :func:`render_stochastic_sdt` -- skeleton cells coloured by P(empty)
  (red through amber to green), thickened so a one-cell skeleton shows at
  any size;
* :func:`render_topology` -- a graph's nodes (X crossing / T junction /
  L end), its edges along their cells coloured by probability, and
  optionally a route;
* :func:`render_route` -- waypoints over the occupancy grid (and a graph).

``background`` is always an occupancy probability grid of the frame's
shape, drawn faintly under the picture.

The functions take plain numpy arrays, a :class:`GridFrame` and (for the
topology) any networkx-like graph, so they depend on no other map class.
Big grids are reduced before drawing to about one cell per screen pixel,
block by block so that nothing thin disappears (the most occupied cell of
a block wins, the smallest distance, the lowest skeleton probability, any
edge cell); the title says "shown 1:k" when that happened.

How a picture is drawn, and why it is quick: all the pictures of one map
can share one :class:`MapSheet` (``sheet=``; :func:`atlas_rap.views.map_levels.write_levels`
passes one to every call, a call without one makes its own). The sheet is
a matplotlib figure (``Figure`` + Agg canvas, no pyplot) with the axes in
metres, their ticks and labels and the grid's outline, rendered once. A
picture starts from a copy of those pixels; its grids are coloured with
numpy through one colour lookup table each, composited at the reduced size
and written into the pixels at once (no matplotlib image); then only the
picture's own artists are rendered -- one collection per kind of thing
(edges, nodes, node letters, place names, polygons) rather than one artist
per element -- with its titles, legend and colorbar. The result is cropped
to what it shows plus a margin (what ``bbox_inches="tight"`` gives,
without drawing twice) and written by :func:`atlas_rap.views.page.write_png`.
The sheet also keeps what several pictures share: the reduced grids and the
faint background. For a map of about 400 × 400 cells the sheet costs some
50 ms and each picture on it about 40 ms (most of it matplotlib laying out
and rasterising text, then zlib); a 4000 × 4000 grid takes a few tenths of
a second a picture.

matplotlib and scipy are imported inside the functions, so importing this
module stays cheap. The same inputs give the same PNG bytes.

Over 25 KB on purpose: every map picture draws on one reused :class:`MapSheet` (its figure,
axes and fonts made once per size, which is what makes writing all the levels fast), and the
renderers share its drawing helpers; apart, they would reach into each other's internals.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from atlas_rap.maps.frame import GridFrame
from atlas_rap.views.page import DPI as _DPI
from atlas_rap.views.page import PAD_INCHES as _PAD_INCHES
from atlas_rap.views.page import map_layout, plain_text, save_figure_png, write_png

if TYPE_CHECKING:
    from typing import Self

    import networkx

__all__ = [
    "MapSheet",
    "render_distance_transform",
    "render_edges",
    "render_grid",
    "render_places",
    "render_polygons",
    "render_route",
    "render_stochastic_sdt",
    "render_topology",
]


# Look of the pictures ---------------------------------------------------------

_LINE_PX = 4.0  # thin things (skeletons, edge cells) are thickened to about this many pixels

_UNKNOWN = "#c5d3e6"  # NaN in the occupancy grid: a blue-grey, never mistaken for a grey probability
_FAINT_OCCUPIED = "#8f8f8f"  # the faint background map: white free ... this grey occupied
_FAINT_UNKNOWN = "#edf1f7"
_FRAME_EDGE = "#b0b0b0"
_PATH = "#1e63d6"
_ROUTE = "#1e63d6"
_OCCUPIED_EDGE = "#c62828"
_EMPTY_EDGE = "#1e88e5"
_NO_PROBABILITY = "#555555"
# Probabilities: red (0, unlikely empty / passable) through amber to green (1). Like RdYlGn, but its
# middle is a saturated amber rather than a pale yellow that vanishes on a white map.
_PROBABILITY_COLOURS = ("#b2182b", "#e8590c", "#f0b400", "#8cc63f", "#1a7f37")
_DISTANCE_CMAP = "magma"  # perceptual; 0 (obstacles) is black
_PALETTE = (  # places and polygons: strong colours first, then lighter ones
    "#4e79a7", "#f28e2b", "#59a14f", "#e15759", "#b07aa1",
    "#76b7b2", "#edc948", "#9c755f", "#ff9da7", "#bab0ac",
    "#aec7e8", "#ffbb78", "#98df8a", "#ff9896", "#c5b0d5",
    "#c49c94", "#f7b6d2", "#dbdb8d", "#9edae5", "#c7c7c7",
)
_NODE_STYLE: dict[str, tuple[str, str, float]] = {
    # kind: (marker, colour, size in points)
    "X": ("D", "#7b1fa2", 7.5),
    "T": ("^", "#ef6c00", 8.0),
    "L": ("o", "#00838f", 7.0),
}
_OTHER_NODE = ("o", "#757575", 6.0)
_NODE_MEANING = {"X": "crossing", "T": "junction", "L": "end"}  # atlas_rap.maps.topology's kinds


# Public functions ---------------------------------------------------------------


def render_grid(
    p_occ: np.ndarray,
    frame: GridFrame,
    out_png: str | Path,
    *,
    title: str | None = None,
    path_xy: Any = None,
    sheet: MapSheet | None = None,
) -> Path:
    """Draw the occupancy probabilities ``p_occ`` (NaN = unknown) to ``out_png``; return its path.

    Grey from white (P = 0, free) to black (P = 1, occupied), unknown cells
    in a blue-grey tint, a colorbar for P(occupied). ``path_xy`` is an
    optional robot path, an (N, 2) sequence of world (x, y) in metres,
    drawn from a start circle to an end dot.
    """
    grid = _grid_array(p_occ, frame, "p_occ")
    path = None if path_xy is None else _points(path_xy, "path_xy")
    with _picture(frame, title or "occupancy grid", sheet) as pic:
        shown = pic.reduced(grid, "max")  # walls win a block, then known cells, then unknown
        pic.layer(_colourize(shown, "gray_r", 0.0, 1.0, bad=_UNKNOWN))
        pic.colorbar("gray_r", 0.0, 1.0, "P(occupied)")
        pic.legend_patch(_UNKNOWN, "unknown (NaN)")
        if path is not None:
            _draw_track(pic, path, label="robot path", ends=("start", "end"))
        return pic.save(out_png)


def render_edges(
    occupied_edges: Any,
    empty_edges: Any,
    frame: GridFrame,
    out_png: str | Path,
    *,
    title: str | None = None,
    background: np.ndarray | None = None,
    sheet: MapSheet | None = None,
) -> Path:
    """Draw occupied edges (red) and empty edges (blue) to ``out_png``; return its path.

    Each of ``occupied_edges`` and ``empty_edges`` is either a boolean mask
    of the frame's shape (edge cells, thickened so they show at any size),
    or a sequence of polylines / segments in world metres (each an (N, 2)
    array-like, N >= 2), or None for none.
    """
    with _picture(frame, title or "edges", sheet) as pic:
        _draw_background(pic, background)
        for edges, colour, label in ((occupied_edges, _OCCUPIED_EDGE, "occupied edge"),
                                     (empty_edges, _EMPTY_EDGE, "empty edge")):
            if edges is None:
                continue
            if isinstance(edges, np.ndarray) and edges.dtype == bool:
                _draw_mask(pic, _grid_array(edges, frame, label + "s"), colour)
            else:
                lines = [_points(line, label) for line in edges]
                _draw_lines(pic, [line for line in lines if len(line) >= 2], colour)
            pic.legend_line(colour, label, width=2.5)
        return pic.save(out_png)


def render_polygons(
    polygons: Sequence[Any],
    frame: GridFrame,
    out_png: str | Path,
    *,
    background: np.ndarray | None = None,
    title: str | None = None,
    sheet: MapSheet | None = None,
) -> Path:
    """Draw ``polygons`` (each an (N, 2) array of world x, y; closed or not) to ``out_png``; return its path.

    Outlines inside others are holes (as ``find_contours`` gives them):
    the fill is even-odd, so a region's holes stay unfilled and an island
    in a hole is filled again. Each outer outline and its holes share a
    colour and are numbered with the outer outline's index in
    ``polygons`` (up to 80 of them); vertices are small dots.
    """
    from matplotlib.collections import PathCollection
    from matplotlib.path import Path as MplPath

    rings = [_points(p, f"polygon {i}") for i, p in enumerate(polygons)]
    rings = [ring[:-1] if len(ring) > 3 and np.array_equal(ring[0], ring[-1]) else ring for ring in rings]
    with _picture(frame, title or "polygons", sheet) as pic:
        _draw_background(pic, background)
        shapes = _nest_rings(rings)
        numbered = len(shapes) <= 80  # beyond that the numbers would only clutter
        paths, vertices, vertex_shape = [], [], []
        for outer, holes in shapes:
            parts = [_oriented(rings[outer], ccw=True)] + [_oriented(rings[h], ccw=False) for h in holes]
            # One compound path a shape: outer ring counter-clockwise, holes clockwise, so a nonzero fill
            # leaves the holes open. (closed=True takes the last vertex as the CLOSEPOLY code's: repeat the first.)
            paths.append(MplPath.make_compound_path(*(MplPath(np.vstack([part, part[:1]]), closed=True)
                                                      for part in parts)))
            vertices.extend(parts)
            vertex_shape.extend([len(paths) - 1] * len(parts))
        if paths:
            colours = np.array([_rgba(_PALETTE[n % len(_PALETTE)]) for n in range(len(paths))])
            edges = colours.copy()
            edges[:, :3] *= 0.65  # _darker
            pic.ax.add_collection(PathCollection(paths, facecolors=colours, alpha=0.35, edgecolors="none",
                                                 zorder=2))
            pic.ax.add_collection(PathCollection(paths, facecolors="none", edgecolors=edges, linewidths=1.3,
                                                 joinstyle="round", zorder=3))
            counts = [len(part) for part in vertices]
            dots = np.vstack(vertices)
            dot_colours = np.repeat(edges[np.asarray(vertex_shape)], counts, axis=0)
            pic.ax.scatter(dots[:, 0], dots[:, 1], s=2.2 ** 2, marker="o", facecolors=dot_colours,
                           edgecolors=dot_colours, linewidths=1.0, zorder=3.5)
        if numbered:
            for outer, holes in shapes:
                at = _polygon_centroid(rings[outer])
                inside = MplPath(rings[outer]).contains_point(at)
                if not inside or any(MplPath(rings[h]).contains_point(at) for h in holes):
                    # e.g. a ring-shaped wall: name it at its first corner
                    at = rings[outer][0]
                pic.label(at, str(outer), colour="#222222", fontsize=7.5)
        n_holes = sum(len(holes) for _, holes in shapes)
        pic.legend_patch(_PALETTE[0], f"polygon ({len(shapes)})", alpha=0.35, edge=_darker(_PALETTE[0]))
        if n_holes:
            pic.legend_patch("white", f"hole ({n_holes})", edge=_darker(_PALETTE[0]))
        pic.legend_marker("o", "#555555", "vertex", size=3.5)
        return pic.save(out_png)


def render_distance_transform(
    dt_metres: np.ndarray,
    frame: GridFrame,
    out_png: str | Path,
    *,
    title: str | None = None,
    sheet: MapSheet | None = None,
) -> Path:
    """Draw distances to the nearest obstacle (metres; NaN = unknown) to ``out_png``; return its path.

    magma from black (0 m, obstacles) to pale yellow (the largest distance),
    with a colorbar in metres; unknown cells in the unknown tint.
    """
    dt = _grid_array(dt_metres, frame, "dt_metres")
    with _picture(frame, title or "distance transform", sheet) as pic:
        shown = np.array(pic.reduced(dt, "min"), dtype=float)  # obstacles (0 m) never vanish
        shown[~np.isfinite(shown)] = np.nan  # (inf: no obstacle anywhere) shown as unknown
        top = float(np.nanmax(shown)) if np.isfinite(shown).any() else 1.0
        top = top if top > 0 else 1.0
        pic.layer(_colourize(shown, _DISTANCE_CMAP, 0.0, top, bad=_UNKNOWN))
        pic.colorbar(_DISTANCE_CMAP, 0.0, top, "distance to the nearest obstacle (m)")
        if np.isnan(shown).any():
            pic.legend_patch(_UNKNOWN, "unknown")
        return pic.save(out_png)


def render_places(
    labels: np.ndarray,
    frame: GridFrame,
    out_png: str | Path,
    *,
    names: dict[int, str] | None = None,
    background: np.ndarray | None = None,
    title: str | None = None,
    sheet: MapSheet | None = None,
) -> Path:
    """Draw the place label image ``labels`` to ``out_png``; return its path.

    Labels > 0 are places (0 and negative labels are "no place", as in
    scikit-image, unless ``names`` names them). Each place gets its own
    colour (up to 20 places all differ; with more, neighbouring places
    still differ) and is named (``names[label]``, else the number) at its
    centroid, or at its innermost cell when the centroid falls outside it.
    """
    names = dict(names or {})
    grid = _grid_array(labels, frame, "labels")
    if not np.issubdtype(grid.dtype, np.integer):
        raise ValueError(f"labels must be integers, not {grid.dtype}")
    with _picture(frame, title or "places", sheet) as pic:
        _draw_background(pic, background)
        shown = pic.reduced(grid, "first")
        ids = [int(v) for v in np.unique(shown) if v > 0 or int(v) in names]
        if ids:
            colours = _place_colours(shown, ids)
            alpha = 0.6 if background is not None else 0.8
            table = np.zeros((len(ids) + 1, 4), dtype=np.uint8)  # a colour per place; the last: no place
            table[:-1] = _rgba_bytes([colours[i] for i in ids], alpha=alpha)
            lookup = np.searchsorted(ids, shown)
            inside = (lookup < len(ids)) & (np.asarray(ids)[np.minimum(lookup, len(ids) - 1)] == shown)
            pic.layer(table[np.where(inside, lookup, len(ids))])
            fontsize = 8.5 if len(ids) <= 40 else 6.5
            cells = np.array(_label_cells(shown, ids), dtype=float).reshape(-1, 2)
            xs, ys = frame.cell_to_world(cells[:, 0] * pic.k + (pic.k - 1) / 2, cells[:, 1] * pic.k + (pic.k - 1) / 2)
            pic.labels(np.column_stack([np.atleast_1d(xs), np.atleast_1d(ys)]),
                       [names.get(place, str(place)) for place in ids], colour="#1a1a1a", fontsize=fontsize)
        pic.detail += f", {len(ids)} places"
        return pic.save(out_png)


def render_stochastic_sdt(
    skeleton_probability: np.ndarray,
    frame: GridFrame,
    out_png: str | Path,
    *,
    background: np.ndarray | None = None,
    title: str | None = None,
    sheet: MapSheet | None = None,
) -> Path:
    """Draw skeleton cells coloured by P(empty) (NaN = off the skeleton) to ``out_png``; return its path.

    Red (0) through amber to green (1), with a colorbar, over the faint
    ``background`` map. The skeleton is thickened (a grey dilation that
    keeps the lowest probability nearby) to about four pixels, so a
    one-cell skeleton shows at any picture size; the title says how wide
    it is drawn.
    """
    prob = _grid_array(skeleton_probability, frame, "skeleton_probability")
    with _picture(frame, title or "stochastic skeleton", sheet) as pic:
        _draw_background(pic, background)
        shown = pic.reduced(prob, "min")  # the weakest cell of a block speaks for it
        radius = pic.thickening_radius()
        shown = _dilate(shown, radius, "min")
        pic.layer(_colourize(shown, "probability", 0.0, 1.0, bad=(0, 0, 0, 0)))
        pic.colorbar("probability", 0.0, 1.0, "P(empty) on the skeleton")
        if radius:
            pic.detail += f", skeleton drawn {2 * radius + 1} cells wide"
        return pic.save(out_png)


def render_topology(
    graph: networkx.Graph,
    frame: GridFrame,
    out_png: str | Path,
    *,
    background: np.ndarray | None = None,
    route: Any = None,
    title: str | None = None,
    sheet: MapSheet | None = None,
) -> Path:
    """Draw a topological graph to ``out_png``; return its path.

    Nodes sit at their ``xy`` attribute (world x, y), with a marker, colour
    and letter by their ``kind`` attribute ("X" crossing, "T" junction, "L"
    end; anything else in grey). Edges follow their ``cells`` attribute, an ordered list of
    (row, col), joined to their end nodes (a straight line without it),
    coloured by their ``probability`` attribute (red 0 ... green 1, with a
    colorbar; dark grey without one). ``route`` is a list of node ids
    (followed along the edges' cells) or an (N, 2) array of world
    waypoints (marked with dots), highlighted as a wide translucent blue
    band under the edges, from a start ring to a goal ring.
    """
    return _render_graph(graph, frame, out_png, background=background, route=route,
                         title=title or "topological graph", sheet=sheet)


def render_route(
    p_occ: np.ndarray,
    frame: GridFrame,
    waypoints_xy: Any,
    out_png: str | Path,
    *,
    graph: networkx.Graph | None = None,
    title: str | None = None,
    sheet: MapSheet | None = None,
) -> Path:
    """Draw waypoints (an (N, 2) sequence of world x, y) as a route over the faint map ``p_occ``; return the path.

    A blue line from a start circle through waypoint dots to a goal dot.

    With ``graph`` the topological graph is drawn too (this is
    :func:`render_topology` with the waypoints as its route).
    """
    return _render_graph(graph, frame, out_png, background=p_occ, route=_points(waypoints_xy, "waypoints_xy"),
                         title=title or "route", sheet=sheet)


# The sheet: one figure for every picture of a map ---------------------------------

# Inches round the map on the sheet: (left, bottom, right, top). Generous, so that the legend, a long title
# and the colorbar fit; each picture is cropped to what it shows. The colorbar sits _CBAR_BELOW inches under
# the map.
_SHEET_MARGINS = (1.4, 1.8, 4.6, 1.0)
_CBAR_BELOW = 0.78


class MapSheet:
    """The page every picture of one map is drawn on: a figure with the axes in metres, drawn once.

    It holds the figure, its axes (limits, equal aspect, ticks, axis
    labels, the grid's outline) rendered to pixels once, and what several
    pictures of the map share: grids reduced for display and the faint
    background map (both remembered by array identity: do not change an
    array while a sheet that has seen it is in use). Give one to every
    ``render_*`` call of a map (``sheet=``) and close it at the end (or use
    it as a context manager); one picture at a time, in one thread.
    """

    def __init__(self, frame: GridFrame) -> None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        _check_frame(frame)
        self.frame = frame
        self.limits, map_w, map_h = map_layout(*frame.extent)
        xmin, xmax, ymin, ymax = self.limits
        scale = map_w / (xmax - xmin)

        # Reduce grids to at most about one cell per screen pixel (k × k cells per shown cell).
        px_per_cell = scale * frame.resolution * _DPI
        self.k = max(1, math.ceil(1.0 / px_per_cell - 1e-9))
        self.px_per_shown_cell = px_per_cell * self.k

        left, bottom, right, top = _SHEET_MARGINS
        fig_w, fig_h = left + map_w + right, bottom + map_h + top
        self.fig = Figure(figsize=(fig_w, fig_h), dpi=_DPI, facecolor="white")
        self.canvas = FigureCanvasAgg(self.fig)
        self.ax = ax = self.fig.add_axes((left / fig_w, bottom / fig_h, map_w / fig_w, map_h / fig_h))
        self.cbar_box = (left / fig_w, (bottom - _CBAR_BELOW) / fig_h, min(map_w * 0.6, 3.4) / fig_w, 0.1 / fig_h)
        ax.set_facecolor("white")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.tick_params(labelsize=8)
        for spine in ax.spines.values():
            spine.set_color("#999999")
        ax.set_xlim(xmin, xmax)
        ax.set_ylim(ymin, ymax)
        ax.set_aspect("equal", adjustable="box")
        ax.set_autoscale_on(False)  # pictures add artists; the limits stay the map's
        _draw_frame_outline(self)

        self._page: Any = None  # the rendered sheet (a canvas region), made before the first picture
        self._page_box: Any = None  # its tight bounding box (axes, ticks, labels), display pixels
        self._static: set[Any] = set()  # the axes' own artists; anything else belongs to a picture
        self._busy = False
        self._closed = False
        self._cax: Any = None  # the colorbar's axes and image, made for the first picture with a colorbar
        self._cax_image: Any = None
        self._memo: dict[Any, Any] = {}
        self._keep: list[Any] = []  # arrays memoised by id, kept alive so their ids stay theirs

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Free the figure and what the sheet remembers."""
        self._memo.clear()
        self._keep.clear()
        self._page = None
        self._closed = True
        self.fig.clear()

    # shared between pictures

    def reduced(self, grid: np.ndarray, how: str) -> np.ndarray:
        """``grid`` reduced for display (see :func:`_reduce`), computed once per grid and ``how``."""
        if self.k == 1:
            return grid
        key = ("reduced", id(grid), how)
        if key not in self._memo:
            self._keep.append(grid)
            self._memo[key] = _reduce(grid, self.k, how)
        return self._memo[key]

    def faint(self, background: np.ndarray) -> tuple[np.ndarray, bool, bool]:
        """The faint background map as RGBA bytes, and whether it shows occupied and unknown cells."""
        key = ("faint", id(background))
        if key not in self._memo:
            self._keep.append(background)
            shown = self.reduced(background, "max")
            shown = np.asarray(shown, dtype=float)
            unknown = bool(np.isnan(shown).any())
            occupied = bool(np.nan_to_num(shown, nan=0.0).max(initial=0.0) >= 0.5)
            self._memo[key] = (_colourize(shown, "faint", 0.0, 1.0, bad=_FAINT_UNKNOWN), occupied, unknown)
        return self._memo[key]

    def text_path(self, text: str, fontsize: float, ha: str, va: str,
                  offset: tuple[float, float]) -> tuple[Any, np.ndarray]:
        """A bold label as a path in points, aligned like ``Text`` (``ha``, ``va``) and moved by ``offset``; its box.

        The box is (x0, y0, x1, y1) in points.
        """
        key = ("text", text, fontsize, ha, va, offset)
        if key not in self._memo:
            from matplotlib.font_manager import FontProperties
            from matplotlib.path import Path as MplPath
            from matplotlib.textpath import TextPath, text_to_path

            prop = FontProperties(weight="bold", size=fontsize)
            s = plain_text(text)
            path = TextPath((0, 0), s, prop=prop)
            w, h, d = text_to_path.get_text_width_height_descent(s, prop, ismath=False)
            _, lp_h, lp_d = text_to_path.get_text_width_height_descent("lp", prop, ismath=False)
            h, d = max(h, lp_h), max(d, lp_d)  # as Text lays out a line
            dx = {"left": 0.0, "center": -w / 2, "right": -w}[ha]
            dy = {"bottom": d, "center": d - h / 2, "top": d - h, "baseline": 0.0}[va]
            vertices = path.vertices + (dx + offset[0], dy + offset[1])
            # Its box from the control points (they bound the curves; Path.get_extents is slow on glyphs).
            box = np.concatenate([vertices.min(axis=0), vertices.max(axis=0)]) if len(vertices) else np.zeros(4)
            self._memo[key] = (MplPath(vertices, path.codes), box)
        return self._memo[key]

    # drawing

    def _colorbar(self, cmap: str, vmin: float, vmax: float, label: str) -> Any:
        """The sheet's colorbar axes showing ``cmap`` from ``vmin`` to ``vmax`` (made once, shown per picture).

        It looks like ``Figure.colorbar`` with a horizontal bar: the
        colours as an image along x, ticks and the label under it, a thin
        outline; making a colorbar afresh for every picture costs more
        than the rest of the picture.
        """
        if self._cax is None:
            cax = self.fig.add_axes(self.cbar_box)
            cax.set_navigate(False)
            cax.set_autoscale_on(False)
            cax.set_yticks([])
            cax.tick_params(axis="x", labelsize=7, length=2)
            for spine in cax.spines.values():
                spine.set_linewidth(0.5)
            self._cax_image = cax.imshow(np.zeros((1, 2, 4), dtype=np.uint8), aspect="auto",
                                         interpolation="nearest", extent=(0.0, 1.0, 0.0, 1.0))
            cax.set_ylim(0.0, 1.0)
            self._cax = cax
        cax = self._cax
        self._cax_image.set_data(_lut(cmap)[None, :, :])
        self._cax_image.set_extent((vmin, vmax, 0.0, 1.0))
        cax.set_xlim(vmin, vmax)
        cax.set_xlabel(label, fontsize=8, labelpad=2)
        cax.set_visible(True)
        return cax

    def _begin(self) -> None:
        """Ready for a picture: the sheet rendered (the first time) and nothing of another picture on it."""
        if self._closed:
            raise RuntimeError("this MapSheet is closed")
        if self._busy:
            raise RuntimeError("a MapSheet draws one picture at a time")
        self._busy = True
        if self._page is None:
            self.canvas.draw()
            renderer = self.canvas.get_renderer()
            self._page = self.canvas.copy_from_bbox(self.fig.bbox)
            self._page_box = self.ax.get_tightbbox(renderer)
            self._static = set(self.ax.get_children())

    def _end(self) -> None:
        """Take the picture's artists off the sheet again."""
        for artist in [a for a in self.ax.get_children() if a not in self._static]:
            artist.remove()
        if self._cax is not None:
            self._cax.set_visible(False)  # until a picture with a colorbar
        self._busy = False

    def _blit(self, rgba: np.ndarray) -> None:
        """Write a shown grid (RGBA bytes, rows from the top) into the rendered pixels, where imshow would put it.

        Nearest-neighbour, each screen pixel takes the cell under its
        centre, clipped to the axes; translucent cells are blended with
        what is there (the sheet's white and the grid's outline). Pixels
        move as one 32-bit word each: one gather for the whole picture.
        """
        h, w = rgba.shape[:2]
        key = ("blit", h, w)
        if key not in self._memo:
            self._memo[key] = self._blit_indices(h, w)
        gather, r0, c0 = self._memo[key]
        if gather.size == 0:
            return
        pixels = np.asarray(self.canvas.get_renderer().buffer_rgba())
        words = np.ascontiguousarray(rgba).view(np.uint32).reshape(-1)
        shown = np.take(words, gather)
        target = pixels[r0:r0 + gather.shape[0], c0:c0 + gather.shape[1]]
        alpha = rgba[..., 3]
        if alpha.min() == 255:
            target.view(np.uint32)[..., 0] = shown
            return
        up = shown.view(np.uint8).reshape(gather.shape + (4,))
        a = up[..., 3:4].astype(np.uint16)
        rgb = target[..., :3]
        rgb[...] = ((up[..., :3] * a + rgb * (255 - a) + 127) // 255).astype(np.uint8)

    def _blit_indices(self, h: int, w: int) -> tuple[np.ndarray, int, int]:
        """For a shown grid of h × w: the flat index of the cell each pixel shows, and the first pixel row, column."""
        frame, k = self.frame, self.k
        ox, oy, _ = frame.origin
        res = frame.resolution
        top = oy + frame.height * res
        (x0, y0), (x1, y1) = self.ax.transData.transform([(ox, top - h * k * res), (ox + w * k * res, top)])
        box = self.ax.bbox  # display pixels, y up
        height = self.fig.bbox.height
        # Pixels whose centre is inside both the grid and the axes (Agg rounds the clip box to whole pixels).
        cx = np.arange(max(math.ceil(x0 - 0.5), math.floor(box.x0 + 0.5)),
                       min(math.ceil(x1 - 0.5), math.floor(box.x1 + 0.5)))
        cy = np.arange(max(math.ceil(y0 - 0.5), math.floor(box.y0 + 0.5)),
                       min(math.ceil(y1 - 0.5), math.floor(box.y1 + 0.5)))[::-1]  # top row first
        cols = np.clip(np.floor((cx + 0.5 - x0) / (x1 - x0) * w).astype(np.intp), 0, w - 1)
        rows = np.clip(np.floor((y1 - (cy + 0.5)) / (y1 - y0) * h).astype(np.intp), 0, h - 1)
        r0 = round(height) - 1 - int(cy[0]) if len(cy) else 0
        c0 = int(cx[0]) if len(cx) else 0
        return rows[:, None] * w + cols[None, :], r0, c0


class _Picture:
    """One map picture being drawn on a :class:`MapSheet`: its grid layers, labels, legend and colorbar."""

    def __init__(self, sheet: MapSheet, title: str) -> None:
        sheet._begin()
        self.sheet = sheet
        self.frame = sheet.frame
        self.fig, self.ax = sheet.fig, sheet.ax
        self.k = sheet.k
        self.px_per_shown_cell = sheet.px_per_shown_cell
        self.title = title
        self.detail = f"{self.frame.height} \u00d7 {self.frame.width} cells of {self.frame.resolution:g} m"
        if self.k > 1:
            self.detail += f", shown 1:{self.k}"
        self.handles: list[Any] = []
        self._layers: list[np.ndarray] = []
        self._labels: list[tuple[np.ndarray, list[str], str, float, tuple[float, float], str, str]] = []
        self._colorbars: list[Any] = []

    # drawing

    def reduced(self, grid: np.ndarray, how: str) -> np.ndarray:
        return self.sheet.reduced(grid, how)

    def layer(self, rgba: np.ndarray) -> None:
        """A shown grid coloured as RGBA bytes (see :meth:`reduced`), drawn over the layers before it.

        The layers go under everything else in the picture (lines,
        markers, labels), as imshow images at zorder <= 2 did.
        """
        self._layers.append(rgba)

    def thickening_radius(self) -> int:
        """Dilation radius (in shown cells) that makes a one-cell line about ``_LINE_PX`` pixels wide."""
        return max(0, math.floor((_LINE_PX / self.px_per_shown_cell - 1) / 2 + 0.5))

    def label(self, xy: Any, text: str, *, colour: Any, fontsize: float, offset: tuple[float, float] = (0, 0),
              ha: str = "center", va: str = "center") -> None:
        """A bold text with a white halo at world ``xy`` (moved by ``offset`` points)."""
        self.labels(np.asarray(xy, dtype=float).reshape(1, 2), [text], colour=colour, fontsize=fontsize,
                    offset=offset, ha=ha, va=va)

    def labels(self, xy: np.ndarray, texts: str | list[str], *, colour: Any, fontsize: float,
               offset: tuple[float, float] = (0, 0), ha: str = "center", va: str = "center") -> None:
        """Many labels at world points ``xy`` (N, 2): one text for all, or one each. Drawn as two collections."""
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        texts = [texts] * len(xy) if isinstance(texts, str) else list(texts)
        xmin, xmax, ymin, ymax = self.sheet.limits
        seen = (xy[:, 0] >= xmin) & (xy[:, 0] <= xmax) & (xy[:, 1] >= ymin) & (xy[:, 1] <= ymax)
        if not seen.all():  # as annotation_clip: a label whose point is off the axes is not drawn
            texts = [t for t, s in zip(texts, seen) if s]
            xy = xy[seen]
        if len(xy):
            self._labels.append((xy, texts, colour, fontsize, (float(offset[0]), float(offset[1])), ha, va))

    def colorbar(self, cmap: str, vmin: float, vmax: float, label: str) -> None:
        """A horizontal colorbar under the map: ``cmap`` from ``vmin`` to ``vmax``, titled ``label``."""
        self._colorbars.append(self.sheet._colorbar(cmap, vmin, vmax, label))

    def legend_line(self, colour: Any, label: str, *, width: float = 2.0, alpha: float = 1.0) -> None:
        from matplotlib.lines import Line2D

        self.handles.append(Line2D([], [], color=colour, linewidth=width, alpha=alpha, label=label,
                                   solid_capstyle="round"))

    def legend_marker(self, marker: str, colour: Any, label: str, *, size: float = 7.0,
                      face: Any = None) -> None:
        from matplotlib.lines import Line2D

        self.handles.append(Line2D([], [], linestyle="none", marker=marker, markersize=size,
                                   markerfacecolor=colour if face is None else face, markeredgecolor=colour,
                                   markeredgewidth=1.2, label=label))

    def legend_patch(self, colour: Any, label: str, *, alpha: float = 1.0, edge: Any = "#999999") -> None:
        from matplotlib.patches import Patch

        self.handles.append(Patch(facecolor=colour, alpha=alpha, edgecolor=edge, linewidth=0.6, label=label))

    # finishing

    def save(self, out_png: str | Path) -> Path:
        """Render the picture on its sheet, crop it to what it shows (plus a margin) and write the PNG."""
        from matplotlib.transforms import Bbox

        out = Path(out_png)
        out.parent.mkdir(parents=True, exist_ok=True)
        sheet, ax = self.sheet, self.ax
        renderer = sheet.canvas.get_renderer()
        texts = self._titles()
        if self.handles:
            ax.legend(handles=self.handles, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0,
                      fontsize=8, frameon=False, handlelength=1.8, labelspacing=0.45)
        label_box = self._add_labels()
        raster = _composite(self._layers)
        blit = raster is not None and self.frame.origin[2] == 0.0
        if raster is not None and not blit:
            self._raster_image(raster)  # a rotated grid: matplotlib places it

        sheet.canvas.restore_region(sheet._page)
        if blit:
            sheet._blit(raster)
        own = [a for a in ax.get_children() if a not in sheet._static]
        for artist in sorted(own + list(ax.spines.values()), key=lambda a: a.get_zorder()):
            artist.draw(renderer)  # as Axes.draw: by zorder, ties in the order added; spines over the grids
        for cax in self._colorbars:
            cax.draw(renderer)

        boxes = [sheet._page_box, label_box, *(t.get_window_extent(renderer) for t in texts)]
        if ax.legend_ is not None:
            boxes.append(ax.legend_.get_window_extent(renderer))
        boxes += [cax.get_tightbbox(renderer) for cax in self._colorbars]
        box = Bbox.union([b for b in boxes if b is not None and (b.width > 0 or b.height > 0)])
        pad = _PAD_INCHES * _DPI
        width, height = sheet.fig.bbox.width, sheet.fig.bbox.height
        x0, x1 = math.floor(box.x0 - pad), math.ceil(box.x1 + pad)
        y0, y1 = math.floor(box.y0 - pad), math.ceil(box.y1 + pad)
        if x0 >= 0 and y0 >= 0 and x1 <= width and y1 <= height:
            pixels = np.asarray(renderer.buffer_rgba())
            rows = pixels.shape[0]
            return write_png(pixels[rows - y1:rows - y0, x0:x1], out)
        # Something reaches past the sheet (a very long title?): let matplotlib lay the page out.
        if blit:
            self._raster_image(raster)
        save_figure_png(sheet.fig, out, dpi=_DPI, bbox_inches="tight", pad_inches=_PAD_INCHES)
        sheet._page = None  # savefig resized the canvas for a while: render the sheet afresh next time
        return out

    def close(self) -> None:
        self.sheet._end()

    def _titles(self) -> list[Any]:
        """The title (left) and the detail (right) above the map, placed as ``Axes.set_title`` places them."""
        from matplotlib.transforms import ScaledTranslation

        ax = self.ax
        above = ax.transAxes + ScaledTranslation(0, 6 / 72, self.fig.dpi_scale_trans)  # axes.titlepad: 6 pt
        return [ax.text(0.0, 1.0, plain_text(self.title), transform=above, ha="left", va="baseline", fontsize=11),
                ax.text(1.0, 1.0, self.detail, transform=above, ha="right", va="baseline", fontsize=7.5,
                        color="#666666")]

    def _add_labels(self) -> Any:
        """Every label as two path collections (white halo, then the letters); their bounding box in pixels."""
        if not self._labels:
            return None
        from matplotlib.collections import PathCollection
        from matplotlib.transforms import Affine2D, Bbox

        paths, boxes, offsets, colours = [], [], [], []
        for xy, texts, colour, fontsize, offset, ha, va in self._labels:
            for text in texts:
                path, box = self.sheet.text_path(text, fontsize, ha, va, offset)
                paths.append(path)
                boxes.append(box)
            offsets.append(xy)
            colours.append(np.repeat([_rgba(colour)], len(xy), axis=0))
        xy, colours = np.vstack(offsets), np.vstack(colours)
        points = Affine2D().scale(_DPI / 72.0)
        style = {"offsets": xy, "offset_transform": self.ax.transData, "transform": points, "zorder": 9}
        halo = PathCollection(paths, facecolors=colours, edgecolors="white", linewidths=2.5, **style)
        letters = PathCollection(paths, facecolors=colours, edgecolors="none", **style)
        for collection in (halo, letters):
            collection.set_clip_on(False)
            self.ax.add_collection(collection, autolim=False)
        extents = np.array(boxes) * (_DPI / 72.0)  # x0, y0, x1, y1 in pixels
        anchors = self.ax.transData.transform(xy)
        grow = 1.25 * _DPI / 72.0  # half the halo
        lo = anchors + extents[:, :2] - grow
        hi = anchors + extents[:, 2:] + grow
        return Bbox([lo.min(axis=0), hi.max(axis=0)])

    def _raster_image(self, rgba: np.ndarray) -> Any:
        """The composited grid layers as a matplotlib image in their place in the world (yaw included)."""
        from matplotlib.transforms import Affine2D

        frame, k = self.frame, self.k
        ox, oy, yaw = frame.origin
        res = frame.resolution
        h, w = rgba.shape[:2]
        top = oy + frame.height * res
        extent = (ox, ox + w * k * res, top - h * k * res, top)  # padding of the last block hangs off the map
        image = self.ax.imshow(rgba, origin="upper", extent=extent, interpolation="nearest", zorder=1)
        if yaw:
            image.set_transform(Affine2D().rotate_around(ox, oy, yaw) + self.ax.transData)
        return image


@contextmanager
def _picture(frame: GridFrame, title: str, sheet: MapSheet | None) -> Iterator[_Picture]:
    """A picture of ``frame`` on ``sheet`` (or on a sheet of its own)."""
    _check_frame(frame)
    own = sheet is None
    if sheet is None:
        sheet = MapSheet(frame)
    elif sheet.frame != frame:
        theirs, ours = sheet.frame, frame
        raise ValueError(f"the sheet is for a {theirs.height} \u00d7 {theirs.width} grid at {theirs.origin}, "
                         f"not this frame ({ours.height} \u00d7 {ours.width} at {ours.origin})")
    try:
        pic = _Picture(sheet, title)
        try:
            yield pic
        finally:
            pic.close()
    finally:
        if own:
            sheet.close()


# Drawing ideas, each once ---------------------------------------------------------


def _draw_frame_outline(sheet: MapSheet) -> None:
    """The grid's boundary as a thin grey line (it shows where the map ends when little is drawn)."""
    f = sheet.frame
    rows = np.array([-0.5, -0.5, f.height - 0.5, f.height - 0.5, -0.5])
    cols = np.array([-0.5, f.width - 0.5, f.width - 0.5, -0.5, -0.5])
    xs, ys = f.cell_to_world(rows, cols)
    sheet.ax.plot(xs, ys, color=_FRAME_EDGE, linewidth=0.7, zorder=0.5)


def _draw_background(pic: _Picture, background: np.ndarray | None) -> None:
    """The faint occupancy map under a picture, and its two colours in the legend."""
    if background is None:
        return
    rgba, occupied, unknown = pic.sheet.faint(_grid_array(background, pic.frame, "background"))
    pic.layer(rgba)
    if occupied:
        pic.legend_patch(_FAINT_OCCUPIED, "map: occupied")
    if unknown:
        pic.legend_patch(_FAINT_UNKNOWN, "map: unknown")


def _draw_mask(pic: _Picture, mask: np.ndarray, colour: str) -> None:
    """Cells of a boolean mask in one colour, thickened so that one-cell lines show."""
    shown = _dilate(pic.reduced(mask.astype(bool), "any"), pic.thickening_radius(), "any")
    rgba = np.zeros(shown.shape + (4,), dtype=np.uint8)
    rgba[shown] = _rgba_bytes([colour])[0]
    pic.layer(rgba)


def _draw_lines(pic: _Picture, lines: list[np.ndarray], colour: Any, **style: Any) -> Any:
    """Polylines in metres (one colour, or one per line), one collection."""
    from matplotlib.collections import LineCollection

    style = {"linewidths": 2.0, "capstyle": "round", "joinstyle": "round", "zorder": 3, **style}
    collection = LineCollection(lines, colors=colour, **style)
    pic.ax.add_collection(collection, autolim=False)
    return collection


def _draw_track(pic: _Picture, xy: np.ndarray, *, label: str, ends: tuple[str, str], colour: str = _PATH,
                width: float = 2.2, alpha: float = 1.0, zorder: float = 5, waypoints: bool = False) -> None:
    """A path or route: a polyline from a hollow start circle to a filled end dot, all in the legend.

    A wide translucent ``width`` makes a highlighter band (its end circles
    grow with it, so they ring a node drawn on top); ``waypoints`` marks the
    points in between with small dots.
    """
    if len(xy) == 0:
        return
    from matplotlib import patheffects

    end_size = max(7.0, width + 5.0)
    if len(xy) >= 2:
        halo = [patheffects.withStroke(linewidth=width + 2, foreground="white", alpha=0.7)]
        pic.ax.plot(xy[:, 0], xy[:, 1], color=colour, linewidth=width, alpha=alpha, solid_capstyle="round",
                    solid_joinstyle="round", zorder=zorder, path_effects=halo if alpha == 1.0 else None)
        pic.legend_line(colour, label, width=min(width, 6.0), alpha=alpha)
    if waypoints and len(xy) > 2:
        pic.ax.plot(xy[1:-1, 0], xy[1:-1, 1], linestyle="none", marker="o", markersize=4.5,
                    markerfacecolor="white", markeredgecolor=colour, markeredgewidth=1.2, zorder=zorder + 0.4)
        pic.legend_marker("o", colour, "waypoint", size=4.5, face="white")
    pic.ax.plot(*xy[0], marker="o", markersize=end_size, markerfacecolor="white", markeredgecolor=colour,
                markeredgewidth=2.0, zorder=zorder + 0.5)
    pic.legend_marker("o", colour, ends[0], face="white")
    if len(xy) >= 2:
        pic.ax.plot(*xy[-1], marker="o", markersize=end_size, markerfacecolor=colour, markeredgecolor="white",
                    markeredgewidth=1.0, zorder=zorder + 0.5)
        pic.legend_marker("o", colour, ends[1])


def _render_graph(graph: Any, frame: GridFrame, out_png: str | Path, *, background: np.ndarray | None,
                  route: Any, title: str, sheet: MapSheet | None) -> Path:
    """The topology picture (``graph`` may be None: then only the background and the route)."""
    nodes: dict[Any, tuple[np.ndarray, str]] = {}
    lines: list[np.ndarray] = []
    probabilities: list[float | None] = []
    if graph is not None:
        for node, data in graph.nodes(data=True):
            if data.get("xy") is None:
                raise ValueError(f"graph node {node!r} has no xy attribute")
            nodes[node] = (np.asarray(data["xy"], dtype=float).reshape(2), str(data.get("kind", "")))
        ends, cells = [], []
        for u, v, data in graph.edges(data=True):
            p = data.get("probability")
            probabilities.append(None if p is None else float(p))
            ends.append((nodes[u][0], nodes[v][0]))
            cells.append(data.get("cells"))
        lines = _edge_polylines(frame, ends, cells)
    route_xy, route_is_waypoints = (None, False) if route is None else _route_points(graph, nodes, frame, route)

    with _picture(frame, title, sheet) as pic:
        _draw_background(pic, background)
        if route_xy is not None:  # a wide translucent band under the edges: the edges stay readable
            _draw_track(pic, route_xy, label="route", ends=("start", "goal"), colour=_ROUTE,
                        width=9.0 if graph is not None else 3.0, alpha=0.45 if graph is not None else 1.0,
                        zorder=2.5, waypoints=route_is_waypoints)
        if lines:
            known = [i for i, p in enumerate(probabilities) if p is not None]
            unknown = [i for i, p in enumerate(probabilities) if p is None]
            if known:
                colours = _colourize(np.array([probabilities[i] for i in known]), "probability", 0.0, 1.0,
                                     bad=_NO_PROBABILITY) / 255.0
                _draw_lines(pic, [lines[i] for i in known], colours, linewidths=2.6)
                pic.colorbar("probability", 0.0, 1.0, "edge probability")
                pic.legend_line(_colormap("probability")(0.85), "edge (colour = probability)", width=2.6)
            if unknown:
                _draw_lines(pic, [lines[i] for i in unknown], _NO_PROBABILITY, linewidths=2.0)
                pic.legend_line(_NO_PROBABILITY, "edge (no probability)")
        _draw_nodes(pic, nodes)
        if graph is not None:
            pic.detail += f", {len(nodes)} nodes, {len(lines)} edges"
        return pic.save(out_png)


def _draw_nodes(pic: _Picture, nodes: dict[Any, tuple[np.ndarray, str]]) -> None:
    """A marker per node (one artist per kind) and its kind's letter beside it (one collection)."""
    order = list(_NODE_STYLE)  # X, T, L, then other kinds by name
    kinds = sorted({kind for _, kind in nodes.values()},
                   key=lambda k: (order.index(k) if k in order else len(order), k))
    fontsize = 7.5 if len(nodes) <= 200 else 5.5
    for kind in kinds:
        marker, colour, size = _NODE_STYLE.get(kind, _OTHER_NODE)
        xy = np.array([p for p, k in nodes.values() if k == kind])
        pic.ax.plot(xy[:, 0], xy[:, 1], linestyle="none", marker=marker, markersize=size, markerfacecolor=colour,
                    markeredgecolor="white", markeredgewidth=0.9, zorder=6)
        if kind:
            pic.labels(xy, kind, colour=_darker(colour), fontsize=fontsize, offset=(4, 3), ha="left", va="bottom")
        meaning = f" ({_NODE_MEANING[kind]})" if kind in _NODE_MEANING else ""
        pic.legend_marker(marker, colour, f"{plain_text(kind)} node{meaning}" if kind else "node (no kind)", size=size)


# Arrays -------------------------------------------------------------------------


def _check_frame(frame: Any) -> None:
    if not isinstance(frame, GridFrame):
        raise TypeError(f"frame must be a GridFrame, not {type(frame).__name__}")


def _grid_array(values: Any, frame: GridFrame, name: str) -> np.ndarray:
    _check_frame(frame)
    grid = np.asarray(values)
    if grid.shape != frame.shape:
        raise ValueError(f"{name} has shape {grid.shape}, but the frame is {frame.height} \u00d7 {frame.width}")
    return grid


def _points(values: Any, name: str) -> np.ndarray:
    xy = np.asarray(values, dtype=float)
    if xy.size == 0:
        return np.zeros((0, 2))
    if xy.ndim != 2 or xy.shape[1] != 2:
        raise ValueError(f"{name} must be an (N, 2) array of world x, y; got shape {xy.shape}")
    return xy


def _reduce(grid: np.ndarray, k: int, how: str) -> np.ndarray:
    """``grid`` reduced k × k cells to one: "max" / "min" (NaN-aware; all-NaN blocks stay NaN), "any", "first".

    The last row and column of blocks are padded (so the shown grid may hang
    a little below and right of the map; the axes limits hide it).
    """
    if k == 1:
        return grid
    if how == "first":
        return grid[::k, ::k]
    h, w = grid.shape
    hp, wp = -(-h // k) * k, -(-w // k) * k
    if how == "any":
        values = np.asarray(grid, dtype=bool)
        if (hp, wp) != (h, w):
            values = np.zeros((hp, wp), dtype=bool)
            values[:h, :w] = grid
        return values.reshape(hp // k, k, wp // k, k).any(axis=(1, 3))
    values = np.asarray(grid, dtype=float)  # no copy for float grids
    if (hp, wp) != (h, w):
        values = np.full((hp, wp), np.nan)
        values[:h, :w] = grid
    reduce = np.fmax.reduce if how == "max" else np.fmin.reduce  # fmax / fmin skip NaN
    return reduce(values.reshape(hp // k, k, wp // k, k), axis=(1, 3))


def _dilate(shown: np.ndarray, radius: int, how: str) -> np.ndarray:
    """Thicken what is drawn by a disc of ``radius`` cells: "any" for masks, "min" for values (NaN = nothing)."""
    if radius <= 0:
        return shown
    from scipy import ndimage

    yy, xx = np.mgrid[-radius:radius + 1, -radius:radius + 1]
    disc = xx * xx + yy * yy <= radius * radius + radius  # a rounder disc than r² for small radii
    if how == "any":
        return ndimage.binary_dilation(shown, structure=disc)
    values = np.where(np.isnan(shown), np.inf, shown)
    grown = ndimage.minimum_filter(values, footprint=disc, mode="constant", cval=np.inf)
    grown[np.isinf(grown)] = np.nan
    return grown


def _composite(layers: list[np.ndarray]) -> np.ndarray | None:
    """RGBA byte layers of one shape, each over the ones before ("over" with straight alpha), or None."""
    if not layers:
        return None
    out = layers[0]
    for top in layers[1:]:
        a = top[..., 3]
        if a.min() == 255:  # opaque: hides what is under it
            out = top
        elif ((a == 0) | (a == 255)).all():  # cells drawn or not (masks, the skeleton)
            shown = np.where(a == 255, top.view(np.uint32)[..., 0], out.view(np.uint32)[..., 0])
            out = shown[..., None].view(np.uint8)
        elif out[..., 3].min() == 255:  # translucent over an opaque map (places)
            weight = a[..., None].astype(np.uint16)
            rgb = (top[..., :3] * weight + out[..., :3] * (255 - weight) + 127) // 255
            out = np.concatenate([rgb.astype(np.uint8), out[..., 3:]], axis=2)
        else:
            af = a[..., None].astype(np.float32) / 255.0
            bf = out[..., 3:4].astype(np.float32) / 255.0
            alpha = af + bf * (1.0 - af)
            rgb = top[..., :3] * af + out[..., :3] * (bf * (1.0 - af))
            rgb = np.divide(rgb, alpha, out=np.zeros_like(rgb), where=alpha > 0)
            out = np.concatenate([rgb, alpha * 255.0], axis=2).round().astype(np.uint8)
    return out


def _colourize(values: np.ndarray, cmap: str, vmin: float, vmax: float, *, bad: Any) -> np.ndarray:
    """``values`` as RGBA bytes through ``cmap``'s lookup table (as matplotlib maps them), NaN as ``bad``."""
    lut = _lut(cmap)
    n = len(lut)
    values = np.asarray(values)
    x = (values.astype(np.float32, copy=False) - np.float32(vmin)) * np.float32(n / ((vmax - vmin) or 1.0))
    nan = np.isnan(x)
    np.clip(x, 0, n - 1, out=x)  # below vmin: the first colour, above vmax: the last (and vmax itself)
    x[nan] = 0
    out = lut[x.astype(np.intp)]
    if nan.any():
        out[nan] = _rgba_bytes([bad])[0]
    return out


@functools.cache
def _colormap(name: str) -> Any:
    """A colormap by name: matplotlib's, or ours ("probability", "faint")."""
    from matplotlib import colormaps
    from matplotlib.colors import LinearSegmentedColormap

    if name == "probability":
        return LinearSegmentedColormap.from_list("atlas_probability", _PROBABILITY_COLOURS)
    if name == "faint":
        return LinearSegmentedColormap.from_list("faint_occupancy", ["#ffffff", _FAINT_OCCUPIED])
    return colormaps[name]


@functools.cache
def _lut(name: str) -> np.ndarray:
    """The colormap's N colours as RGBA bytes (read-only)."""
    cmap = _colormap(name)
    lut = cmap(np.arange(cmap.N), bytes=True)
    lut.setflags(write=False)
    return lut


def _rgba(colour: Any) -> np.ndarray:
    from matplotlib.colors import to_rgba

    return np.array(to_rgba(colour), dtype=float)


def _rgba_bytes(colours: Sequence[Any], *, alpha: float | None = None) -> np.ndarray:
    """Colours as (N, 4) RGBA bytes; ``alpha`` replaces their alpha."""
    from matplotlib.colors import to_rgba_array

    rgba = to_rgba_array(list(colours))
    if alpha is not None:
        rgba[:, 3] = alpha
    return np.round(rgba * 255).astype(np.uint8)


def _place_colours(shown: np.ndarray, ids: list[int]) -> dict[int, str]:
    """A colour per place: all different up to the palette's size; beyond, different from nearby places."""
    if len(ids) <= len(_PALETTE):
        return {place: _PALETTE[i] for i, place in enumerate(ids)}
    # Places within a few cells of each other (across a thin wall, too) are neighbours.
    lo = int(min(ids[0], shown.min()))
    span = int(max(ids[-1], shown.max())) - lo + 1
    keys = []  # each pair of different labels side by side as one number: (a - lo) * span + (b - lo)
    for shift in (1, 2, 3):
        for a, b in ((shown[:, :-shift], shown[:, shift:]), (shown[:-shift, :], shown[shift:, :])):
            differ = a != b
            keys.append((a[differ].astype(np.int64) - lo) * span + (b[differ].astype(np.int64) - lo))
    found = np.unique(np.concatenate(keys))
    pairs = zip((found // span + lo).tolist(), (found % span + lo).tolist())
    neighbours: dict[int, set[int]] = {place: set() for place in ids}
    for x, y in pairs:
        if x in neighbours and y in neighbours:
            neighbours[x].add(y)
            neighbours[y].add(x)
    colours: dict[int, str] = {}
    for i, place in enumerate(ids):
        taken = {colours[n] for n in neighbours[place] if n in colours}
        options = [_PALETTE[(i + j) % len(_PALETTE)] for j in range(len(_PALETTE))]
        colours[place] = next((c for c in options if c not in taken), options[0])
    return colours


def _label_cells(shown: np.ndarray, ids: list[int]) -> list[tuple[float, float]]:
    """Where to name each place (shown-grid row, col): its centroid, or its innermost cell if that is outside."""
    from scipy import ndimage

    centroids = ndimage.center_of_mass(np.ones(shown.shape), shown, ids)
    out: list[tuple[float, float]] = []
    boxes = None
    h, w = shown.shape
    for place, (row, col) in zip(ids, centroids):
        r, c = int(round(row)), int(round(col))
        if 0 <= r < h and 0 <= c < w and shown[r, c] == place:
            out.append((row, col))
            continue
        if boxes is None:  # once: each place's bounding box
            ordered = np.asarray(ids)
            index = np.searchsorted(ordered, shown)
            index[(index >= len(ids)) | (ordered[np.minimum(index, len(ids) - 1)] != shown)] = -1
            boxes = dict(zip(ids, ndimage.find_objects(index + 1, max_label=len(ids))))
        # The cell deepest inside the place (farthest from a change of label), within its box and a cell more.
        rows, cols = boxes[place]
        r0, r1 = max(rows.start - 1, 0), min(rows.stop + 1, h)
        c0, c1 = max(cols.start - 1, 0), min(cols.stop + 1, w)
        part = shown[r0:r1, c0:c1]
        border = np.zeros(part.shape, dtype=bool)
        border[:-1] |= part[:-1] != part[1:]
        border[1:] |= part[1:] != part[:-1]
        border[:, :-1] |= part[:, :-1] != part[:, 1:]
        border[:, 1:] |= part[:, 1:] != part[:, :-1]
        depth = np.where(part == place, ndimage.distance_transform_edt(~border), -1.0)
        pr, pc = np.unravel_index(int(np.argmax(depth)), depth.shape)
        out.append((float(pr + r0), float(pc + c0)))
    return out


def _edge_polylines(frame: GridFrame, ends: list[tuple[np.ndarray, np.ndarray]], cells: list[Any]) -> list[np.ndarray]:
    """Each edge from node a to node b in metres: along its cells (oriented a -> b) or straight.

    All the edges' cells go to world coordinates in one call.
    """
    if not ends:
        return []
    rc = [np.zeros((0, 2)) if c is None or len(c) == 0 else np.asarray(c, dtype=float).reshape(-1, 2) for c in cells]
    counts = np.array([len(c) for c in rc])
    every = np.vstack(rc)
    xs, ys = frame.cell_to_world(every[:, 0], every[:, 1])
    world = np.column_stack([np.atleast_1d(xs), np.atleast_1d(ys)]).reshape(-1, 2)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    a = np.array([e[0] for e in ends])
    b = np.array([e[1] for e in ends])
    with_cells = counts > 0
    first = world[np.where(with_cells, starts, 0)] if len(world) else a
    last = world[np.where(with_cells, starts + counts - 1, 0)] if len(world) else b
    straight = np.hypot(*(first - a).T) + np.hypot(*(last - b).T)
    crossed = np.hypot(*(first - b).T) + np.hypot(*(last - a).T)
    flip = with_cells & (straight > crossed)
    out = []
    for i in range(len(ends)):
        if not with_cells[i]:
            out.append(np.array([a[i], b[i]]))
            continue
        line = world[starts[i]:starts[i] + counts[i]]
        out.append(np.vstack([a[i], line[::-1] if flip[i] else line, b[i]]))
    return out


def _route_points(graph: Any, nodes: dict[Any, tuple[np.ndarray, str]], frame: GridFrame,
                  route: Any) -> tuple[np.ndarray, bool]:
    """A route in metres, and whether it was given as waypoints (else: node ids followed along their edges)."""
    if isinstance(route, np.ndarray) or graph is None:
        return _points(route, "route"), True
    ids = list(route)
    missing = []
    for node in ids:
        try:
            if node not in nodes:
                missing.append(node)
        except TypeError:  # unhashable, e.g. [x, y] lists: waypoints
            return _points(route, "route"), True
    if missing:
        raise ValueError(f"route node(s) not in the graph: {', '.join(repr(m) for m in missing)}")
    if not ids:
        return np.zeros((0, 2)), False
    ends, cells = [], []
    for u, v in zip(ids, ids[1:]):
        data = graph.get_edge_data(u, v) if graph.has_edge(u, v) else None
        if data is not None and graph.is_multigraph():
            data = data[min(data, key=lambda key: -float(data[key].get("probability", 0.0)))]  # the likeliest
        ends.append((nodes[u][0], nodes[v][0]))
        cells.append(None if data is None else data.get("cells"))
    parts = [nodes[ids[0]][0][None, :]] + [line[1:] for line in _edge_polylines(frame, ends, cells)]
    return np.vstack(parts), False


# Small helpers -------------------------------------------------------------------


def _nest_rings(rings: list[np.ndarray]) -> list[tuple[int, list[int]]]:
    """Group outlines into shapes: (outer ring, its holes), by how many rings contain each ring's first vertex.

    Rings with fewer than three points are left out. A ring inside an even
    number of others is an outer ring; inside an odd number, a hole of the
    smallest ring that holds it.
    """
    from matplotlib.path import Path as MplPath

    ids = [i for i, ring in enumerate(rings) if len(ring) >= 3]
    if not ids:
        return []
    firsts = np.array([rings[i][0] for i in ids])
    lo = np.array([rings[i].min(axis=0) for i in ids])
    hi = np.array([rings[i].max(axis=0) for i in ids])
    areas = np.array([abs(_signed_area(rings[i])) for i in ids])
    holders: list[list[int]] = [[] for _ in ids]  # positions in ids of the rings holding each ring
    for j, ring_id in enumerate(ids):
        near = np.flatnonzero(np.all((firsts >= lo[j]) & (firsts <= hi[j]), axis=1))  # cheap box test first
        near = near[(near != j) & (areas[near] < areas[j])]
        if len(near):
            inside = MplPath(rings[ring_id]).contains_points(firsts[near])
            for k in near[inside]:
                holders[k].append(j)
    shapes: dict[int, list[int]] = {}
    for k, held_by in enumerate(holders):
        if len(held_by) % 2 == 0:
            shapes.setdefault(k, [])
    for k, held_by in enumerate(holders):
        if len(held_by) % 2 == 1:
            parent = min(held_by, key=lambda j: areas[j])
            shapes.setdefault(parent, []).append(ids[k])
    return [(ids[k], holes) for k, holes in sorted(shapes.items())]


def _signed_area(xy: np.ndarray) -> float:
    """The shoelace area of a ring (positive counter-clockwise)."""
    x, y = xy[:, 0], xy[:, 1]
    return float(((x[:-1] * y[1:] - x[1:] * y[:-1]).sum() + x[-1] * y[0] - x[0] * y[-1]) / 2)


def _oriented(xy: np.ndarray, *, ccw: bool) -> np.ndarray:
    """The ring counter-clockwise or clockwise (outer rings one way, holes the other: nonzero fill then leaves holes)."""
    return xy if (_signed_area(xy) > 0) == ccw else xy[::-1]


def _polygon_centroid(xy: np.ndarray) -> np.ndarray:
    """Area centroid of a simple polygon (the vertex mean when it has no area)."""
    x, y = xy[:, 0], xy[:, 1]
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    cross = x * y1 - x1 * y
    area = cross.sum() / 2
    if abs(area) < 1e-12:
        return xy.mean(axis=0)
    return np.array([((x + x1) * cross).sum(), ((y + y1) * cross).sum()]) / (6 * area)



def _darker(colour: Any, factor: float = 0.65) -> tuple[float, float, float]:
    from matplotlib.colors import to_rgb

    return tuple(v * factor for v in to_rgb(colour))  # type: ignore[return-value]
