"""The page layout every PNG of atlas-rap shares: map size in inches, metres kept 1:1, resolution; PNG writing.

Pictures of runs (``views.world_render``) and of maps (``views.map_render``) draw a map
in metres with equal aspect; :func:`map_layout` decides how big it is and
which range of metres it shows, so all pictures look alike.
:func:`write_png` writes an RGB image as a PNG quickly (see there why not
through PIL); :func:`save_figure_png` writes a matplotlib figure as
matplotlib lays it out. Both write a file whole or not at all
(``atlas_rap.outputs``). :func:`plain_text` and :func:`cut_text` are the text
helpers every picture shares.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

from atlas_rap.outputs import atomic_write, write_bytes

DPI = 110
PAD_INCHES = 0.15  # white margin round what a picture shows
MAX_MAP_W = 7.5  # inches for the map itself, at most...
MAX_MAP_H = 6.5  # ...and at most this tall
MIN_MAP_SIDE = 2.5  # a long thin map still gets this much on its short side
PNG_COMPRESS_LEVEL = 3
"""zlib level of :func:`write_png`. Pictures are mostly flat colour: level 3 without row filters comes
within a quarter of PIL's level 6 with its adaptive filters (often under it) in a quarter of its time;
level 6 would save another 10-25 % for twice the time."""


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


def write_png(pixels: np.ndarray, path: str | Path, *, dpi: float = DPI,
              level: int = PNG_COMPRESS_LEVEL) -> Path:
    """Write an (H, W, 3) RGB or (H, W, 4) RGBA uint8 image as an 8-bit RGB PNG (alpha is dropped); the path.

    The same pixels give the same bytes (no time stamp, no software
    name). Rows are not filtered (PNG filter 0) and zlib runs at
    ``level`` (see :data:`PNG_COMPRESS_LEVEL`): on pictures of maps,
    which are mostly flat colour, that is about as small as PIL's writer
    with its per-row adaptive filters and several times faster.
    """
    image = np.asarray(pixels)
    if image.ndim != 3 or image.shape[2] not in (3, 4) or image.dtype != np.uint8:
        raise ValueError(f"write_png takes an (H, W, 3 or 4) uint8 image, not {image.dtype} of shape {image.shape}")
    h, w = image.shape[:2]
    rows = np.empty((h, 1 + 3 * w), dtype=np.uint8)  # each row: its filter type, then its pixels
    rows[:, 0] = 0  # filter type 0 (none)
    if image.shape[2] == 4 and h and w:  # (as a canvas holds them) move each pixel's 3 colour bytes in one go
        rgba = np.ascontiguousarray(image)
        colours = np.ndarray((h, w), dtype="V3", buffer=rgba, strides=(4 * w, 4))
        np.ndarray((h, w), dtype="V3", buffer=rows, offset=1, strides=(1 + 3 * w, 3))[...] = colours
    else:
        np.ndarray((h, w, 3), dtype=np.uint8, buffer=rows, offset=1, strides=(1 + 3 * w, 3, 1))[...] = image[..., :3]
    per_metre = round(dpi / 0.0254)

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    png = b"".join([
        b"\x89PNG\r\n\x1a\n",
        chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)),  # 8 bits, RGB, no interlace
        chunk(b"pHYs", struct.pack(">IIB", per_metre, per_metre, 1)),
        chunk(b"IDAT", zlib.compress(rows, level)),
        chunk(b"IEND", b""),
    ])
    return write_bytes(path, png)


def save_figure_png(fig, path: str | Path, **options) -> Path:
    """``fig.savefig`` as a PNG on a white page, with no software name (the same figure gives the
    same bytes), written whole or not at all; ``options`` go to ``savefig`` (``dpi``,
    ``bbox_inches``, ...). The path."""
    options = {"dpi": DPI, "facecolor": "white", **options}
    with atomic_write(path) as stream:
        fig.savefig(stream, format="png", metadata={"Software": None}, **options)
    return Path(path)


def plain_text(text: object) -> str:
    """Text shown as written in a matplotlib picture: a ``$`` would otherwise start its mathtext."""
    return str(text).replace("$", r"\$")


def cut_text(text: str, limit: int) -> str:
    """``text`` cut to at most ``limit`` characters, with an ellipsis where it was cut."""
    return text if len(text) <= limit else text[: limit - 1] + "\u2026"
