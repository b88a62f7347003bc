"""ROS ``map_server`` maps: a YAML file and an image, read and written with the nav2 conventions.

A map is two files. The YAML says how to read the image::

    image: small-office-map.pgm     # relative to this YAML file
    resolution: 0.05                # metres per pixel
    origin: [-0.5, -0.5, 0.0]       # pose (x, y, yaw) of the image's LOWER-LEFT pixel
    negate: 0                       # 1: white is occupied, black is free
    occupied_thresh: 0.65           # occupancy above this: occupied
    free_thresh: 0.196              # occupancy below this: free
    mode: trinary                   # trinary (default), scale or raw

The image (PGM ``P5``/``P2``, or PNG and anything else imageio reads) gives
each pixel's shade ``s`` in [0, 1]; its occupancy probability is ``1 - s``
(``s`` when ``negate``), i.e. ``(255 - p) / 255`` for 8-bit pixels. The labels
follow nav2's ``map_io``: in ``trinary`` mode a cell is occupied (100) when its
occupancy is above ``occupied_thresh``, free (0) when below ``free_thresh``,
and unknown (-1) otherwise; ``scale`` gives 1..99 in between (and -1 for
transparent pixels); ``raw`` takes ``round(255 s)`` as the value, -1 above 100.
The comparisons are strict, as in nav2 (the ROS wiki says the same in words).

:class:`RosMap` keeps the image's row order: row 0 is the TOP of the image as
stored, so the lower-left pixel that ``origin`` places is row ``height - 1``,
column 0. :meth:`RosMap.cell_to_world` and :meth:`RosMap.world_to_cell` do the
flip. :func:`wall_segments` turns the occupied cells into wall segments for
the simulator.

Problems are reported at their file:line:column through
:class:`atlas_rap.yamlsource.YamlSource`, as in world files.
"""

from __future__ import annotations

import re
import shlex
import warnings
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path
from typing import Any

import numpy as np
from yaml.nodes import MappingNode, ScalarNode

from atlas_rap.errors import MapFileError, Problem, did_you_mean, line_of
from atlas_rap.maps.frame import GridFrame
from atlas_rap.maps.geometry import outlines
from atlas_rap.yamlsource import YamlSource, _kind
from atlas_rap.model import Point, Segment
from atlas_rap.outputs import atomic_write, write_bytes, write_text

# --------------------------------------------------------------------------
# ROS maps

MAP_KEYS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode")
MAP_REQUIRED = ("image", "resolution", "origin", "occupied_thresh", "free_thresh")
MODES = ("trinary", "scale", "raw")
FREE, OCCUPIED, UNKNOWN = 0, 100, -1
# The top-level keys of a world file (atlas_rap.sim.world) that no map YAML has: a YAML with
# one of them and no image is a world given where a map was wanted.
WORLD_KEYS = ("walls", "polygons", "map", "places", "doors", "disturbances", "robot", "sonar", "base", "objects",
              "openings")
MAP_NEEDS = ("image: the PGM or PNG beside it, resolution: metres per pixel, origin: [x, y, yaw], "
             "occupied_thresh: and free_thresh: (usually 0.65 and 0.196)")


@dataclass(frozen=True, eq=False)
class RosMap:
    """An occupancy map read from a ROS map_server YAML + image.

    ``labels`` (int8, the image's shape, row 0 = top of the image) holds what
    nav2 would publish: 0 free, 100 occupied, -1 unknown (and 1..99 in
    ``scale``/``raw`` modes). ``occupancy`` (float32, same shape) is each
    cell's probability of being occupied as the image gives it (``(255 - p) /
    255`` for an 8-bit pixel ``p``, or ``p / 255`` when ``negate``; the value
    / 100 in ``raw`` mode), and **NaN where the label is unknown**: an
    occupancy grid built on this map chooses its own prior for those cells.
    ``origin`` is (x, y, yaw) of the lower-left corner of the lower-left pixel.
    """

    occupancy: np.ndarray
    labels: np.ndarray
    resolution: float
    origin: tuple[float, float, float]
    mode: str = "trinary"
    negate: bool = False
    occupied_thresh: float = 0.65
    free_thresh: float = 0.196
    image: str = ""
    source: str = ""

    @property
    def height(self) -> int:
        """Rows of cells (the image's height in pixels)."""
        return int(self.labels.shape[0])

    @property
    def width(self) -> int:
        """Columns of cells (the image's width in pixels)."""
        return int(self.labels.shape[1])

    @property
    def occupied(self) -> np.ndarray:
        """Boolean mask of the cells labelled occupied (100)."""
        return self.labels == OCCUPIED

    @property
    def frame(self) -> GridFrame:
        """Where the cells are in the world (row 0 = the image's top row)."""
        return GridFrame(self.height, self.width, self.resolution, self.origin)

    def cell_to_world(self, row: Any, col: Any) -> tuple[Any, Any]:
        """World (x, y) of the centre of cell (row, col); see :class:`GridFrame`."""
        return self.frame.cell_to_world(row, col)

    def world_to_cell(self, x: Any, y: Any) -> tuple[Any, Any]:
        """The cell (row, col) that contains world point (x, y); may be outside the map."""
        return self.frame.world_to_cell(x, y)

    def contains_cell(self, row: int, col: int) -> bool:
        """Whether (row, col) is a cell of this map."""
        return self.frame.contains_cell(row, col)

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the map's area in the world (axis-aligned, yaw included)."""
        return self.frame.extent

    def label_at(self, x: float, y: float) -> int | None:
        """The label (0 free, 100 occupied, -1 unknown, 1..99) of the cell at world (x, y); None off the map."""
        row, col = self.world_to_cell(x, y)
        return int(self.labels[row, col]) if self.contains_cell(row, col) else None

    def free_points_near(self, x: float, y: float, clearance: float, count: int = 200) -> list[Point]:
        """Centres of free cells at least ``clearance`` metres from every cell that is not free, nearest first.

        Up to ``count`` of them, the nearest to world (x, y) first: where a
        robot of radius ``clearance`` could be put instead of (x, y).
        Cells off the map count as not free.
        """
        from scipy.ndimage import distance_transform_edt

        free = np.pad(self.labels == FREE, 1, constant_values=False)
        room = distance_transform_edt(free)[1:-1, 1:-1] * self.resolution - self.resolution / 2 >= clearance
        rows, cols = np.nonzero(room)
        if rows.size == 0:
            return []
        xs, ys = self.cell_to_world(rows, cols)
        xs, ys = np.atleast_1d(xs), np.atleast_1d(ys)
        distance = np.hypot(xs - x, ys - y)
        nearest = np.argpartition(distance, count)[:count] if distance.size > count else np.arange(distance.size)
        nearest = nearest[np.argsort(distance[nearest], kind="stable")]
        return [(float(xs[i]), float(ys[i])) for i in nearest]


def load_ros_map(path_yaml: str | Path, shown_as: str | None = None) -> RosMap:
    """Read a map_server YAML and its image into a :class:`RosMap`.

    A file that is not a map raises :class:`MapFileError` with every problem
    located at its key in the YAML (``shown_as`` is the name used in those
    reports; the path by default). A world file, or a YAML with none of a
    map's keys, gets one problem that says so: where the world's map is, how
    to build one, or which keys a map needs.
    """
    path = Path(path_yaml)
    src = YamlSource.read(path, shown_as, "ROS map YAML", MapFileError)
    _check_is_a_map(src, path)
    entries = src.keys(src.root, "", None, MAP_REQUIRED, what=" (a ROS map_server map)")
    if entries is None:
        src.check()
    assert entries is not None
    # Unknown keys are allowed (nav2 ignores them), so misspellings show up as missing keys.
    node = {key: value for key, (_, value) in entries.items()}
    resolution = src.number(node["resolution"], "resolution", above=0.0) if "resolution" in node else None
    origin = None
    if "origin" in node:
        values = src.numbers(node["origin"], "origin", (3,), "[x, y, yaw]")
        origin = None if values is None else (values[0], values[1], values[2])
    negate = False
    if "negate" in node:
        raw = src.value(node["negate"])
        if isinstance(raw, bool) or raw in (0, 1):
            negate = bool(raw)
        else:
            src.error(node["negate"], f"negate must be 0 or 1, not {_kind(node['negate'])}")
    occ = src.number(node["occupied_thresh"], "occupied_thresh", minimum=0.0, maximum=1.0) \
        if "occupied_thresh" in node else None
    free = src.number(node["free_thresh"], "free_thresh", minimum=0.0, maximum=1.0) \
        if "free_thresh" in node else None
    if occ is not None and free is not None and not free < occ:
        src.error(node["free_thresh"], f"free_thresh ({free:g}) must be less than occupied_thresh ({occ:g})",
                  "the usual values are free_thresh: 0.196 and occupied_thresh: 0.65")
    mode = "trinary"
    if "mode" in node:
        given = src.string(node["mode"], "mode")
        if given is not None and given not in MODES:
            src.error(node["mode"], f"unknown mode '{given}'",
                      (did_you_mean(given, MODES, end=" ") or "") + "modes: trinary, scale, raw")
        elif given is not None:
            mode = given
    image_path = None
    if "image" in node:
        name = src.string(node["image"], "image", "name the image file, e.g. image: map.pgm")
        if name is not None:
            image_path = Path(name) if Path(name).is_absolute() else path.parent / name
            if not image_path.is_file():
                src.error(node["image"], f"image file '{name}' not found next to {path.name}",
                          f"looked for {image_path}; the path is relative to the YAML file")
                image_path = None
    shade = alpha = None
    if image_path is not None:
        try:
            shade, alpha = read_image(image_path)
        except (OSError, ValueError) as exc:
            src.error(node["image"], f"cannot read image '{image_path.name}': {exc}",
                      "use an 8- or 16-bit PGM (P5 or P2) or a PNG")
    src.check()
    assert shade is not None and resolution is not None and origin is not None and occ is not None
    assert free is not None
    labels, occupancy = classify(shade, alpha, mode=mode, negate=negate, occupied_thresh=occ, free_thresh=free)
    return RosMap(occupancy, labels, resolution, origin, mode, negate, occ, free,
                  str(image_path), shown_as or str(path))


def _check_is_a_map(src: YamlSource, path: Path) -> None:
    """Refuse, as one located problem, a YAML that is a world file or has none of a map's keys.

    Without this a world file (or any other YAML) given where a map is wanted
    gets a "missing the key" error for each of a map's keys, which says
    nothing of what the file is or where the map is.
    """
    root = src.root
    if not isinstance(root, MappingNode):
        src.error(root, f"this is not a ROS map_server map YAML: it must be a mapping of keys to values, "
                        f"not {_kind(root)}",
                  f"a map YAML has {MAP_NEEDS}")
        src.check()
    assert isinstance(root, MappingNode)
    keys = {str(k.value): (k, v) for k, v in root.value if isinstance(k, ScalarNode)}
    if "image" in keys:
        return
    if any(key in keys for key in WORLD_KEYS):
        src.problems.append(_world_file_problem(src, keys, path))
        src.check()
    if not any(key in keys for key in MAP_KEYS):
        shown = ", ".join(list(keys)[:6]) + (", ..." if len(keys) > 6 else "")
        src.error(root, f"this is not a ROS map_server map YAML: it has none of a map's keys (it has {shown})",
                  f"a map YAML has {MAP_NEEDS}")
        src.check()


def _world_file_problem(src: YamlSource, keys: dict[str, tuple[Any, Any]], path: Path) -> Problem:
    """What to say of a world file given where a ROS map YAML is wanted: where its map is, or how to build one.

    ``path`` is the world file; ``src.file`` how it is named in messages (the map's path is shown the same way).
    """
    map_node = keys["map"][1] if "map" in keys else None
    if isinstance(map_node, ScalarNode) and str(map_node.value).strip():
        key, (message, hint) = keys["map"][0], _map_of_world(src.file, str(map_node.value).strip(), path)
    elif "base" in keys:
        key = keys["base"][0]
        base = keys["base"][1].value if isinstance(keys["base"][1], ScalarNode) else "?"
        message = f"this is a world file (a variant of '{base}'), not a ROS map YAML"
        hint = f"give the map that world '{base}' names in its map: key, if any; or {_build_hint(src.file)}"
    else:
        key = next(k for name, (k, _) in keys.items() if name in WORLD_KEYS)
        message = "this is a world file, not a ROS map YAML, and it names no map image (no map: key)"
        hint = _build_hint(src.file)
    loc = src.location(key)
    return Problem(message, loc, line_of(src.lines, loc.line), hint)


def _map_of_world(shown: str, name: str, path: Path) -> tuple[str, str]:
    """(message, hint) for a world whose ``map:`` is ``name``: the map's path, as the world's is shown."""
    given = Path(name)
    hint = f"give that map instead: {given if given.is_absolute() else Path(shown).parent / name}"
    if not (given if given.is_absolute() else path.parent / name).is_file():
        hint += " (it is not there: the path is relative to the world file)"
    return f"this is a world file, not a ROS map YAML; the map it names is '{name}'", hint


def _build_hint(world: str) -> str:
    """How to get a ROS map of a world that has no map image: map it from sonar with `atlas map build`."""
    out = f"{Path(world).stem}-map"
    return (f"build a map of it with `atlas map build --world {shlex.quote(world)} --out {shlex.quote(out)}`, "
            f"then give {out}/occupancy.yaml")


def classify(shade: np.ndarray, alpha: np.ndarray | None = None, *, mode: str = "trinary", negate: bool = False,
             occupied_thresh: float = 0.65, free_thresh: float = 0.196) -> tuple[np.ndarray, np.ndarray]:
    """(labels, occupancy) of pixel shades in [0, 1], as nav2's map_io computes them."""
    occ = shade if negate else 1.0 - shade
    if mode == "raw":
        value = np.rint(shade * 255.0)
        known = (value >= 0) & (value <= 100)
        labels = np.where(known, value, UNKNOWN).astype(np.int8)
        occupancy = np.where(known, value / 100.0, np.nan).astype(np.float32)
        return labels, occupancy
    labels = np.full(shade.shape, UNKNOWN, dtype=np.int8)
    labels[occ < free_thresh] = FREE
    labels[occ > occupied_thresh] = OCCUPIED
    if mode == "scale":
        between = (occ >= free_thresh) & (occ <= occupied_thresh)
        scaled = np.rint((occ - free_thresh) / (occupied_thresh - free_thresh) * 100.0)
        labels[between] = scaled[between].astype(np.int8)
        if alpha is not None:
            labels[alpha < 1.0] = UNKNOWN
    occupancy = np.where(labels == UNKNOWN, np.nan, occ).astype(np.float32)
    return labels, occupancy


# -- images -------------------------------------------------------------------

_PNM_TOKEN = re.compile(rb"(?:\s|#[^\n]*\n?)*(\S+)")


def read_image(path: Path) -> tuple[np.ndarray, np.ndarray | None]:
    """(shade, alpha) of an image as float arrays in [0, 1], row 0 at the top.

    Colour pixels are averaged over their channels (as nav2 does); ``alpha``
    is None for an image without an alpha channel. PGM/PPM are parsed here;
    other formats (PNG ...) are read with imageio.
    """
    data = path.read_bytes()
    if data[:2] in (b"P2", b"P5", b"P3", b"P6"):
        return _read_pnm(data), None
    try:
        import imageio.v3 as iio
    except ImportError as exc:  # pragma: no cover - scikit-image brings imageio
        raise ValueError("reading this image format needs imageio") from exc
    try:
        with warnings.catch_warnings():  # imageio tries its plugins in turn; some warn as they decline
            warnings.simplefilter("ignore")
            pixels = np.asarray(iio.imread(path))
    except Exception as exc:  # noqa: BLE001 - imageio raises many kinds; any of them means "not an image"
        raise ValueError(f"not an image imageio can read ({type(exc).__name__})") from None
    if pixels.dtype == np.uint8:
        scale = 255.0
    elif pixels.dtype == np.uint16:
        scale = 65535.0
    elif pixels.dtype == bool:
        scale = 1.0
    else:
        raise ValueError(f"unsupported pixel type {pixels.dtype}")
    pixels = pixels.astype(np.float64) / scale
    if pixels.ndim == 2:
        return pixels, None
    if pixels.ndim != 3 or pixels.shape[2] not in (2, 3, 4):
        raise ValueError(f"unsupported image shape {pixels.shape}")
    alpha = pixels[:, :, -1] if pixels.shape[2] in (2, 4) else None
    colour = pixels[:, :, :-1] if alpha is not None else pixels
    return colour.mean(axis=2), alpha


def _read_pnm(data: bytes) -> np.ndarray:
    """Shades of a PGM (P5 binary, P2 ascii) or PPM (P6, P3) image."""
    magic = data[:2]
    fields: list[int] = []
    pos = 2
    while len(fields) < 3:
        match = _PNM_TOKEN.match(data, pos)
        if match is None:
            raise ValueError("truncated header")
        try:
            fields.append(int(match.group(1)))
        except ValueError:
            raise ValueError(f"bad header field {match.group(1)[:20]!r}") from None
        pos = match.end()
    width, height, maxval = fields
    if width <= 0 or height <= 0 or not 0 < maxval < 65536:
        raise ValueError(f"bad size {width}x{height} or maximum value {maxval}")
    channels = 3 if magic in (b"P3", b"P6") else 1
    count = width * height * channels
    if magic in (b"P5", b"P6"):
        start = pos + 1  # exactly one whitespace byte after maxval
        dtype = np.dtype(">u2") if maxval > 255 else np.dtype(np.uint8)
        raw = data[start:start + count * dtype.itemsize]
        if len(raw) < count * dtype.itemsize:
            raise ValueError(f"image data is truncated ({len(raw)} of {count * dtype.itemsize} bytes)")
        values = np.frombuffer(raw, dtype=dtype).astype(np.float64)
    else:
        body = re.sub(rb"#[^\n]*", b" ", data[pos:]).split()
        if len(body) < count:
            raise ValueError(f"image data is truncated ({len(body)} of {count} values)")
        try:
            values = np.array([int(v) for v in body[:count]], dtype=np.float64)
        except ValueError:
            raise ValueError("image data has a value that is not a whole number") from None
    if values.max(initial=0) > maxval:
        raise ValueError(f"a pixel value is above the maximum {maxval}")
    shade = values.reshape(height, width, channels) / maxval
    return shade[:, :, 0] if channels == 1 else shade.mean(axis=2)


# -- writing ------------------------------------------------------------------

def write_ros_map(path_yaml: str | Path, labels_or_probabilities: np.ndarray, resolution: float,
                  origin: tuple[float, float] | tuple[float, float, float], image_format: str = "pgm", *,
                  occupied_thresh: float = 0.65, free_thresh: float = 0.196) -> Path:
    """Write a map_server map (trinary, thresholds 0.65 / 0.196 unless given) and return the image's path.

    ``labels_or_probabilities`` has row 0 at the TOP (as :class:`RosMap`):
    either labels (integers 0 free, 100 occupied, -1 unknown; or booleans,
    True occupied), written as the usual pixels 254 / 0 / 205 and read back
    identically; or probabilities of occupancy (floats in [0, 1], NaN
    unknown), written as ``round(255 (1 - p))`` and read back to within
    1/510, except that probabilities between the thresholds read back as
    unknown (NaN), as any trinary reader sees them. The image is
    ``<yaml stem>.pgm`` (binary P5) or ``.png`` beside the YAML. Each file is
    written whole or not at all (``atlas_rap.outputs``), the image first.
    """
    grid = np.asarray(labels_or_probabilities)
    if grid.ndim != 2 or grid.size == 0:
        raise ValueError(f"a map is a non-empty 2-D array, not shape {grid.shape}")
    if not resolution > 0:
        raise ValueError(f"resolution must be positive, not {resolution}")
    if image_format not in ("pgm", "png"):
        raise ValueError(f"image_format must be 'pgm' or 'png', not {image_format!r}")
    if grid.dtype == bool:
        pixels = np.where(grid, 0, 254).astype(np.uint8)
    elif np.issubdtype(grid.dtype, np.integer):
        bad = ~np.isin(grid, (FREE, OCCUPIED, UNKNOWN))
        if bad.any():
            raise ValueError(f"labels must be 0, 100 or -1; found {grid[bad].flat[0]}")
        pixels = np.select([grid == OCCUPIED, grid == FREE], [0, 254], 205).astype(np.uint8)
    elif np.issubdtype(grid.dtype, np.floating):
        known = ~np.isnan(grid)
        if ((grid[known] < 0) | (grid[known] > 1)).any():
            raise ValueError("probabilities must be in [0, 1] (NaN for unknown)")
        pixels = np.where(known, np.rint(255.0 * (1.0 - np.where(known, grid, 0.0))), 205).astype(np.uint8)
    else:
        raise ValueError(f"cannot write a map of {grid.dtype}")
    path = Path(path_yaml)
    image = path.with_suffix("." + image_format)
    if image_format == "pgm":
        height, width = pixels.shape
        write_bytes(image, b"P5\n# written by atlas-rap\n%d %d\n255\n" % (width, height) + pixels.tobytes())
    else:
        import imageio.v3 as iio

        with atomic_write(image) as stream:
            iio.imwrite(stream, pixels, extension=".png")
    ox, oy = float(origin[0]), float(origin[1])
    yaw = float(origin[2]) if len(origin) > 2 else 0.0
    write_text(path,
               f"image: {image.name}\n"
               f"resolution: {float(resolution)!r}\n"
               f"origin: [{ox!r}, {oy!r}, {yaw!r}]\n"
               "negate: 0\n"
               f"occupied_thresh: {float(occupied_thresh)!r}\n"
               f"free_thresh: {float(free_thresh)!r}\n"
               "mode: trinary\n")
    return image


# -- walls ------------------------------------------------------------------

def wall_segments(rosmap: RosMap, tolerance: float | None = None) -> list[Segment]:
    """The outlines of the occupied cells as wall segments in world coordinates.

    The outlines are :func:`atlas_rap.maps.geometry.outlines` of the occupied
    cells: the occupied mask is padded with free cells (so blobs touching the
    border still close), outlined with ``skimage.measure.find_contours`` along
    the cells' edges (half a cell from occupied cell centres; corners are cut
    by half a cell at 45 degrees) and simplified with ``approximate_polygon``
    to within ``tolerance`` metres. The default, a third of a cell, keeps
    straight walls on the cells' edges; a cell or more merges the corner cuts
    and staircases into fewer, slightly slanted segments.
    """
    segments: list[Segment] = []
    for polygon in outlines(rosmap.occupied, rosmap.frame, tolerance):
        points = [(round(float(x), 6), round(float(y), 6)) for x, y in polygon]
        for a, b in pairwise(points):
            if a != b:
                segments.append(Segment(a, b))
    return segments
