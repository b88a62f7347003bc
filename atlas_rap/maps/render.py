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
edge cell); the title says "shown 1:k" when that happened. A 4000 × 4000
grid draws in about a second.

matplotlib and scipy are imported inside the functions (object-oriented
``Figure`` + Agg canvas, no pyplot), so importing this module stays cheap.
The same inputs give the same PNG bytes.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from atlas_rap.maps.frame import GridFrame
from atlas_rap.pictures import DPI as _DPI
from atlas_rap.pictures import map_layout

if TYPE_CHECKING:
    import networkx

__all__ = [
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
) -> Path:
    """Draw the occupancy probabilities ``p_occ`` (NaN = unknown) to ``out_png``; return its path.

    Grey from white (P = 0, free) to black (P = 1, occupied), unknown cells
    in a blue-grey tint, a colorbar for P(occupied). ``path_xy`` is an
    optional robot path, an (N, 2) sequence of world (x, y) in metres,
    drawn from a start circle to an end dot.
    """
    grid = _grid_array(p_occ, frame, "p_occ")
    with _picture(frame, title or "occupancy grid", colorbar=True) as pic:
        image = _draw_occupancy(pic, grid, faint=False)
        pic.colorbar(image, "P(occupied)")
        pic.legend_patch(_UNKNOWN, "unknown (NaN)")
        if path_xy is not None:
            _draw_track(pic, _points(path_xy, "path_xy"), label="robot path", ends=("start", "end"))
        return pic.save(out_png)


def render_edges(
    occupied_edges: Any,
    empty_edges: Any,
    frame: GridFrame,
    out_png: str | Path,
    *,
    title: str | None = None,
    background: np.ndarray | None = None,
) -> Path:
    """Draw occupied edges (red) and empty edges (blue) to ``out_png``; return its path.

    Each of ``occupied_edges`` and ``empty_edges`` is either a boolean mask
    of the frame's shape (edge cells, thickened so they show at any size),
    or a sequence of polylines / segments in world metres (each an (N, 2)
    array-like, N >= 2), or None for none.
    """
    with _picture(frame, title or "edges", colorbar=False) as pic:
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
) -> Path:
    """Draw ``polygons`` (each an (N, 2) array of world x, y; closed or not) to ``out_png``; return its path.

    Outlines inside others are holes (as ``find_contours`` gives them):
    the fill is even-odd, so a region's holes stay unfilled and an island
    in a hole is filled again. Each outer outline and its holes share a
    colour and are numbered with the outer outline's index in
    ``polygons`` (up to 80 of them); vertices are small dots.
    """
    from matplotlib.patches import PathPatch
    from matplotlib.path import Path as MplPath

    rings = [_points(p, f"polygon {i}") for i, p in enumerate(polygons)]
    rings = [ring[:-1] if len(ring) > 3 and np.array_equal(ring[0], ring[-1]) else ring for ring in rings]
    with _picture(frame, title or "polygons", colorbar=False) as pic:
        _draw_background(pic, background)
        shapes = _nest_rings(rings)
        numbered = len(shapes) <= 80  # beyond that the numbers would only clutter
        for n, (outer, holes) in enumerate(shapes):
            colour = _PALETTE[n % len(_PALETTE)]
            parts = [_oriented(rings[outer], ccw=True)] + [_oriented(rings[h], ccw=False) for h in holes]
            # (closed=True takes the last vertex as the CLOSEPOLY code's: repeat the first point for it)
            path = MplPath.make_compound_path(*(MplPath(np.vstack([part, part[:1]]), closed=True) for part in parts))
            pic.ax.add_patch(PathPatch(path, facecolor=colour, alpha=0.35, edgecolor="none", zorder=2))
            pic.ax.add_patch(PathPatch(path, fill=False, edgecolor=_darker(colour), linewidth=1.3,
                                       joinstyle="round", zorder=3))
            vertices = np.vstack(parts)
            pic.ax.plot(vertices[:, 0], vertices[:, 1], linestyle="none", marker="o", markersize=2.2,
                        color=_darker(colour), zorder=3.5)
            if numbered:
                at = _polygon_centroid(rings[outer])
                inside = MplPath(rings[outer]).contains_point(at)
                if not inside or any(MplPath(rings[h]).contains_point(at) for h in holes):
                    # e.g. a ring-shaped wall: name it at its first corner
                    at = rings[outer][0]
                _label(pic, at, str(outer), colour="#222222", fontsize=7.5)
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
) -> Path:
    """Draw distances to the nearest obstacle (metres; NaN = unknown) to ``out_png``; return its path.

    magma from black (0 m, obstacles) to pale yellow (the largest distance),
    with a colorbar in metres; unknown cells in the unknown tint.
    """
    from matplotlib.colors import Normalize

    dt = _grid_array(dt_metres, frame, "dt_metres")
    with _picture(frame, title or "distance transform", colorbar=True) as pic:
        shown = np.array(pic.reduce(dt, "min"), dtype=float)  # obstacles (0 m) never vanish
        shown[~np.isfinite(shown)] = np.nan  # (inf: no obstacle anywhere) shown as unknown
        top = float(np.nanmax(shown)) if np.isfinite(shown).any() else 1.0
        norm = Normalize(vmin=0.0, vmax=top if top > 0 else 1.0)
        image = pic.image(shown, cmap=_cmap(_DISTANCE_CMAP, bad=_UNKNOWN), norm=norm)
        pic.colorbar(image, "distance to the nearest obstacle (m)")
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
) -> Path:
    """Draw the place label image ``labels`` to ``out_png``; return its path.

    Labels > 0 are places (0 and negative labels are "no place", as in
    scikit-image, unless ``names`` names them). Each place gets its own
    colour (up to 20 places all differ; with more, neighbouring places
    still differ) and is named (``names[label]``, else the number) at its
    centroid, or at its innermost cell when the centroid falls outside it.
    """
    from matplotlib.colors import ListedColormap

    names = dict(names or {})
    grid = _grid_array(labels, frame, "labels")
    if not np.issubdtype(grid.dtype, np.integer):
        raise ValueError(f"labels must be integers, not {grid.dtype}")
    with _picture(frame, title or "places", colorbar=False) as pic:
        _draw_background(pic, background)
        shown = pic.reduce(grid, "first")
        ids = [int(v) for v in np.unique(shown) if v > 0 or int(v) in names]
        if ids:
            colours = _place_colours(shown, ids)
            index = np.full(shown.shape, -1, dtype=np.int32)  # position in ids, -1 = no place
            lookup = np.searchsorted(ids, shown)
            inside = (lookup < len(ids)) & (np.asarray(ids)[np.minimum(lookup, len(ids) - 1)] == shown)
            index[inside] = lookup[inside]
            cmap = ListedColormap([colours[i] for i in ids]).with_extremes(bad=(0, 0, 0, 0))
            alpha = 0.6 if background is not None else 0.8
            pic.image(np.ma.masked_less(index, 0), cmap=cmap, vmin=-0.5, vmax=len(ids) - 0.5, alpha=alpha)
            fontsize = 8.5 if len(ids) <= 40 else 6.5
            for place, (row, col) in zip(ids, _label_cells(shown, ids)):
                xy = frame.cell_to_world(row * pic.k + (pic.k - 1) / 2, col * pic.k + (pic.k - 1) / 2)
                _label(pic, xy, names.get(place, str(place)), colour="#1a1a1a", fontsize=fontsize)
        pic.detail += f", {len(ids)} places"
        return pic.save(out_png)


def render_stochastic_sdt(
    skeleton_probability: np.ndarray,
    frame: GridFrame,
    out_png: str | Path,
    *,
    background: np.ndarray | None = None,
    title: str | None = None,
) -> Path:
    """Draw skeleton cells coloured by P(empty) (NaN = off the skeleton) to ``out_png``; return its path.

    Red (0) through amber to green (1), with a colorbar, over the faint
    ``background`` map. The skeleton is thickened (a grey dilation that
    keeps the lowest probability nearby) to about four pixels, so a
    one-cell skeleton shows at any picture size; the title says how wide
    it is drawn.
    """
    from matplotlib.colors import Normalize

    prob = _grid_array(skeleton_probability, frame, "skeleton_probability")
    with _picture(frame, title or "stochastic skeleton", colorbar=True) as pic:
        _draw_background(pic, background)
        shown = pic.reduce(prob, "min")  # the weakest cell of a block speaks for it
        radius = pic.thickening_radius()
        shown = _dilate(shown, radius, "min")
        image = pic.image(shown, cmap=_probability_cmap(bad=(0, 0, 0, 0)), norm=Normalize(0.0, 1.0))
        pic.colorbar(image, "P(empty) on the skeleton")
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
                         title=title or "topological graph")


def render_route(
    p_occ: np.ndarray,
    frame: GridFrame,
    waypoints_xy: Any,
    out_png: str | Path,
    *,
    graph: networkx.Graph | None = None,
    title: str | None = None,
) -> Path:
    """Draw waypoints (an (N, 2) sequence of world x, y) as a route over the faint map ``p_occ``; return the path.

    A blue line from a start circle through waypoint dots to a goal dot.

    With ``graph`` the topological graph is drawn too (this is
    :func:`render_topology` with the waypoints as its route).
    """
    return _render_graph(graph, frame, out_png, background=p_occ, route=_points(waypoints_xy, "waypoints_xy"),
                         title=title or "route")


# The picture: figure, axes, colorbar, legend, saving --------------------------------


class _Picture:
    """One map picture being drawn: the axes in metres, the legend's handles and the display reduction."""

    def __init__(self, frame: GridFrame, title: str, colorbar: bool) -> None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        self.frame = frame
        self.limits, map_w, map_h = map_layout(*frame.extent)
        xmin, xmax, ymin, ymax = self.limits
        scale = map_w / (xmax - xmin)

        # Reduce grids to at most about one cell per screen pixel (k × k cells per shown cell).
        px_per_cell = scale * frame.resolution * _DPI
        self.k = max(1, math.ceil(1.0 / px_per_cell - 1e-9))
        self.px_per_shown_cell = px_per_cell * self.k

        left, bottom, top, right = 0.75, 1.05 if colorbar else 0.6, 0.55, 0.25
        fig_w, fig_h = left + map_w + right, bottom + map_h + top
        self.fig = Figure(figsize=(fig_w, fig_h), dpi=_DPI)
        FigureCanvasAgg(self.fig)
        self.ax = self.fig.add_axes((left / fig_w, bottom / fig_h, map_w / fig_w, map_h / fig_h))
        self._cbar_box = (left / fig_w, (bottom - 0.78) / fig_h, min(map_w * 0.6, 3.4) / fig_w, 0.1 / fig_h)
        self.title = title
        self.detail = f"{frame.height} \u00d7 {frame.width} cells of {frame.resolution:g} m"
        if self.k > 1:
            self.detail += f", shown 1:{self.k}"
        self.handles: list[Any] = []

        ax = self.ax
        ax.set_facecolor("white")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.tick_params(labelsize=8)
        for spine in ax.spines.values():
            spine.set_color("#999999")
        _draw_frame_outline(self)

    # drawing

    def reduce(self, grid: np.ndarray, how: str) -> np.ndarray:
        return _reduce(grid, self.k, how)

    def image(self, shown: np.ndarray, **style: Any) -> Any:
        """imshow a grid reduced by :meth:`reduce`, in its place in the world."""
        from matplotlib.transforms import Affine2D

        frame, k = self.frame, self.k
        ox, oy, yaw = frame.origin
        res = frame.resolution
        h, w = shown.shape[:2]
        top = oy + frame.height * res
        extent = (ox, ox + w * k * res, top - h * k * res, top)  # padding of the last block hangs off the map
        style.setdefault("zorder", 1)
        image = self.ax.imshow(shown, origin="upper", extent=extent, interpolation="nearest", **style)
        if yaw:
            image.set_transform(Affine2D().rotate_around(ox, oy, yaw) + self.ax.transData)
        return image

    def thickening_radius(self) -> int:
        """Dilation radius (in shown cells) that makes a one-cell line about ``_LINE_PX`` pixels wide."""
        return max(0, math.floor((_LINE_PX / self.px_per_shown_cell - 1) / 2 + 0.5))

    def colorbar(self, mappable: Any, label: str) -> None:
        cax = self.fig.add_axes(self._cbar_box)
        cb = self.fig.colorbar(mappable, cax=cax, orientation="horizontal")
        cb.set_label(label, fontsize=8, labelpad=2)
        cb.ax.tick_params(labelsize=7, length=2)
        cb.outline.set_linewidth(0.5)
        cb.solids.set(alpha=1.0)

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
        out = Path(out_png)
        out.parent.mkdir(parents=True, exist_ok=True)
        ax = self.ax
        xmin, xmax, ymin, ymax = self.limits
        ax.set_xlim(xmin, xmax)
        ax.set_ylim(ymin, ymax)
        ax.set_aspect("equal", adjustable="box")
        ax.set_title(_plain(self.title), fontsize=11, loc="left")
        ax.set_title(self.detail, fontsize=7.5, loc="right", color="#666666")
        if self.handles:
            ax.legend(handles=self.handles, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0,
                      fontsize=8, frameon=False, handlelength=1.8, labelspacing=0.45)
        self.fig.savefig(out, format="png", dpi=_DPI, bbox_inches="tight", pad_inches=0.15,
                         facecolor="white", metadata={"Software": None})
        return out

    def close(self) -> None:
        self.fig.clear()


@contextmanager
def _picture(frame: GridFrame, title: str, *, colorbar: bool) -> Iterator[_Picture]:
    """A picture of ``frame`` (say up front whether it has a colorbar: room is kept for it under the map)."""
    _check_frame(frame)
    pic = _Picture(frame, title, colorbar)
    try:
        yield pic
    finally:
        pic.close()


# Drawing ideas, each once ---------------------------------------------------------


def _draw_frame_outline(pic: _Picture) -> None:
    """The grid's boundary as a thin grey line (it shows where the map ends when little is drawn)."""
    f = pic.frame
    rows = np.array([-0.5, -0.5, f.height - 0.5, f.height - 0.5, -0.5])
    cols = np.array([-0.5, f.width - 0.5, f.width - 0.5, -0.5, -0.5])
    xs, ys = f.cell_to_world(rows, cols)
    pic.ax.plot(xs, ys, color=_FRAME_EDGE, linewidth=0.7, zorder=0.5)


def _draw_occupancy(pic: _Picture, p_occ: np.ndarray, *, faint: bool) -> Any:
    """Occupancy probability as grey: full contrast for the grid itself, faint as a background."""
    from matplotlib.colors import LinearSegmentedColormap, Normalize

    shown = pic.reduce(np.asarray(p_occ, dtype=float), "max")  # walls win a block, then known cells, then unknown
    if faint:
        cmap = LinearSegmentedColormap.from_list("faint_occupancy", ["#ffffff", _FAINT_OCCUPIED])
        cmap = cmap.with_extremes(bad=_FAINT_UNKNOWN)
    else:
        cmap = _cmap("gray_r", bad=_UNKNOWN)
    return pic.image(shown, cmap=cmap, norm=Normalize(0.0, 1.0), zorder=0.8 if faint else 1)


def _draw_background(pic: _Picture, background: np.ndarray | None) -> None:
    """The faint occupancy map under a picture, and its two colours in the legend."""
    if background is None:
        return
    image = _draw_occupancy(pic, _grid_array(background, pic.frame, "background"), faint=True)
    shown = image.get_array()
    if np.ma.filled(shown >= 0.5, False).any():
        pic.legend_patch(_FAINT_OCCUPIED, "map: occupied")
    if np.ma.getmaskarray(shown).any() or np.isnan(np.ma.filled(shown, 0.0)).any():
        pic.legend_patch(_FAINT_UNKNOWN, "map: unknown")


def _draw_mask(pic: _Picture, mask: np.ndarray, colour: str) -> None:
    """Cells of a boolean mask in one colour, thickened so that one-cell lines show."""
    from matplotlib.colors import to_rgba

    shown = _dilate(pic.reduce(mask.astype(bool), "any"), pic.thickening_radius(), "any")
    rgba = np.zeros(shown.shape + (4,), dtype=np.float32)
    rgba[shown] = to_rgba(colour)
    pic.image(rgba, zorder=2)


def _draw_lines(pic: _Picture, lines: list[np.ndarray], colour: Any, **style: Any) -> Any:
    """Polylines in metres (one colour, or one per line)."""
    from matplotlib.collections import LineCollection

    style = {"linewidths": 2.0, "capstyle": "round", "joinstyle": "round", "zorder": 3, **style}
    collection = LineCollection(lines, colors=colour, **style)
    pic.ax.add_collection(collection)
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


def _label(pic: _Picture, xy: Any, text: str, *, colour: Any, fontsize: float,
           offset: tuple[float, float] = (0, 0), ha: str = "center", va: str = "center") -> None:
    from matplotlib import patheffects

    pic.ax.annotate(_plain(text), (float(xy[0]), float(xy[1])), xytext=offset, textcoords="offset points",
                    ha=ha, va=va, fontsize=fontsize, color=colour, fontweight="bold", zorder=9,
                    path_effects=[patheffects.withStroke(linewidth=2.5, foreground="white")],
                    annotation_clip=True)


def _render_graph(graph: Any, frame: GridFrame, out_png: str | Path, *, background: np.ndarray | None,
                  route: Any, title: str) -> Path:
    """The topology picture (``graph`` may be None: then only the background and the route)."""
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    nodes: dict[Any, tuple[np.ndarray, str]] = {}
    edges: list[tuple[np.ndarray, float | None]] = []
    if graph is not None:
        for node, data in graph.nodes(data=True):
            if data.get("xy") is None:
                raise ValueError(f"graph node {node!r} has no xy attribute")
            nodes[node] = (np.asarray(data["xy"], dtype=float).reshape(2), str(data.get("kind", "")))
        for u, v, data in graph.edges(data=True):
            p = data.get("probability")
            edges.append((_edge_polyline(frame, nodes[u][0], nodes[v][0], data.get("cells")),
                          None if p is None else float(p)))
    route_xy, route_is_waypoints = (None, False) if route is None else _route_points(graph, nodes, frame, route)
    with_probability = any(p is not None for _, p in edges)

    with _picture(frame, title, colorbar=with_probability) as pic:
        _draw_background(pic, background)
        if route_xy is not None:  # a wide translucent band under the edges: the edges stay readable
            _draw_track(pic, route_xy, label="route", ends=("start", "goal"), colour=_ROUTE,
                        width=9.0 if graph is not None else 3.0, alpha=0.45 if graph is not None else 1.0,
                        zorder=2.5, waypoints=route_is_waypoints)
        if edges:
            norm = Normalize(0.0, 1.0)
            cmap = _probability_cmap()
            known = [(line, p) for line, p in edges if p is not None]
            unknown = [line for line, p in edges if p is None]
            if known:
                probabilities = np.array([p for _, p in known])
                _draw_lines(pic, [line for line, _ in known], cmap(norm(probabilities)), linewidths=2.6)
                pic.colorbar(ScalarMappable(norm=norm, cmap=cmap), "edge probability")
                pic.legend_line(cmap(0.85), "edge (colour = probability)", width=2.6)
            if unknown:
                _draw_lines(pic, unknown, _NO_PROBABILITY, linewidths=2.0)
                pic.legend_line(_NO_PROBABILITY, "edge (no probability)")
        _draw_nodes(pic, nodes)
        if graph is not None:
            pic.detail += f", {len(nodes)} nodes, {len(edges)} edges"
        return pic.save(out_png)


def _draw_nodes(pic: _Picture, nodes: dict[Any, tuple[np.ndarray, str]]) -> None:
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
            for point in xy:
                _label(pic, point, kind, colour=_darker(colour), fontsize=fontsize, offset=(4, 3),
                       ha="left", va="bottom")
        meaning = f" ({_NODE_MEANING[kind]})" if kind in _NODE_MEANING else ""
        pic.legend_marker(marker, colour, f"{_plain(kind)} node{meaning}" if kind else "node (no kind)", size=size)


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


def _place_colours(shown: np.ndarray, ids: list[int]) -> dict[int, str]:
    """A colour per place: all different up to the palette's size; beyond, different from nearby places."""
    if len(ids) <= len(_PALETTE):
        return {place: _PALETTE[i] for i, place in enumerate(ids)}
    # Places within a few cells of each other (across a thin wall, too) are neighbours.
    pairs: set[tuple[int, int]] = set()
    for shift in (1, 2, 3):
        for a, b in ((shown[:, :-shift], shown[:, shift:]), (shown[:-shift, :], shown[shift:, :])):
            differ = a != b
            for x, y in np.unique(np.stack([a[differ], b[differ]], axis=1), axis=0):
                pairs.add((int(x), int(y)))
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
    innermost = None
    for place, (row, col) in zip(ids, centroids):
        r, c = int(round(row)), int(round(col))
        if 0 <= r < shown.shape[0] and 0 <= c < shown.shape[1] and shown[r, c] == place:
            out.append((row, col))
            continue
        if innermost is None:  # once, for all places: distance of each cell to its place's border
            border = np.zeros(shown.shape, dtype=bool)
            border[:-1] |= shown[:-1] != shown[1:]
            border[1:] |= shown[1:] != shown[:-1]
            border[:, :-1] |= shown[:, :-1] != shown[:, 1:]
            border[:, 1:] |= shown[:, 1:] != shown[:, :-1]
            depth = ndimage.distance_transform_edt(~border)
            innermost = dict(zip(ids, ndimage.maximum_position(depth, shown, ids)))
        out.append(tuple(float(v) for v in innermost[place]))  # type: ignore[arg-type]
    return out


def _edge_polyline(frame: GridFrame, a: np.ndarray, b: np.ndarray, cells: Any) -> np.ndarray:
    """An edge from node a to node b in metres: along its cells (oriented a -> b) or straight."""
    if cells is None or len(cells) == 0:
        return np.array([a, b])
    rc = np.asarray(cells, dtype=float).reshape(-1, 2)
    xs, ys = frame.cell_to_world(rc[:, 0], rc[:, 1])
    line = np.column_stack([np.atleast_1d(xs), np.atleast_1d(ys)])
    if np.hypot(*(line[0] - a)) + np.hypot(*(line[-1] - b)) > np.hypot(*(line[0] - b)) + np.hypot(*(line[-1] - a)):
        line = line[::-1]
    return np.vstack([a, line, b])


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
    parts = [nodes[ids[0]][0][None, :]]
    for u, v in zip(ids, ids[1:]):
        data = graph.get_edge_data(u, v) if graph.has_edge(u, v) else None
        if data is not None and graph.is_multigraph():
            data = data[min(data, key=lambda key: -float(data[key].get("probability", 0.0)))]  # the likeliest
        cells = None if data is None else data.get("cells")
        parts.append(_edge_polyline(frame, nodes[u][0], nodes[v][0], cells)[1:])
    return np.vstack(parts), False


# Small helpers -------------------------------------------------------------------


def _probability_cmap(*, bad: Any = None) -> Any:
    from matplotlib.colors import LinearSegmentedColormap

    cmap = LinearSegmentedColormap.from_list("atlas_probability", _PROBABILITY_COLOURS)
    return cmap if bad is None else cmap.with_extremes(bad=bad)


def _cmap(name: str, *, bad: Any = None) -> Any:
    from matplotlib import colormaps

    cmap = colormaps[name]
    return cmap if bad is None else cmap.with_extremes(bad=bad)


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
    x, y = xy[:, 0], xy[:, 1]
    return float((x * np.roll(y, -1) - np.roll(x, -1) * y).sum() / 2)


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


def _plain(text: str) -> str:
    """Text shown as written: a ``$`` would otherwise start matplotlib's mathtext."""
    return str(text).replace("$", r"\$")


def _darker(colour: Any, factor: float = 0.65) -> tuple[float, float, float]:
    from matplotlib.colors import to_rgb

    return tuple(v * factor for v in to_rgb(colour))  # type: ignore[return-value]
