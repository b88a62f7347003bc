"""Benchmark the map abstraction: ``abstract()`` against the two library calls it is built on.

On a synthetic floor plan of size x size cells at 0.05 m (a deterministic
office: rows of rooms with doors on corridors, cross corridors, furniture,
noisy probabilities and a few unknown patches), time

- ``ours``: :func:`atlas_rap.maps.abstraction.abstract` -- free space, DT, skeleton,
  segments, places, topology, every edge's probability;
- ``bare``: ``skimage.morphology.skeletonize(free)`` +
  ``scipy.ndimage.distance_transform_edt(free)`` on the same free mask;

and report seconds (best of ``runs``), the ratio ours / bare (target <= 1.5:
the pipeline should add little beyond those two calls) and where our time
goes, stage by stage. Prints one JSON object a line.

Run: ``python benchmarks/bench_abstraction.py`` (``--sizes 2000 4000``,
``--runs 3``; ``--quick`` for one run of 2000).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent)]  # the checkout, if not installed

RESOLUTION = 0.05
TARGET = 1.5


def floor_plan(size: int, seed: int = 0, resolution: float = RESOLUTION) -> np.ndarray:
    """P(occupied) of a synthetic office of size x size cells (NaN = unknown), the same for the same seed."""
    rng = np.random.default_rng(seed)

    def cells(metres: float) -> int:
        return max(1, int(round(metres / resolution)))

    wall, corridor, depth, door = cells(0.2), cells(2.0), cells(5.0), cells(0.9)
    occ = np.zeros((size, size), dtype=bool)
    occ[:wall] = occ[-wall:] = True
    occ[:, :wall] = occ[:, -wall:] = True
    period = 2 * depth + corridor + 2 * wall
    y = wall
    corridors = []
    while y + period <= size - wall:
        cor0 = y + depth + wall
        cor1 = cor0 + corridor
        bottom = cor1 + wall + depth
        occ[cor0 - wall:cor0] = True
        occ[cor1:cor1 + wall] = True
        occ[bottom:bottom + wall] = True
        corridors.append((cor0, cor1))
        for r0, r1, door_row in ((y, cor0 - wall, cor0 - wall), (cor1 + wall, bottom, cor1)):
            x = wall
            while x < size - wall:
                x1 = min(x + int(rng.integers(cells(3.0), cells(8.0))), size - wall)
                occ[r0:r1, x1:x1 + wall] = True
                if x1 - x > door + 4:
                    d0 = int(rng.integers(x + 2, x1 - door - 1))
                    occ[door_row:door_row + wall, d0:d0 + door] = False
                if rng.random() < 0.5 and x1 - x > cells(2.0) and r1 - r0 > cells(2.0):  # a table or a cupboard
                    fw, fh = int(rng.integers(cells(0.4), cells(1.2))), int(rng.integers(cells(0.4), cells(1.2)))
                    fx = int(rng.integers(x + wall, max(x + wall + 1, x1 - fw - wall)))
                    fy = int(rng.integers(r0 + wall, max(r0 + wall + 1, r1 - fh - wall)))
                    occ[fy:fy + fh, fx:fx + fw] = True
                x = x1 + wall
        y = bottom + wall
    # Cross corridors, walled on both sides, open onto the corridors they cross.
    for x in range(cells(10.0), size - cells(10.0), cells(30.0)):
        occ[wall:y, x - wall:x + corridor + wall] = True
        occ[wall:y, x:x + corridor] = False
        for cor0, cor1 in corridors:
            occ[cor0:cor1, x - wall:x + corridor + wall] = False
    p = np.where(occ, rng.uniform(0.7, 0.95, occ.shape), rng.uniform(0.0, 0.05, occ.shape)).astype(np.float32)
    for _ in range(size // 200):  # unexplored patches
        r, c = rng.integers(0, size - cells(3.0), 2)
        p[r:r + cells(3.0), c:c + cells(3.0)] = np.nan
    return p


def _best(fn, runs: int) -> float:
    best = float("inf")
    for _ in range(runs):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def bench_abstraction(size: int, runs: int = 3, seed: int = 0) -> dict:
    """Time abstract() and the bare skeletonize + distance_transform_edt on a size x size floor plan."""
    from scipy.ndimage import distance_transform_edt
    from skimage.morphology import skeletonize

    from atlas_rap.maps.abstraction import abstract
    from atlas_rap.maps.frame import GridFrame
    from atlas_rap.maps.sdt import (
        distance_transform,
        free_space,
        skeleton,
        trace_skeleton,
    )
    from atlas_rap.maps.topology import build_topology

    p = floor_plan(size, seed)
    frame = GridFrame(size, size, RESOLUTION)
    free = p < 0.5

    def bare() -> None:
        skeletonize(free)
        distance_transform_edt(free)

    result = {}

    def ours() -> None:
        result["a"] = abstract(p, frame)

    bare_s = ours_s = float("inf")
    for _ in range(runs):  # interleaved, so that a slow moment of the machine hits both
        bare_s = min(bare_s, _best(bare, 1))
        ours_s = min(ours_s, _best(ours, 1))
    ab = result["a"]

    # Where our time goes (the same steps as abstract(), timed one by one, once).
    stages: dict[str, float] = {}
    clock = time.perf_counter()

    def lap(name: str) -> None:
        nonlocal clock
        now = time.perf_counter()
        stages[name] = round(now - clock, 3)
        clock = now

    f = free_space(p)
    lap("free_space")
    dt = distance_transform(f, frame)
    lap("distance_transform")
    skel = skeleton(dt, f, 0.2)
    lap("skeletonize")
    trace = trace_skeleton(skel, dt)
    lap("trace")
    build_topology(trace, dt, p, frame, robot_radius=0.2, free=f)
    lap("topology+places")

    kinds = ab.topology.kinds()
    return {
        "bench": "map-abstraction", "size": size, "cells": size * size, "resolution": RESOLUTION,
        "ours_s": round(ours_s, 3), "bare_s": round(bare_s, 3), "ratio": round(ours_s / bare_s, 3),
        "target": TARGET, "ok": ours_s / bare_s <= TARGET, "runs": runs, "stages_s": stages,
        "skeleton_pixels": int(skel.sum()), "nodes": ab.topology.graph.number_of_nodes(),
        "edges": ab.topology.graph.number_of_edges(), "kinds": kinds, "places": int(ab.places.max()),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[2000, 4000])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="one run of 2000 x 2000")
    args = parser.parse_args()
    sizes, runs = ([2000], 1) if args.quick else (args.sizes, args.runs)
    for size in sizes:
        print(json.dumps(bench_abstraction(size, runs)), flush=True)


if __name__ == "__main__":
    main()
