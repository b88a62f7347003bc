"""Every level of a map written to a folder: data for programs, PNG for people.

:func:`write_levels` takes an occupancy map (probabilities, NaN unknown)
and its abstraction and writes:

- ``grid.npz`` (``p_occ``, ``dt``, ``skeleton``, ``places``, ``skeleton_probability``
  and the frame) and ``grid.png``;
- ``edges.png`` and ``polygons.png`` (the geometric map), when computed;
- ``distance-transform.png``, ``places.png``, ``stochastic-sdt.png``;
- ``topology.json``, ``topology.graphml`` and ``topology.png`` (X/T/L nodes over the map);
- ``route.png``: a route on the graph, between two given points or else
  between the two graph nodes farthest apart.

``atlas map abstract`` and ``atlas map build`` both end here.

Writing is kept cheap (issue 13): the pictures share one
:class:`atlas_rap.views.map_render.MapSheet` (the figure, its axes and ticks,
the reduced grids and the faint background are made once; each picture
then costs some 30-60 ms, mostly matplotlib's text and zlib), the topology
files are written without Python work per cell, and ``grid.npz`` by
:func:`save_npz`. On a 2000 x 2000 plan writing costs about what the
abstraction does; on a small map the eight pictures cost more than its
abstraction (a few hundredths of a second), so ``pictures=False`` is there
for callers that only want the data.
"""

from __future__ import annotations

import io
import zipfile
import zlib
from pathlib import Path

import numpy as np

from atlas_rap.maps.abstraction import Abstraction
from atlas_rap.outputs import atomic_write

LEVEL_FILES = ("grid.npz", "grid.png", "edges.png", "polygons.png", "distance-transform.png", "places.png",
               "stochastic-sdt.png", "topology.json", "topology.graphml", "topology.png", "route.png")
"""The files :func:`write_levels` may write in its folder."""

NPZ_COMPRESS_LEVEL = 1
"""zlib level of the arrays in ``grid.npz``. Level 1 is about as small as numpy's default (6) on maps and
two to three times faster; an array that would not shrink by a fifth (noise) is stored as it is (a
2000 x 2000 plan with noisy probabilities: 18 MB in 0.2 s, against 15.5 MB in 0.8 s)."""


def write_levels(p_occ: np.ndarray, result: Abstraction, out_dir: str | Path, *,
                 path_xy: np.ndarray | None = None, title: str = "",
                 route_ends: tuple[tuple[float, float], tuple[float, float]] | None = None,
                 pictures: bool = True) -> list[Path]:
    """Write every level (data and pictures) into ``out_dir``; the files written, in order.

    ``pictures=False`` writes the data only (``grid.npz``, ``topology.json``,
    ``topology.graphml``), for a caller that has no use for the PNGs.
    """
    from atlas_rap.views import map_render as render

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    frame, sdt = result.frame, result.sdt
    prefix = f"{title}: " if title else ""
    probability = sdt.probability_grid()
    written = [save_npz(out / "grid.npz", p_occ=np.asarray(p_occ, dtype=np.float32), dt=sdt.dt,
                        skeleton=sdt.skeleton, places=sdt.places, skeleton_probability=probability,
                        frame=frame.to_array())]
    topology = result.topology
    if not pictures:
        return written + [topology.to_json(out / "topology.json"), topology.to_graphml(out / "topology.graphml")]
    with render.MapSheet(frame) as sheet:
        written.append(render.render_grid(p_occ, frame, out / "grid.png", title=prefix + "occupancy grid",
                                          path_xy=path_xy, sheet=sheet))
        if result.geometry is not None:
            geo = result.geometry
            written.append(render.render_edges(geo.occupied_edges, geo.empty_edges, frame, out / "edges.png",
                                               title=prefix + "edges", background=p_occ, sheet=sheet))
            written.append(render.render_polygons(geo.polygons, frame, out / "polygons.png", background=p_occ,
                                                  title=prefix + "polygons", sheet=sheet))
        written.append(render.render_distance_transform(sdt.dt, frame, out / "distance-transform.png",
                                                        title=prefix + "distance transform", sheet=sheet))
        written.append(render.render_places(sdt.places, frame, out / "places.png", names=topology.place_names or None,
                                            background=p_occ, title=prefix + "places", sheet=sheet))
        written.append(render.render_stochastic_sdt(probability, frame, out / "stochastic-sdt.png",
                                                    background=p_occ, title=prefix + "stochastic SDT", sheet=sheet))
        written.append(topology.to_json(out / "topology.json"))
        written.append(topology.to_graphml(out / "topology.graphml"))
        written.append(render.render_topology(topology.graph, frame, out / "topology.png", background=p_occ,
                                              title=prefix + "topological map", sheet=sheet))
        ends = route_ends or _farthest_nodes(topology.graph)
        route = topology.route(*ends) if ends else None
        if route is not None:
            written.append(render.render_route(p_occ, frame, np.asarray(route.waypoints), out / "route.png",
                                               graph=topology.graph, sheet=sheet,
                                               title=prefix + f"a route, {route.length:.1f} m, "
                                               f"P(clear) {route.probability:.2f}"))
    return written


def save_npz(path: str | Path, **arrays: np.ndarray) -> Path:
    """Write ``arrays`` as a ``.npz`` that ``np.load`` reads, compressed at :data:`NPZ_COMPRESS_LEVEL`; the path.

    Like ``np.savez_compressed`` but quicker: zlib level 1, and an array
    whose middle 64 kB do not shrink by a fifth (a noisy float grid) is
    stored uncompressed rather than squeezed for little. The entries
    carry a fixed date, so the same arrays give the same bytes.
    """
    out = Path(path)
    with atomic_write(out) as stream, zipfile.ZipFile(stream, "w", allowZip64=True) as archive:
        for name, value in arrays.items():
            buffer = io.BytesIO()
            np.lib.format.write_array(buffer, np.asanyarray(value), allow_pickle=False)
            data = buffer.getbuffer()
            middle = len(data) // 2  # (a map's first rows are often all unknown: the middle says more)
            sample = bytes(data[max(0, middle - (1 << 15)):middle + (1 << 15)])
            squeezes = len(zlib.compress(sample, NPZ_COMPRESS_LEVEL)) < 0.8 * len(sample)
            entry = zipfile.ZipInfo(name + ".npy", date_time=(1980, 1, 1, 0, 0, 0))
            entry.external_attr = 0o644 << 16
            archive.writestr(entry, data, compress_type=zipfile.ZIP_DEFLATED if squeezes else zipfile.ZIP_STORED,
                             compresslevel=NPZ_COMPRESS_LEVEL if squeezes else None)
    return out


def _farthest_nodes(graph) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """The world positions of the two nodes farthest apart (straight line), or None for fewer than two."""
    if graph.number_of_nodes() < 2:
        return None
    nodes = list(graph.nodes)
    xy = np.array([graph.nodes[n]["xy"] for n in nodes], dtype=float)
    gaps = np.hypot(xy[:, None, 0] - xy[None, :, 0], xy[:, None, 1] - xy[None, :, 1])
    i, j = np.unravel_index(int(np.argmax(gaps)), gaps.shape)
    return tuple(xy[i]), tuple(xy[j])
