"""Benchmark the places: room segmentation on three test beds side by side, and its speed.

Prints one JSON object a line:

- ``places-score``: generated floor plans (``tests/floorplans.py``, seeds
  0..N-1), plain and hard (walls of their own thickness, doors anywhere and
  often in a corner, turned buildings, specks and holes), each clean and
  furnished, and the generator's SLAM-noise variant when it has one: the
  share of rooms with a place of their own (IoU >= 0.5), mean recall,
  pixel-weighted precision, merged and split rooms, the worst plan.
  Targets (issue 25, on the hard plans): owned >= 0.95 clean and >= 0.9
  furnished, precision >= 0.9.
- ``places-real``: the real building ``../shared/data/maps/rooms/g4s_y2``
  (15 rooms with hand-drawn ground truth; skipped, saying why, when the
  data is absent). Target: >= 12 rooms with a place, precision >= 0.85.
- ``places-worlds``: ``atlas map build`` on the shipped worlds
  ``lab-corridor-office``, ``office-building`` and ``maze``: for each named
  region, whether a place of IoU >= 0.5 is named after it.
- ``places-speed``: the whole abstraction (``atlas_rap.maps.abstraction.abstract``:
  free space, DT, skeleton, topology, places) against the bare
  ``skimage.morphology.skeletonize`` + ``scipy.ndimage.distance_transform_edt``
  on the same free mask, on generated plans of about 0.25, 1, 4 and 16 million
  cells, best of ``--runs`` interleaved runs (target: ratio <= 1.5 from 1 M up).
- ``places-output``: ``atlas map abstract``'s work in one process: the
  abstraction alone against the abstraction plus writing every level (data
  and pictures, ``write_levels``) on a generated 1 M cell plan and on the
  shipped ``small-office-map`` (target: ratio <= 2).

Run: ``python benchmarks/bench_places.py`` (``--quick``: 10 plans, sizes up
to 4 M cells, one run).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent), str(HERE.parent / "tests")]  # the checkout, and the test bed

from floorplans import generate_plan, score  # noqa: E402

RESOLUTION = 0.05


def emit(record: dict) -> None:
    print(json.dumps(record), flush=True)


def _plan_kinds() -> list[dict]:
    """The generated test bed: plain and hard plans, clean and furnished, and SLAM-like ones if drawn."""
    import inspect

    kinds = [{"hard": hard, "furniture": furniture} for hard in (False, True) for furniture in (False, True)]
    if "slam" in inspect.signature(generate_plan).parameters:
        kinds += [{"slam": True, "furniture": furniture} for furniture in (False, True)]
    return kinds


def bench_scores(plans: int) -> None:
    from atlas_rap.maps.abstraction import abstract

    for kind in _plan_kinds():
        owned = rooms = 0
        recall, weighted, weight, merged, split = [], 0.0, 0.0, 0, 0
        worst = (2.0, -1)
        for seed in range(plans):
            plan = generate_plan(seed, **kind)
            result = score(abstract(plan.occupancy, plan.frame).places, plan.rooms)
            owned += result.owned_rooms
            rooms += result.n_rooms
            recall.append(result.mean_recall)
            on_rooms = float((plan.rooms > 0).sum())
            weighted += result.pixel_precision * on_rooms
            weight += on_rooms
            merged += result.merged_rooms
            split += result.split_rooms
            worst = min(worst, (result.owned_fraction, seed))
        emit({"bench": "places-score", **kind, "plans": plans, "rooms": rooms,
              "owned_fraction": round(owned / rooms, 4), "mean_recall": round(float(np.mean(recall)), 4),
              "pixel_precision": round(weighted / weight, 4), "merged_rooms": merged, "split_rooms": split,
              "worst_plan": {"seed": worst[1], "owned_fraction": round(worst[0], 4)},
              "target": {"owned_fraction": 0.9 if kind["furniture"] else 0.95, "pixel_precision": 0.9}})


def bench_real_map() -> None:
    from skimage.io import imread

    from atlas_rap.maps.abstraction import abstract
    from atlas_rap.maps.rosmap import load_ros_map

    folder = HERE.parent.parent / "shared" / "data" / "maps" / "rooms"
    if not (folder / "g4s_y2.yaml").exists():
        emit({"bench": "places-real", "map": "g4s_y2", "skipped": f"the shared real maps are not at {folder}"})
        return
    rosmap = load_ros_map(folder / "g4s_y2.yaml")
    truth = imread(folder / "g4s_y2_rooms.png").astype(np.int64)
    start = time.perf_counter()
    places = abstract(rosmap.occupancy, rosmap.frame).places
    seconds = time.perf_counter() - start
    result = score(places, truth)
    emit({"bench": "places-real", "map": "g4s_y2", "rooms": result.n_rooms, "places": int(places.max()),
          "owned_rooms": result.owned_rooms, "pixel_precision": round(result.pixel_precision, 4),
          "mean_recall": round(result.mean_recall, 4), "merged_rooms": result.merged_rooms,
          "split_rooms": result.split_rooms, "abstract_s": round(seconds, 3),
          "target": {"owned_rooms": 12, "pixel_precision": 0.85}})


def bench_worlds() -> None:
    import subprocess

    from floorplans import built_world_scores

    for world in ("lab-corridor-office", "office-building", "maze"):
        with tempfile.TemporaryDirectory() as out:
            start = time.perf_counter()
            done = subprocess.run([sys.executable, "-m", "atlas_rap", "map", "build", "--world", world, "--out", out],
                                  capture_output=True, text=True, cwd=HERE.parent)
            seconds = time.perf_counter() - start
            if done.returncode != 0:
                emit({"bench": "places-worlds", "world": world, "error": done.stderr.strip().splitlines()[-1:]})
                continue
            with np.load(Path(out) / "grid.npz") as data:
                places = int(data["places"].max())
            found = built_world_scores(out, world)
        regions = {name: {"iou": round(iou, 3), "place": place, "ok": iou >= 0.5 and place == name}
                   for name, (iou, place) in found.items()}
        emit({"bench": "places-worlds", "world": world, "places": places,
              "named_regions_with_their_place": sum(r["ok"] for r in regions.values()), "regions": len(regions),
              "build_s": round(seconds, 1), "detail": regions})


def _best(fn, runs: int) -> float:
    best = math.inf
    for _ in range(runs):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def bench_speed(cells: list[float], runs: int) -> None:
    from scipy.ndimage import distance_transform_edt
    from skimage.morphology import skeletonize

    from atlas_rap.maps.abstraction import abstract

    for target in cells:
        side = math.sqrt(target) * RESOLUTION - 2.0  # the plan has 1 m of unknown round it
        plan = generate_plan(1, furniture=True, size=(side, side))
        p, frame = plan.occupancy, plan.frame
        free = p < 0.5
        result = {}

        def ours() -> None:
            result["a"] = abstract(p, frame)

        def bare() -> None:
            skeletonize(free)
            distance_transform_edt(free)

        ours_s = bare_s = math.inf
        for _ in range(runs):  # interleaved, so that a slow moment of the machine hits both
            bare_s = min(bare_s, _best(bare, 1))
            ours_s = min(ours_s, _best(ours, 1))
        ratio = ours_s / bare_s
        target = 1.5 if p.size >= 1e6 else None
        emit({"bench": "places-speed", "cells": int(p.size), "shape": list(p.shape), "rooms": int(plan.rooms.max()),
              "places": int(result["a"].places.max()), "ours_s": round(ours_s, 3), "bare_s": round(bare_s, 3),
              "ratio": round(ratio, 3), "target": target, "ok": target is None or ratio <= target, "runs": runs})


def bench_output(runs: int) -> None:
    from atlas_rap.maps.abstraction import abstract_map
    from atlas_rap.views.map_levels import write_levels
    from atlas_rap.maps.rosmap import load_ros_map
    from atlas_rap.shipped import shipped_root

    plan = generate_plan(2, furniture=True, size=(48.0, 48.0))
    rosmap = load_ros_map(shipped_root("worlds") / "maps" / "small-office-map.yaml")
    cases = [("generated 1 M cells", plan.occupancy, plan.frame), ("small-office-map", rosmap.occupancy, rosmap.frame)]
    for name, p, frame in cases:
        with tempfile.TemporaryDirectory() as out:
            holder = {}
            alone = _best(lambda: holder.__setitem__("r", abstract_map(p, frame)), runs)
            whole = _best(lambda: write_levels(p, abstract_map(p, frame), out, title=name), runs)
        ratio = whole / alone
        emit({"bench": "places-output", "map": name, "cells": int(p.size), "abstraction_s": round(alone, 3),
              "abstract_and_write_s": round(whole, 3), "writing_s": round(whole - alone, 3),
              "ratio": round(ratio, 3), "target": 2.0, "ok": ratio <= 2.0, "runs": runs})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="10 plans, sizes up to 4 M cells, one run")
    parser.add_argument("--plans", type=int, default=50, help="generated plans to score (default 50)")
    parser.add_argument("--runs", type=int, default=3, help="timed runs per size (best is kept)")
    args = parser.parse_args()
    plans = 10 if args.quick else args.plans
    runs = 1 if args.quick else args.runs
    sizes = [0.25e6, 1e6, 4e6] if args.quick else [0.25e6, 1e6, 4e6, 16e6]
    bench_scores(plans)
    bench_real_map()
    bench_worlds()
    bench_speed(sizes, runs)
    bench_output(runs)


if __name__ == "__main__":
    main()
