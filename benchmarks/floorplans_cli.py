"""Write one generated floor plan for people to look at: the ROS map, its ground truth and a PNG preview.

Run ``python benchmarks/floorplans_cli.py --seed 3 --furniture --out DIR`` (``--hard``,
``--slam``, ``--clutter-corridors``: see ``generate_plan``); it
writes ``DIR/plan-3.yaml`` + ``.pgm`` (read it with ``atlas map abstract
DIR/plan-3.yaml --out ...``), ``plan-3-rooms.png`` / ``.json`` (the ground
truth, see ``tests/floorplans.py``) and ``plan-3-preview.png`` (each room
in its colour with its name, doors in red, furniture in brown, unknown in
grey). ``--score`` also runs the abstraction on the map and prints how its
places score against the rooms, as one JSON object.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent / "tests"), str(HERE.parent)]

from floorplans import FloorPlan, generate_plan, score, write_plan


def preview(plan: FloorPlan, out_png: Path) -> Path:
    """A picture of the plan: rooms coloured and named, walls black, doors red, furniture brown, unknown grey."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    palette = plt.get_cmap("tab20")(np.arange(20))[:, :3]
    rgb = np.ones(plan.rooms.shape + (3,))
    rgb[plan.rooms > 0] = 0.55 + 0.45 * palette[(plan.rooms[plan.rooms > 0] - 1) % 20]
    rgb[plan.occupancy == 1] = 0.0
    rgb[np.isnan(plan.occupancy)] = 0.8
    rgb[plan.furniture_cells()] = (0.55, 0.35, 0.15)
    rgb[plan.door_cells()] = (0.9, 0.1, 0.1)
    xmin, ymin, xmax, ymax = plan.frame.extent
    height, width = plan.rooms.shape
    fig, ax = plt.subplots(figsize=(max(width / 80, 6.0), height / 80 + 0.4), dpi=100)
    ax.imshow(rgb, extent=(xmin, xmax, ymin, ymax), interpolation="nearest")
    for label, name in enumerate(plan.room_names, start=1):
        rows, cols = np.nonzero(plan.rooms == label)
        if rows.size:
            inside = np.argmin((rows - rows.mean()) ** 2 + (cols - cols.mean()) ** 2)  # a cell of the room
            x, y = plan.frame.cell_to_world(rows[inside], cols[inside])
            ax.text(x, y, name, ha="center", va="center", fontsize=6)
    furnished = f", {len(plan.furniture)} pieces of furniture" if plan.furniture else ""
    hard = f", {'slam' if plan.slam else 'hard'} (turned {plan.rotation:g} deg)" if plan.hard else ""
    ax.set_title(f"seed {plan.seed}: {plan.layout} layout, {plan.n_rooms} rooms, {len(plan.doors)} doors{furnished}"
                 f"{hard}", fontsize=9)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    fig.tight_layout()
    fig.savefig(out_png)
    plt.close(fig)
    return out_png


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--furniture", action="store_true", help="add desks, tables, shelves, cabinets, pillars")
    parser.add_argument("--hard", action="store_true",
                        help="walls of their own thickness, doors anywhere, a turned building, map noise")
    parser.add_argument("--slam", action="store_true",
                        help="the hard plan as a SLAM scan: ragged and unseen walls, unexplored patches, speckle")
    parser.add_argument("--clutter-corridors", action="store_true",
                        help="benches, printers, lockers and plants along the corridors")
    parser.add_argument("--resolution", type=float, default=0.05, help="metres per cell (default 0.05)")
    parser.add_argument("--size", type=float, nargs=2, metavar=("WIDTH", "HEIGHT"),
                        help="the building's size in metres (default: drawn from the seed)")
    parser.add_argument("--out", type=Path, required=True, help="folder to write into")
    parser.add_argument("--name", help="file name stem (default plan-SEED)")
    parser.add_argument("--score", action="store_true", help="abstract the map and score its places")
    args = parser.parse_args(argv)
    plan = generate_plan(args.seed, furniture=args.furniture, hard=args.hard, slam=args.slam,
                         clutter_corridors=args.clutter_corridors, resolution=args.resolution,
                         size=tuple(args.size) if args.size else None)
    name = args.name or f"plan-{args.seed}"
    yaml = write_plan(plan, args.out, name)
    png = preview(plan, args.out / f"{name}-preview.png")
    print(f"{yaml}\n{png}")
    if args.score:
        from atlas_rap.maps.abstraction import abstract

        result = abstract(plan.occupancy, plan.frame)
        print(json.dumps({k: v for k, v in score(result.places, plan.rooms).to_dict().items() if k != "rooms"}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
