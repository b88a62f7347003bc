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

The first half of this module reads YAML into PyYAML *nodes* so that every
problem can be reported at its file:line:column (:class:`YamlSource`);
``atlas_rap.sim.world`` uses it for world files too.
"""

from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass, field
from itertools import pairwise
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from yaml.constructor import SafeConstructor
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from atlas_rap.errors import Problem, SourceError, SourceLocation, line_of, source_lines
from atlas_rap.maps.frame import GridFrame
from atlas_rap.sim.model import Segment

MAX_YAML_BYTES = 4 * 1024 * 1024

# --------------------------------------------------------------------------
# YAML with locations


def _nearest(word: str, choices: list[str]) -> str | None:
    # Imported here: atlas_rap.lang pulls in the grammar, which map readers do not need.
    from atlas_rap.lang.validator import nearest

    return nearest(word, choices)


@dataclass
class YamlSource:
    """A YAML file parsed into PyYAML nodes, with the problems found in it so far.

    The typed readers (:meth:`number`, :meth:`point`, :meth:`keys` ...) take a
    node and the dotted *key path* that names it (``doors.office-door.between``)
    and return the Python value, or None after recording a located
    :class:`Problem` so that reading can go on and report every problem.
    :meth:`check` raises them all as one :class:`SourceError`.
    """

    file: str
    text: str
    root: Node | None = None
    problems: list[Problem] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.lines = source_lines(self.text)
        self._constructor = SafeConstructor()

    # -- reading ------------------------------------------------------------

    @classmethod
    def read(cls, path: Path, shown_as: str | None = None, what: str = "YAML file") -> YamlSource:
        """Read and compose ``path``; a missing, unreadable or ill-formed file raises SourceError."""
        name = shown_as or str(path)
        where = SourceLocation(name, 1, 1)
        try:
            if path.stat().st_size > MAX_YAML_BYTES:
                raise SourceError(Problem(f"file is too large for a {what}", where))
            data = path.read_bytes()
        except IsADirectoryError:
            raise SourceError(Problem("is a directory, not a file", where, None,
                                      f"name the {what} inside it")) from None
        except FileNotFoundError:
            raise SourceError(Problem("no such file", where, None, "check the path")) from None
        except OSError as exc:
            raise SourceError(Problem(f"cannot read file: {exc.strerror}", where)) from None
        try:
            text = data.decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            raise SourceError(Problem(f"not UTF-8 text (byte {exc.start})", where, None,
                                      f"a {what} is YAML text; is this a binary file?")) from None
        return cls.parse(text, name, what)

    @classmethod
    def parse(cls, text: str, file: str, what: str = "YAML file") -> YamlSource:
        """Compose ``text``; a YAML syntax error becomes a located SourceError."""
        source = cls(file, text)
        try:
            source.root = yaml.compose(text, Loader=yaml.SafeLoader)
        except yaml.MarkedYAMLError as exc:
            mark = exc.problem_mark or exc.context_mark
            message = f"YAML syntax: {exc.problem or exc.context or 'cannot parse'}"
            if exc.context and exc.problem:
                message += f" ({exc.context}"
                if exc.context_mark is not None and exc.problem_mark is not None \
                        and exc.context_mark.line != exc.problem_mark.line:
                    message += f" at line {exc.context_mark.line + 1}"
                message += ")"
            source.error(mark, message, "check indentation, colons after keys and closing brackets")
            source.check()
        except yaml.reader.ReaderError as exc:  # a control character
            pos = exc.position
            line = text.count("\n", 0, pos) + 1
            column = pos - (text.rfind("\n", 0, pos) + 1) + 1
            loc = SourceLocation(file, line, column)
            source.problems.append(Problem(f"YAML syntax: character {_char(exc.character)!r} is not allowed here",
                                           loc, line_of(source.lines, line), "remove it or write it escaped in quotes"))
            source.check()
        except yaml.YAMLError as exc:
            source.error(None, f"YAML syntax: {exc}")
            source.check()
        if source.root is not None:
            source._check_tags(source.root)
            source.check()
        if source.root is None:
            source.error(None, "file is empty", f"a {what} is a YAML mapping of keys to values")
            source.check()
        return source

    def _check_tags(self, root: Node) -> None:
        """Report explicit tags other than YAML's own (``!thing``, ``!!python/...``): they mean nothing here."""
        seen: set[int] = set()
        todo = [root]
        while todo:
            node = todo.pop()
            if id(node) in seen:
                continue
            seen.add(id(node))
            if not node.tag.startswith("tag:yaml.org,2002:") or node.tag.startswith("tag:yaml.org,2002:python/"):
                self.error(node, f"unsupported YAML tag '{node.tag}'", "remove the tag: write plain values")
            if isinstance(node, SequenceNode):
                todo.extend(node.value)
            elif isinstance(node, MappingNode):
                for key, value in node.value:
                    todo += (key, value)

    # -- problems -----------------------------------------------------------

    def location(self, where: Node | Any | None) -> SourceLocation:
        """file:line:column of a node (its start) or a PyYAML mark; 1:1 for None."""
        mark = getattr(where, "start_mark", where)
        if mark is None or not hasattr(mark, "line"):
            return SourceLocation(self.file, 1, 1)
        return SourceLocation(self.file, mark.line + 1, mark.column + 1)

    def error(self, where: Node | Any | None, message: str, hint: str | None = None) -> None:
        """Record a problem at ``where`` (a node or a mark)."""
        loc = self.location(where)
        self.problems.append(Problem(message, loc, line_of(self.lines, loc.line), hint))

    def check(self) -> None:
        """Raise every problem recorded so far, if any: those in other files (a map) first, then in file order."""
        if self.problems:
            other = [p for p in self.problems if p.location.file != self.file]
            own = sorted((p for p in self.problems if p.location.file == self.file),
                         key=lambda p: (p.location.line, p.location.column))
            raise SourceError(other + own)

    # -- typed readers ------------------------------------------------------

    def value(self, node: Node) -> Any:
        """The plain Python value of a node (None after a problem: an unknown tag)."""
        try:
            return self._constructor.construct_object(node, deep=True)
        except yaml.YAMLError as exc:
            self.error(node, f"cannot read this value: {getattr(exc, 'problem', None) or exc}",
                       "write plain numbers, strings, lists and mappings (no !tags)")
            return None

    def keys(self, node: Node, path: str, allowed: tuple[str, ...] | None,
             required: tuple[str, ...] = (), what: str = "") -> dict[str, tuple[Node, Node]] | None:
        """A mapping's entries ``{key: (key node, value node)}``.

        Reports a node that is not a mapping, keys that are not strings,
        duplicate keys, keys not in ``allowed`` (with the nearest allowed
        name as a hint; None allows any key) and missing ``required`` keys.
        """
        if not isinstance(node, MappingNode):
            self.error(node, f"{path or 'the file'} must be a mapping of keys to values{what}, "
                             f"not {_kind(node)}",
                       _example_hint(path, allowed))
            return None
        entries: dict[str, tuple[Node, Node]] = {}
        misspelt: set[str | None] = set()  # what the unknown keys were probably meant to be
        for key_node, value_node in node.value:
            if not isinstance(key_node, ScalarNode) or not str(key_node.value).strip():
                self.error(key_node, f"a key in {path or 'the file'} must be a name, not {_kind(key_node)}")
                continue
            key = str(key_node.value)
            if key in entries:
                first = self.location(entries[key][0])
                self.error(key_node, f"key '{key}' appears twice in {path or 'the file'} "
                                     f"(first at line {first.line})", "keep one of them")
                continue
            if allowed is not None and key not in allowed:
                near = _nearest(key, list(allowed))
                misspelt.add(near)
                hint = f"did you mean '{near}'?" if near else None
                known = ", ".join(allowed)
                hint = f"{hint} (known keys: {known})" if hint else f"known keys: {known}"
                self.error(key_node, f"unknown key '{key}' in {path or 'the file'}", hint)
                continue
            entries[key] = (key_node, value_node)
        for key in required:
            if key not in entries and key not in misspelt:
                unknown = [k.value for k, _ in node.value if isinstance(k, ScalarNode) and k.value not in entries]
                near = _nearest(key, [str(k) for k in unknown]) if unknown else None
                hint = f"is '{near}' a misspelling of it?" if near else f"add '{key}: ...'"
                self.error(node, f"{path or 'the file'} is missing the key '{key}'", hint)
        return entries

    def items(self, node: Node, path: str, hint: str | None = None) -> list[Node] | None:
        """A sequence's item nodes, or None after reporting a node that is not a list."""
        if not isinstance(node, SequenceNode):
            self.error(node, f"{path} must be a list, not {_kind(node)}", hint)
            return None
        return list(node.value)

    def number(self, node: Node, path: str, *, minimum: float | None = None, above: float | None = None,
               maximum: float | None = None, integer: bool = False) -> float | None:
        """A finite number (an int when ``integer``) within the given limits."""
        wanted = "a whole number" if integer else "a number"
        tags = ("tag:yaml.org,2002:int",) if integer else ("tag:yaml.org,2002:int", "tag:yaml.org,2002:float")
        if not isinstance(node, ScalarNode) or node.tag not in tags:
            self.error(node, f"{path} must be {wanted}, not {_kind(node)}")
            return None
        value = self.value(node)
        if value is None:
            return None
        if not math.isfinite(value):
            self.error(node, f"{path} must be a finite number")
            return None
        if minimum is not None and value < minimum:
            self.error(node, f"{path} must be at least {minimum:g}, not {value:g}")
            return None
        if above is not None and value <= above:
            self.error(node, f"{path} must be more than {above:g}, not {value:g}")
            return None
        if maximum is not None and value > maximum:
            self.error(node, f"{path} must be at most {maximum:g}, not {value:g}")
            return None
        return int(value) if integer else float(value)

    def numbers(self, node: Node, path: str, counts: tuple[int, ...], shape: str) -> list[float] | None:
        """A list of ``counts`` numbers (one of the allowed lengths), e.g. a wall ``[x1, y1, x2, y2]``."""
        items = self.items(node, path, f"write it as {shape}")
        if items is None:
            return None
        if len(items) not in counts:
            self.error(node, f"{path} must be {shape}: {_count_words(counts)} numbers, not {len(items)}",
                       f"write it as {shape}")
            return None
        values = [self.number(item, f"{path}[{i}]") for i, item in enumerate(items)]
        return None if any(v is None for v in values) else values  # type: ignore[return-value]

    def point(self, node: Node, path: str) -> tuple[float, float] | None:
        """A point ``[x, y]``."""
        values = self.numbers(node, path, (2,), "[x, y]")
        return None if values is None else (values[0], values[1])

    def points(self, node: Node, path: str, at_least: int, shape: str) -> list[tuple[float, float]] | None:
        """A list of at least ``at_least`` points ``[[x, y], ...]``."""
        items = self.items(node, path, f"write it as {shape}")
        if items is None:
            return None
        if len(items) < at_least:
            self.error(node, f"{path} needs at least {at_least} points [x, y], not {len(items)}",
                       f"write it as {shape}")
            return None
        found = [self.point(item, f"{path}[{i}]") for i, item in enumerate(items)]
        return None if any(p is None for p in found) else found  # type: ignore[return-value]

    def string(self, node: Node, path: str, hint: str | None = None) -> str | None:
        """A non-empty string (a plain name)."""
        if not isinstance(node, ScalarNode) or node.tag != "tag:yaml.org,2002:str" or not node.value.strip():
            self.error(node, f"{path} must be a name or text, not {_kind(node)}", hint)
            return None
        return node.value

    def boolean(self, node: Node, path: str) -> bool | None:
        """``true`` or ``false``."""
        if not isinstance(node, ScalarNode) or node.tag != "tag:yaml.org,2002:bool":
            self.error(node, f"{path} must be true or false, not {_kind(node)}")
            return None
        value = self.value(node)
        if value is None:
            return None
        return value


def _kind(node: Node) -> str:
    """What a node is, in words, for messages."""
    if isinstance(node, MappingNode):
        return "a mapping"
    if isinstance(node, SequenceNode):
        return f"a list of {len(node.value)}"
    tag = node.tag.rsplit(":", 1)[-1]
    if tag == "null":
        return "nothing (null)"
    if tag in ("int", "float"):
        return f"the number {node.value}"
    if tag == "bool":
        return f"'{node.value}' (true/false)"
    shown = node.value if len(node.value) <= 40 else node.value[:37] + "..."
    return f"'{shown}'"


def _char(character: object) -> str:
    return chr(character) if isinstance(character, int) else str(character)


def _count_words(counts: tuple[int, ...]) -> str:
    return " or ".join(str(c) for c in counts)


def _example_hint(path: str, allowed: tuple[str, ...] | None) -> str | None:
    if not allowed:
        return None
    return "write it as 'key: value' lines; keys: " + ", ".join(allowed)


# --------------------------------------------------------------------------
# ROS maps

MAP_KEYS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode")
MAP_REQUIRED = ("image", "resolution", "origin", "occupied_thresh", "free_thresh")
MODES = ("trinary", "scale", "raw")
FREE, OCCUPIED, UNKNOWN = 0, 100, -1


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


def load_ros_map(path_yaml: str | Path, shown_as: str | None = None) -> RosMap:
    """Read a map_server YAML and its image into a :class:`RosMap`.

    A file that is not a map raises :class:`SourceError` with every problem
    located at its key in the YAML (``shown_as`` is the name used in those
    reports; the path by default).
    """
    path = Path(path_yaml)
    src = YamlSource.read(path, shown_as, "ROS map YAML")
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
            near = _nearest(given, list(MODES))
            src.error(node["mode"], f"unknown mode '{given}'",
                      (f"did you mean '{near}'? " if near else "") + "modes: trinary, scale, raw")
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
                  origin: tuple[float, float] | tuple[float, float, float], image_format: str = "pgm") -> Path:
    """Write a map_server map (trinary, thresholds 0.65 / 0.196) and return the image's path.

    ``labels_or_probabilities`` has row 0 at the TOP (as :class:`RosMap`):
    either labels (integers 0 free, 100 occupied, -1 unknown; or booleans,
    True occupied), written as the usual pixels 254 / 0 / 205 and read back
    identically; or probabilities of occupancy (floats in [0, 1], NaN
    unknown), written as ``round(255 (1 - p))`` and read back to within
    1/510, except that probabilities between the thresholds read back as
    unknown (NaN), as any trinary reader sees them. The image is
    ``<yaml stem>.pgm`` (binary P5) or ``.png`` beside the YAML.
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
        image.write_bytes(b"P5\n# written by atlas-rap\n%d %d\n255\n" % (width, height) + pixels.tobytes())
    else:
        import imageio.v3 as iio

        iio.imwrite(image, pixels)
    ox, oy = float(origin[0]), float(origin[1])
    yaw = float(origin[2]) if len(origin) > 2 else 0.0
    path.write_text(
        f"image: {image.name}\n"
        f"resolution: {float(resolution)!r}\n"
        f"origin: [{ox!r}, {oy!r}, {yaw!r}]\n"
        "negate: 0\n"
        "occupied_thresh: 0.65\n"
        "free_thresh: 0.196\n"
        "mode: trinary\n", encoding="utf-8")
    return image


# -- walls ------------------------------------------------------------------

def wall_segments(rosmap: RosMap, tolerance: float | None = None) -> list[Segment]:
    """The outlines of the occupied cells as wall segments in world coordinates.

    The occupied mask is padded with free cells (so blobs touching the
    border still close), outlined with ``skimage.measure.find_contours`` along
    the cells' edges (half a cell from occupied cell centres; corners are cut
    by half a cell at 45 degrees) and simplified with ``approximate_polygon``
    to within ``tolerance`` metres. The default, a third of a cell, keeps
    straight walls on the cells' edges; a cell or more merges the corner cuts
    and staircases into fewer, slightly slanted segments.
    """
    from skimage.measure import approximate_polygon, find_contours

    mask = np.pad(rosmap.occupied, 1, constant_values=False).astype(np.float32)
    if not mask.any():
        return []
    cells = tolerance / rosmap.resolution if tolerance is not None else 0.3
    segments: list[Segment] = []
    for contour in find_contours(mask, 0.5, fully_connected="high"):
        simple = approximate_polygon(contour, tolerance=cells) if cells > 0 else contour
        xs, ys = rosmap.cell_to_world(simple[:, 0] - 1.0, simple[:, 1] - 1.0)
        points = [(round(float(x), 6), round(float(y), 6)) for x, y in zip(xs, ys)]
        for a, b in pairwise(points):
            if a != b:
                segments.append(Segment(a, b))
    return segments
