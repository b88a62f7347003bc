"""A picture of a recording (``atlas run --record``), drawn from the MCAP file alone.

What Foxglove's 3D panel shows at the end of the run, as a PNG, for people
without Foxglove and for the docs (``docs/foxglove-recording.png``):
the last occupancy grid, the scene (walls, doors, places, obstacles), the
topology, every route the robot drove, its path, the last sonar ring and
the robot; when the recording has the pose belief (``/robot/estimated_path``,
``/robot/estimate/ellipse``), the path the robot believed it drove beside the
true one and the last estimate's 2-sigma ellipse. It reads the file back with :mod:`atlas_rap.views.mcap_reader`
(so it also checks that a recording can be read without Foxglove)::

    render_recording("run.mcap", "run.png")        # or: atlas record show run.mcap --out run.png
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from atlas_rap.views.mcap_reader import Recording, read_recording
from atlas_rap.views.page import DPI, map_layout, save_figure_png

_LINE_LIST = 2
_BELIEF = "#d6127a"  # the believed path and the estimate's ellipse, as in views.world_render
_LOOKS = {  # how the scene's entities' lines are drawn
    "walls": {"linewidths": 1.4, "zorder": 3},
    "doors": {"linewidths": 2.2, "zorder": 3},
    "places": {"linewidths": 0.8, "linestyles": "--", "alpha": 0.6, "zorder": 1},
}


def _xy(point: dict) -> tuple[float, float]:
    return point.get("x", 0.0), point.get("y", 0.0)


def _yaw(pose: dict) -> float:
    q = pose.get("orientation", {})
    return 2.0 * math.atan2(q.get("z", 0.0), q.get("w", 1.0))


def _colour(c: dict) -> tuple[float, float, float, float]:
    return c.get("r", 0.0), c.get("g", 0.0), c.get("b", 0.0), c.get("a", 1.0)


def scene_at_end(recording: Recording, topic: str) -> dict[str, dict]:
    """The entities a ``SceneUpdate`` topic leaves at the end: id → its last entity (deletions applied)."""
    entities: dict[str, dict] = {}
    for _, update in recording.messages(topic):
        for deletion in update.get("deletions", []):
            entities.pop(deletion.get("id", ""), None)
        for entity in update.get("entities", []):
            entities[entity.get("id", "")] = entity
    return entities


def _routes(recording: Recording) -> list[list[tuple[float, float]]]:
    """Every distinct route line sent on ``/robot/route``, in order."""
    seen: dict[tuple, list[tuple[float, float]]] = {}
    for _, update in recording.messages("/robot/route"):
        for entity in update.get("entities", []):
            for line in entity.get("lines", []):
                points = [_xy(p) for p in line.get("points", [])]
                seen.setdefault(tuple(points), points)
    return list(seen.values())


def _segments(line: dict) -> list[list[tuple[float, float]]]:
    """A line primitive as polylines: pairs for a line list, one strip (closed for a loop) otherwise."""
    points = [_xy(p) for p in line.get("points", [])]
    kind = line.get("type", 0)
    if kind == _LINE_LIST:
        return [points[i:i + 2] for i in range(0, len(points) - 1, 2)]
    return [points + points[:1]] if kind == 1 else [points]


def _grid_image(grid: dict) -> tuple[np.ndarray, tuple[float, float, float, float]]:
    """The ``occupancy`` field of a ``foxglove.Grid`` as rows bottom-up, and its extent."""
    data = np.frombuffer(grid.get("data", b""), dtype=np.uint8)
    stride, columns = grid.get("row_stride", 1), grid.get("column_count", 1)
    rows = data.reshape(-1, stride)[:, :columns * grid.get("cell_stride", 1):grid.get("cell_stride", 1)]
    size = grid.get("cell_size", {})
    ox, oy = _xy(grid.get("pose", {}).get("position", {}))
    return rows, (ox, ox + columns * size.get("x", 1.0), oy, oy + rows.shape[0] * size.get("y", 1.0))


def render_recording(mcap: str | Path, out_png: str | Path, title: str | None = None) -> Path:
    """Draw the end of the recording ``mcap`` to ``out_png``; its path."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.collections import LineCollection
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Circle, Ellipse, Rectangle

    recording = read_recording(mcap)
    scene = scene_at_end(recording, "/world/scene")
    topology = scene_at_end(recording, "/map/topology")
    routes = _routes(recording)
    path_msg = recording.last("/robot/path")
    path = [_xy(p.get("position", {})) for p in path_msg.get("poses", [])] if path_msg else []
    believed_msg = recording.last("/robot/estimated_path")
    believed = [_xy(p.get("position", {})) for p in believed_msg.get("poses", [])] if believed_msg else []
    ellipse = scene_at_end(recording, "/robot/estimate/ellipse").get("estimate")
    pose_msg = recording.last("/robot/pose")
    scan = recording.last("/robot/sonar")
    grid = recording.last("/map/grid")
    end = max((times[-1] for times in map(recording.times, recording.raw) if times), default=0.0)

    polylines = {key: [seg for entity in entities.values() for line in entity.get("lines", [])
                       for seg in _segments(line)] for key, entities in (("scene", scene), ("topology", topology))}
    xs = [x for segs in polylines.values() for seg in segs for x, _ in seg] + [x for x, _ in path + believed]
    ys = [y for segs in polylines.values() for seg in segs for _, y in seg] + [y for _, y in path + believed]
    image = _grid_image(grid) if grid else None
    if image is not None:
        xs += list(image[1][:2])
        ys += list(image[1][2:])
    if not xs:
        xs, ys = [0.0, 1.0], [0.0, 1.0]
    margin = 0.5
    (xmin, xmax, ymin, ymax), map_w, map_h = map_layout(min(xs) - margin, min(ys) - margin,
                                                        max(xs) + margin, max(ys) + margin)
    fig = Figure(figsize=(map_w + 2.2, map_h + 0.9), dpi=DPI)
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0.6 / (map_w + 2.2), 0.5 / (map_h + 0.9), map_w / (map_w + 2.2), map_h / (map_h + 0.9)))
    ax.set_xlim(xmin, xmax)
    ax.set_ylim(ymin, ymax)
    ax.set_aspect("equal", adjustable="box")
    ax.tick_params(labelsize=8)
    ax.set_title(f"{title or Path(mcap).name}: the recording at {end:.1f} s simulated", fontsize=10, loc="left")
    handles: list[Any] = []
    if image is not None:
        ax.imshow(image[0], origin="lower", extent=image[1], cmap="gray_r", vmin=0, vmax=100,
                  interpolation="nearest", zorder=0)
        handles.append(Line2D([], [], color="#777777", lw=6, label="occupancy grid"))
    for name, entity in scene.items():
        look = _LOOKS.get(name, _LOOKS["walls"])
        for line in entity.get("lines", []):
            ax.add_collection(LineCollection(_segments(line), colors=[_colour(line.get("color", {}))], **look))
        for text in entity.get("texts", []):
            x, y = _xy(text.get("pose", {}).get("position", {}))
            ax.text(x, y, text.get("text", ""), fontsize=6 if name == "doors" else 8, color="#1f3f8f",
                    ha="center", va="center", zorder=6)
        for sphere in entity.get("spheres", []):
            x, y = _xy(sphere.get("pose", {}).get("position", {}))
            ax.plot([x], [y], "o", ms=3, color=_colour(sphere.get("color", {})), zorder=3)
        for kind in ("cubes", "cylinders"):
            for shape in entity.get(kind, []):
                x, y = _xy(shape.get("pose", {}).get("position", {}))
                side = shape.get("size", {}).get("x", 0.5)
                patch = (Rectangle((x - side / 2, y - side / 2), side, side) if kind == "cubes"
                         else Circle((x, y), side / 2))
                patch.set(color="#e68a1a", zorder=4)
                ax.add_patch(patch)
    handles += [Line2D([], [], color="#333333", lw=1.4, label="walls, doors (open/shut)"),
                Line2D([], [], color="#4073d9", lw=0.8, ls="--", label="places")]
    topo = polylines["topology"]
    if topo:
        ax.add_collection(LineCollection(topo, colors="#8c33b3", linewidths=0.9, alpha=0.7, zorder=2))
        handles.append(Line2D([], [], color="#8c33b3", lw=0.9, label="topology"))
    for route in routes[:-1]:
        ax.plot(*zip(*route), color="#f2bf0d", lw=1.0, alpha=0.35, zorder=4)
    if routes:
        ax.plot(*zip(*routes[-1]), color="#f2bf0d", lw=2.4, zorder=4)
        handles.append(Line2D([], [], color="#f2bf0d", lw=2.4, label="last route"))
    if len(routes) > 1:
        handles.append(Line2D([], [], color="#f2bf0d", lw=1.0, alpha=0.35, label=f"earlier routes ({len(routes) - 1})"))
    if path:
        ax.plot(*zip(*path), color="#1f77b4", lw=1.2, zorder=5)
        handles.append(Line2D([], [], color="#1f77b4", lw=1.2, label="true path" if believed else "path"))
    if believed:
        ax.plot(*zip(*believed), color=_BELIEF, lw=1.1, ls=(0, (3.0, 1.6)), zorder=5.2)
        handles.append(Line2D([], [], color=_BELIEF, lw=1.1, ls=(0, (3.0, 1.6)), label="believed path"))
    for disc in (ellipse or {}).get("cylinders", [])[:1]:
        pose, size = disc.get("pose", {}), disc.get("size", {})
        ax.add_patch(Ellipse(_xy(pose.get("position", {})), size.get("x", 0.0), size.get("y", 0.0),
                             angle=math.degrees(_yaw(pose)), facecolor=(*_colour(disc.get("color", {}))[:3], 0.25),
                             edgecolor=_BELIEF, lw=1.0, zorder=8.5))
        handles.append(Line2D([], [], ls="none", marker="o", ms=7, markerfacecolor="none", markeredgecolor=_BELIEF,
                              label="last estimate, 2\u03c3"))
    if scan:
        x, y = _xy(scan.get("pose", {}).get("position", {}))
        yaw, ranges = _yaw(scan.get("pose", {})), scan.get("ranges", [])
        start, stop = scan.get("start_angle", 0.0), scan.get("end_angle", 0.0)
        step = (stop - start) / max(len(ranges) - 1, 1)
        rays = [[(x, y), (x + r * math.cos(yaw + start + i * step), y + r * math.sin(yaw + start + i * step))]
                for i, r in enumerate(ranges) if math.isfinite(r)]
        ax.add_collection(LineCollection(rays, colors="#d62728", linewidths=0.7, alpha=0.8, zorder=6))
        ax.scatter([ray[1][0] for ray in rays], [ray[1][1] for ray in rays], s=6, color="#d62728", zorder=6)
        handles.append(Line2D([], [], color="#d62728", lw=0.7, marker=".", label="sonar (last ring)"))
    if pose_msg:
        pose = pose_msg.get("pose", {})
        x, y = _xy(pose.get("position", {}))
        yaw = _yaw(pose)
        ax.add_patch(Circle((x, y), 0.2, facecolor="white", edgecolor="black", lw=1.0, zorder=7))
        ax.plot([x, x + 0.3 * math.cos(yaw)], [y, y + 0.3 * math.sin(yaw)], color="black", lw=1.2, zorder=8)
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, frameon=False)
    out = Path(out_png)
    save_figure_png(fig, out, dpi=DPI, bbox_inches="tight", pad_inches=0.15)
    fig.clear()
    return out
