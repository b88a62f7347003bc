"""Score the room segmentation (``abstract(...).places``) on generated floor plans, hard ones by default.

Run ``python benchmarks/score_plans.py`` (seeds 0-29, hard plans clean and
furnished); ``--seeds A B`` scores seeds A..B-1, ``--variants`` picks among
``plain``, ``furnished``, ``hard``, ``hard-furnished``,
``hard-cluttered`` (hard, furnished, furniture in the corridors too).
It prints, per variant, the totals (rooms owned by a place of their own,
pixel precision, merged and split rooms) and every seed whose
``owned_fraction`` is below ``--below`` (0.95) with what went wrong:
which rooms were merged (and the doors between them: width, in a corner,
the wall's depth there) or split (kind, area, furniture in it), and how
far the building was turned; and, over all plans, how many merges had a
double, corner or narrow door between the rooms, how many splits were in
turned plans or furnished rooms. ``--json FILE`` writes the numbers per
plan.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent / "tests"), str(HERE.parent)]

from floorplans import FloorPlan, generate_plan, score

VARIANTS = {
    "plain": {},
    "furnished": {"furniture": True},
    "hard": {"hard": True},
    "hard-furnished": {"hard": True, "furniture": True},
    "hard-cluttered": {"hard": True, "furniture": True, "clutter_corridors": True},
}


def overlaps(places: np.ndarray, rooms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(n[r, p] pixels of room r in place p, |r|), rooms 1..R and places 0..P as they come."""
    top = int(places.max())
    counts = np.bincount(rooms.ravel().astype(np.int64) * (top + 1) + places.ravel(),
                         minlength=(int(rooms.max()) + 1) * (top + 1)).reshape(-1, top + 1)
    return counts, counts.sum(axis=1)


def door_note(plan: FloorPlan, door: Any) -> str:
    """A door in a few words: width, corner, double or narrow, the wall's depth (gap cells / width)."""
    r0, r1, c0, c1 = door.box
    cells = int(plan.door_cells()[r0:r1, c0:c1].sum())
    depth = cells * plan.frame.resolution ** 2 / door.width
    kind = " double" if door.width >= 1.3 else (" narrow" if door.width <= 0.65 else "")
    return f"{door.width:.2f} m{kind}{' corner' if door.corner else ''} door, wall {depth:.2f} m"


def diagnose(plan: FloorPlan, places: np.ndarray, tally: dict[str, int]) -> list[str]:
    """What went wrong: merged rooms (by the place that holds them), split rooms, other rooms not owned.

    ``tally`` counts the merges by the doors between the merged rooms (any
    double, corner or narrow one) and the split rooms by whether the plan
    was turned and the room furnished.
    """
    counts, size = overlaps(places, plan.rooms)
    notes = []
    holder: dict[int, list[int]] = {}
    for room in range(1, plan.n_rooms + 1):
        held = np.flatnonzero(counts[room, 1:] > 0.5 * size[room])
        if held.size:
            holder.setdefault(int(held[0]) + 1, []).append(room)
    names = plan.room_names
    for group in (g for g in holder.values() if len(g) >= 2):
        doors = [d for d in plan.doors if d.rooms[0] in group and d.rooms[1] in group]
        via = "; ".join(door_note(plan, d) for d in doors) or "no door between them"
        notes.append(f"merged {' + '.join(names[r - 1] for r in group)} ({via})")
        tally["merges"] += 1
        tally["merges through a double door"] += any(d.width >= 1.3 for d in doors)
        tally["merges through a corner door"] += any(d.corner for d in doors)
        tally["merges through a narrow door"] += any(d.width <= 0.65 for d in doors)
        tally["merges with no double door"] += not any(d.width >= 1.3 for d in doors)
    furniture = np.bincount([f.room for f in plan.furniture], minlength=plan.n_rooms + 1)
    specks = np.bincount([int(plan.rooms[b[0] - 1, b[2]]) for b in plan.specks], minlength=plan.n_rooms + 1)
    areas = plan.room_areas()
    merged = {r for g in holder.values() if len(g) >= 2 for r in g}
    place_size = counts[1:].sum(axis=0)
    for room in range(1, plan.n_rooms + 1):
        parts = np.flatnonzero(counts[room, 1:] >= 0.2 * size[room])
        if parts.size >= 2:
            extra = f", {furniture[room]} pieces of furniture" if furniture[room] else ""
            extra += f", {specks[room]} specks near" if specks[room] else ""
            notes.append(f"split {names[room - 1]} in {parts.size} ({areas[room - 1]:.0f} m2{extra})")
            tally["splits"] += 1
            tally[f"splits in {'turned' if plan.rotation else 'straight'} plans"] += 1
            tally[f"splits of {'furnished' if furniture[room] else 'empty'} rooms"] += 1
        elif room not in merged:
            iou = counts[room, 1:] / np.maximum(size[room] + place_size[1:] - counts[room, 1:], 1)
            if iou.max(initial=0) < 0.5:
                shares = np.sort(counts[room, 1:] / size[room])[::-1]
                notes.append(f"not owned {names[room - 1]} ({areas[room - 1]:.0f} m2): in "
                             f"{int(np.count_nonzero(shares >= 0.05))} places of 5 % or more, the largest "
                             f"{shares[0]:.0%} (IoU {iou.max():.2f})")
                tally["other rooms not owned"] += 1
    return notes


def run(seeds: range, variants: list[str], below: float) -> dict[str, Any]:
    from collections import Counter

    from atlas_rap.maps.abstraction import abstract

    results: dict[str, Any] = {}
    for variant in variants:
        rows, tally = [], Counter()
        for seed in seeds:
            plan = generate_plan(seed, **VARIANTS[variant])
            start = time.perf_counter()
            places = abstract(plan.occupancy, plan.frame).places
            seconds = time.perf_counter() - start
            result = score(places, plan.rooms)
            rows.append({"seed": seed, "rotation": plan.rotation, "rooms": result.n_rooms,
                         "owned": result.owned_rooms, "owned_fraction": result.owned_fraction,
                         "pixel_precision": result.pixel_precision, "merged": result.merged_rooms,
                         "split": result.split_rooms, "seconds": round(seconds, 3),
                         "notes": diagnose(plan, places, tally)})
        rooms = sum(r["rooms"] for r in rows)
        results[variant] = {
            "plans": len(rows), "rooms": rooms, "owned": sum(r["owned"] for r in rows),
            "owned_fraction": sum(r["owned"] for r in rows) / rooms,
            "mean_owned_fraction": float(np.mean([r["owned_fraction"] for r in rows])),
            "mean_pixel_precision": float(np.mean([r["pixel_precision"] for r in rows])),
            "merged": sum(r["merged"] for r in rows), "split": sum(r["split"] for r in rows),
            "below": sum(r["owned_fraction"] < below for r in rows), "causes": dict(sorted(tally.items())),
            "per_plan": rows}
    return results


def report(results: dict[str, Any], below: float) -> str:
    head = (f"{'variant':<16}{'plans':>6}{'rooms':>7}{'owned':>7}{'owned%':>8}{'mean px-prec':>14}"
            f"{'merged':>8}{'split':>7}{f'  <{below:g}':>7}")
    lines = [head]
    for variant, total in results.items():
        lines.append(f"{variant:<16}{total['plans']:>6}{total['rooms']:>7}{total['owned']:>7}"
                     f"{100 * total['owned_fraction']:>7.1f}%{total['mean_pixel_precision']:>14.3f}"
                     f"{total['merged']:>8}{total['split']:>7}{total['below']:>7}")
    for variant, total in results.items():
        causes = ", ".join(f"{k} {v}" for k, v in total["causes"].items())
        lines.append(f"  {variant}: {causes or 'nothing wrong'}")
    for variant, total in results.items():
        worst = sorted((r for r in total["per_plan"] if r["owned_fraction"] < below),
                       key=lambda r: r["owned_fraction"])
        if not worst:
            continue
        lines.append(f"\n{variant}: plans with owned_fraction < {below:g}")
        for r in worst:
            lines.append(f"  seed {r['seed']:>3} turned {r['rotation']:>5.1f} deg: owned {r['owned']}/{r['rooms']} "
                         f"({r['owned_fraction']:.2f}), pixel precision {r['pixel_precision']:.3f}, "
                         f"merged {r['merged']}, split {r['split']}")
            lines.extend(f"      {note}" for note in r["notes"])
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, nargs=2, default=(0, 30), metavar=("FIRST", "STOP"))
    parser.add_argument("--variants", nargs="+", choices=list(VARIANTS), default=["hard", "hard-furnished"])
    parser.add_argument("--below", type=float, default=0.95, help="report plans with owned_fraction below this")
    parser.add_argument("--json", type=Path, help="write the numbers per plan here")
    args = parser.parse_args(argv)
    results = run(range(*args.seeds), args.variants, args.below)
    print(report(results, args.below))
    if args.json:
        args.json.write_text(json.dumps(results, indent=1) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
