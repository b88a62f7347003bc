"""The seed's skill-acquisition experiment (seed 000 §5.2, Figs. 12 and 13), as one call.

A robot with no prior map drives from its lab to the office and back,
run after run, the occupancy grid carried from each run to the next
(exactly ``atlas run errand.rap --no-prior-map --map-in/--map-out``). Per
run it records the map quality at the end (1 - mean entropy over the area
the errand needs, fixed before the first run: :mod:`atlas_rap.maps.errand_area`,
so the quality rises only as the map of that area firms up), the map's agreement with the
true walls on the cells it labels (:mod:`atlas_rap.maps.agreement`), the
pose error of the robot's belief, the run's duration in simulated
seconds, the length of the path it drove and that path's time at top
speed (so the figures show how much of a run's time is the way it took and
how much its stops, or a rules file's ``mapping-speed`` cap), and how long each
layer was primary. Layer IV maps and drives
while the map is poor; once the rules find it good enough, mapping stops and
Layer II follows the route, and the runs get close to the optimal time: the
shortest collision-free route on the true map at the robot's top speed.

Then the obstacle scenario (Fig. 13b), three cases, each its own errand
on the map of the last run (:data:`OBSTACLE_CASES`), each with its
obstacles on the way the robot takes: a person crosses the corridor
(short-lived: Layer I stops the robot, Layer II goes on); a box blocks one
way (long-lived: Layer III re-routes on its topology and hands back to II);
a block cuts every way the robot knows (Layer IV remaps and finds a way
through a workshop it has never mapped, then II follows it). Each case
says the layers that were primary in turn (``"seen"``) beside the order
the seed's §5.2 describes (``"expected"``).

:func:`skill_acquisition` returns the ``figures.json`` structure
(:mod:`atlas_rap.views.figures` draws it); :func:`write_results` writes it
with the CSV of the runs and the figures. Ctrl-C stops the whole
experiment; what it has is returned marked incomplete (``"complete":
false``), and the figures say so.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from atlas_rap.layers.engine import MissionEngine
from atlas_rap.layers.system import RunOptions
from atlas_rap.layers.layer import LayerStack, timeline_spans
from atlas_rap.views.figures import (
    FIGURE_FILES,
    plot_durations,
    plot_map_quality,
    plot_obstacle_layers,
    plot_run_layers,
)
from atlas_rap.maps.agreement import map_agreement
from atlas_rap.model import OdometryNoise, World
from atlas_rap.outputs import atomic_write, write_text
from atlas_rap.views.pose_error import pose_errors
from atlas_rap.shipped import shipped_root

ERRAND = """;;; The seed's errand: from the lab to the office, and back (atlas experiment skill-acquisition).
(include "{navigation}")
(define-rap (errand)
  (method
    (task-net
      (sequence
        (t1 (go-to {goal}))
        (t2 (go-to {home}))))))
(post (errand))
"""

CASES_BUILDING = "lab-corridor-office"
"""The building the obstacle cases' worlds are variants of: the runs' world must be it, with its own
odometry noise if it likes (the cases then take that noise: :func:`case_world`)."""

PERSON_WORLD = "lab-corridor-office-person"
"""Fig. 13(b), short-lived: a person crosses the corridor just past the lab door as the robot comes."""

CORRIDOR_BOX_WORLD = "lab-corridor-office-corridor-box"
"""Fig. 13(b), one way blocked: a box fills the corridor on the way by the office door; the way
through the storeroom is open."""

STOREROOM_BOX_WORLD = "lab-corridor-office-storeroom-box"
"""Fig. 13(b), one way blocked, for a robot whose way goes through the storeroom: a box in the
storeroom's doorway; the way by the office door is open."""

FULL_BLOCK_WORLD = "lab-corridor-office-full-block"
"""Fig. 13(b), every known way cut: a block across the corridor past the lab door, and a way round
through a workshop the robot has never mapped."""


@dataclass(frozen=True)
class ObstacleCase:
    """One case of the obstacle scenario (Fig. 13b): an errand in ``world`` on the last run's map.

    ``expected`` is the order of primary layers the seed (000 §5.2) describes for it, with the
    stop of Layer I, which acts first on anything in the robot's way, before the layer that deals
    with what stays (whether it stays is known only after ``long-lived-after`` seconds).
    ``detours`` puts the obstacles on the way the robot takes: ``(place, world)`` pairs, the
    world of the first place the last run passed through on its way to the goal, else ``world``.
    """

    key: str
    title: str
    expected: tuple[str, ...]
    world: str
    detours: tuple[tuple[str, str], ...] = ()

    def world_for(self, places: list[str], goal: str) -> str:
        """The world of this case for a robot whose last run passed ``places`` in turn."""
        outward = places[:places.index(goal)] if goal in places else places
        return next((world for place, world in self.detours if place in outward), self.world)


OBSTACLE_CASES = (
    ObstacleCase("person", "a person crosses: Layer I stops the robot, Layer II resumes",
                 ("II", "I", "II"), PERSON_WORLD),
    ObstacleCase("corridor-box", "a box blocks one way: Layer III re-routes, Layer II resumes",
                 ("II", "I", "III", "II"), CORRIDOR_BOX_WORLD, (("storeroom", STOREROOM_BOX_WORLD),)),
    ObstacleCase("full-block", "a block cuts every known way: Layer IV remaps, Layer II resumes",
                 ("II", "I", "IV", "II"), FULL_BLOCK_WORLD),
)
"""The cases of the obstacle scenario, in the order they run."""

OBSTACLE_CASE_KEYS = tuple(case.key for case in OBSTACLE_CASES)

RUN_LIMIT = 900.0
"""Simulated seconds one run may take."""

RESULT_FILES = ("errand.rap", "figures.json", "runs.csv", "map-run*.npz", "world-*.yaml",
                *(f"map-{key}.npz" for key in OBSTACLE_CASE_KEYS), *FIGURE_FILES.values())
"""The files the experiment writes in its folder (glob patterns)."""


@dataclass(frozen=True)
class Settings:
    """What the experiment runs: ``runs`` errands in ``world`` from ``home`` to ``goal`` and back.
    ``localisation`` is how the robot knows where it is (:class:`~atlas_rap.layers.system.RunOptions`):
    ``mcl``, its odometry corrected against the map it builds and carries, or ``odometry``, dead
    reckoning alone, to compare. ``obstacles``: the keys of the :data:`OBSTACLE_CASES` to run
    after the runs (None: none)."""

    world: str = "lab-corridor-office"
    runs: int = 7
    seed: int = 0
    home: str = "lab"
    goal: str = "office"
    obstacles: tuple[str, ...] | None = OBSTACLE_CASE_KEYS
    layer_rules: str | None = None
    localisation: str = "mcl"


def errand_file(out: Path, settings: Settings) -> Path:
    """The mission of every run, written into ``out``."""
    navigation = shipped_root("rap_library") / "navigation.rap"
    return write_text(out / "errand.rap",
                      ERRAND.format(navigation=navigation.as_posix(), goal=settings.goal, home=settings.home))


def optimal_seconds(world_name: str, home: str, goal: str) -> float:
    """The errand at top speed along the shortest collision-free routes on the true map."""
    from atlas_rap.maps.gridpath import shortest_route_length
    from atlas_rap.sim.world import load_world

    world = load_world(world_name)
    start = world.robot.start[:2]
    there = shortest_route_length(world, start, world.places[goal].point)
    back = shortest_route_length(world, world.places[goal].point, world.places[home].point)
    return (there + back) / world.robot.max_speed


def one_run(mission: Path, world: str, seed: int, map_in: Path | None, map_out: Path,
            layer_rules: str | None, localisation: str = "mcl",
            errand: tuple[str, ...] = ()) -> tuple[dict[str, Any], LayerStack]:
    """One errand with no prior map, from ``map_in``: its figures (the grid written to
    ``map_out``), and the layer stack it ran with (for its settings). ``errand``: the places
    it visits, whose area Layer IV measures the map over. Ctrl-C: the grid it has is
    written, then KeyboardInterrupt goes on up (the whole experiment stops)."""
    engine = MissionEngine(RunOptions(world=world, seed=seed, prior_map=False, map_in=map_in,
                                       layer_rules=layer_rules, localisation=localisation, errand=errand))
    engine.load_file(mission, require_post=True)
    try:
        result = engine.run_mission(RUN_LIMIT)
    finally:
        engine.save_map(map_out)
    if result.ended_by == "interrupted":
        raise KeyboardInterrupt
    stack = engine.stack
    timeline = stack.timeline_records()
    errors = pose_errors(engine.system)
    path = _path_length(engine)
    return {"ok": result.ok, "ended_by": result.ended_by, "map_quality": stack.layers["IV"].quality(),
            "map_agreement": round(map_agreement(engine.grid, engine.world.walls).share, 4),
            "pose_rmse_m": round(errors.rmse, 3) if errors is not None else 0.0,
            "duration_s": round(result.time, 2), "timeline": timeline, "start_s": 0.0, "end_s": round(result.time, 2),
            "primary_s": {k: round(v, 2) for k, v in stack.primary_seconds(result.time).items()},
            "places": _places_passed(engine),
            "path_m": round(path, 2), "path_at_top_speed_s": round(path / engine.world.robot.max_speed, 2)}, stack


def skill_acquisition(out: str | Path, settings: Settings = Settings(),
                      progress: Callable[[str], None] | None = None,
                      finished: Callable[[dict[str, Any]], None] | None = None) -> dict[str, Any]:
    """Run the experiment (see the module docstring); the ``figures.json`` structure.

    ``progress`` is told what starts (``"run 2 of 7"``), ``finished`` is given each
    run's figures as it ends. Ctrl-C stops the whole experiment: the runs that ended
    are returned with ``"complete": false`` and ``"incomplete"`` saying where it
    stopped (``"interrupted after run 3 of 7"``); the run it stopped is left out.
    """
    noise = check_worlds(settings).robot.odometry_noise
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    mission = errand_file(out, settings)
    optimal = round(optimal_seconds(settings.world, settings.home, settings.goal), 2)
    runs: list[dict[str, Any]] = []
    data: dict[str, Any] = {"world": settings.world, "seed": settings.seed, "localisation": settings.localisation,
                            "threshold": 0.9, "runs": runs, "runs_asked": settings.runs, "complete": True}
    map_in: Path | None = None
    during = ""
    try:
        for number in range(1, settings.runs + 1):
            if progress is not None:
                progress(f"run {number} of {settings.runs}")
            map_out = out / f"map-run{number}.npz"
            run, stack = one_run(mission, settings.world, settings.seed, map_in, map_out, settings.layer_rules,
                                 settings.localisation, (settings.goal, settings.home))
            runs.append({"run": number, **run, "optimal_s": optimal})
            data["threshold"] = stack.setting("map-quality-threshold", 0.9)  # the rules file's, as the runs used it
            map_in = map_out
            if finished is not None:
                finished(runs[-1])
        places = runs[-1]["places"] if runs else []
        for case in _cases(settings.obstacles):
            during = f" in the obstacle scenario ({case.key})"
            if progress is not None:
                progress(f"obstacles: {case.key}")
            cases = data.setdefault("obstacles", [])
            cases.append(obstacle_case(mission, settings, case, places, map_in, out, optimal, noise))
    except KeyboardInterrupt:
        data["complete"] = False
        data["incomplete"] = f"interrupted{during} after run {len(runs)} of {settings.runs}"
    return data


def obstacle_case(mission: Path, settings: Settings, case: ObstacleCase, places: list[str],
                  map_in: Path | None, out: Path, optimal: float, noise: OdometryNoise) -> dict[str, Any]:
    """One case of the obstacle scenario: the errand once more, on the map the runs built, in the
    case's world for a robot that went by ``places`` (:meth:`ObstacleCase.world_for`), with the runs'
    odometry ``noise`` (:func:`case_world`); its figures
    as :func:`one_run`'s, with the case, its title, the world, the events, the layers the seed
    orders (``expected``) and those seen (``seen``), and whether they are the same."""
    from atlas_rap.sim.world import load_world

    name = case.world_for(places, settings.goal)
    world = load_world(name)
    run, _ = one_run(mission, case_world(out, settings, name, world, noise), settings.seed, map_in,
                     out / f"map-{case.key}.npz", settings.layer_rules, settings.localisation,
                     (settings.goal, settings.home))
    events = [{"t": d.start, "what": f"{'a person starts to cross' if d.kind == 'person' else 'a box is put down'}"
                                    f" ({d.name})"} for d in world.disturbances]
    seen = layer_order(run)
    return {"case": case.key, "title": case.title, "world": name, "expected": list(case.expected), "seen": seen,
            "as_expected": seen == list(case.expected), **run, "optimal_s": optimal, "events": events}


def case_world(out: Path, settings: Settings, name: str, world: World, noise: OdometryNoise) -> str:
    """The world an obstacle case runs in: the case's world ``name`` (read: ``world``) as shipped;
    or, when the runs' world gives the robot other odometry ``noise``
    (``tests/worlds/lab-corridor-office-exact.yaml``), a variant of it with that noise, written into
    ``out`` as ``world-NAME.yaml`` (its path), so the case's robot errs as the runs' robot did."""
    from atlas_rap.sim.world import world_path

    if noise == world.robot.odometry_noise:
        return name
    alphas = "off" if noise.off else "{" + ", ".join(
        f"alpha{i}: {getattr(noise, f'alpha{i}')!r}" for i in range(1, 5)) + "}"
    return str(write_text(out / f"world-{name}.yaml",
                          f"# {name} with the odometry of the runs' world, {settings.world} (atlas experiment)\n"
                          f"base: {json.dumps(world_path(name).resolve().as_posix())}\n"
                          f"name: {name}\nrobot: {{odometry_noise: {alphas}}}\n"))


def layer_order(run: Mapping[str, Any]) -> list[str]:
    """The layers primary in turn over a run or an obstacle case (``["II", "I", "II"]``): its
    timeline's spans, a layer primary for no time left out and one primary twice in a row named once."""
    length = float(run["end_s"]) - float(run.get("start_s") or 0.0)
    return [layer for layer, _, _ in timeline_spans(run.get("timeline") or [], length)]


def write_tables(data: Mapping[str, Any], out: Path, header: Sequence[str], rows: Iterable[Sequence[Any]]) -> list[Path]:
    """``figures.json`` (``data``) and ``runs.csv`` (``header``, then ``rows``) into ``out``, each
    written whole; their paths."""
    out.mkdir(parents=True, exist_ok=True)
    written = [out / "figures.json", out / "runs.csv"]
    write_text(written[0], json.dumps(data, indent=1) + "\n")
    with atomic_write(written[1], text=True, newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(header)
        writer.writerows(rows)
    return written


def write_results(data: dict[str, Any], out: str | Path) -> list[Path]:
    """``figures.json``, ``runs.csv`` and the four figures (three without the obstacle scenario),
    into ``out``, each written whole; the paths written. Results marked incomplete say so on
    every figure."""
    out = Path(out)
    written = write_tables(data, out, RUNS_CSV_COLUMNS, (runs_csv_row(run) for run in data["runs"]))
    written.append(plot_map_quality(data, out / FIGURE_FILES["map_quality"]))
    written.append(plot_durations(data, out / FIGURE_FILES["durations"]))
    written.append(plot_run_layers(data, out / FIGURE_FILES["run_layers"]))
    if data.get("obstacles"):
        written.append(plot_obstacle_layers(data, out / FIGURE_FILES["obstacle_layers"]))
    return written


RUNS_CSV_COLUMNS = ("run", "map_quality", "map_agreement", "pose_rmse_m", "duration_s", "optimal_s",
                    "primary_I_s", "primary_II_s", "primary_III_s", "primary_IV_s", "ok")
"""The columns of ``runs.csv``, one row a run (the multi-seed form puts a seed column first)."""


def runs_csv_row(run: dict[str, Any]) -> list[Any]:
    """One run's row of ``runs.csv``, in the order of :data:`RUNS_CSV_COLUMNS`."""
    p = run["primary_s"]
    return [run["run"], run["map_quality"], run["map_agreement"], run["pose_rmse_m"],
            run["duration_s"], run["optimal_s"], p["I"], p["II"], p["III"], p["IV"], run["ok"]]


def _cases(keys: tuple[str, ...] | None) -> list[ObstacleCase]:
    """The obstacle cases of ``keys``, in the order of :data:`OBSTACLE_CASES` (a RunError names an
    unknown one)."""
    from atlas_rap.errors import RunError

    keys = tuple(keys or ())
    unknown = [key for key in keys if key not in OBSTACLE_CASE_KEYS]
    if unknown:
        raise RunError(f"no obstacle case {', '.join(unknown)}: the cases are {', '.join(OBSTACLE_CASE_KEYS)}")
    return [case for case in OBSTACLE_CASES if case.key in keys]


def check_worlds(settings: Settings) -> World:
    """The worlds of the runs and of the obstacle cases exist and have the errand's places (a RunError
    that says which is missing); the obstacle cases are known, and when there are any, the runs'
    world is :data:`CASES_BUILDING` but perhaps for its odometry noise (a RunError says what differs).
    The runs' world, as read."""
    from atlas_rap.errors import RunError
    from atlas_rap.sim.world import load_world

    names = [settings.world]
    cases = _cases(settings.obstacles)
    for case in cases:
        names += [case.world, *(world for _, world in case.detours)]
    worlds = []
    for name in names:
        if name == "none":
            raise RunError("the experiment needs a world to drive in, not 'none'")
        world = load_world(name)
        missing = [place for place in (settings.home, settings.goal) if place not in world.places]
        if missing:
            raise RunError(f"world {world.name} has no place named {' or '.join(missing)}: the errand goes "
                             f"from {settings.home} to {settings.goal} and back "
                             f"(its places: {', '.join(world.places) or 'none'})")
        worlds.append(world)
    if cases:
        runs, building = worlds[0], load_world(CASES_BUILDING)
        differ = [what for what, a, b in (
            ("walls", runs.walls, building.walls), ("places", runs.places, building.places),
            ("doors", runs.doors, building.doors), ("sonar", runs.sonar, building.sonar),
            ("robot", replace(runs.robot, odometry_noise=building.robot.odometry_noise), building.robot)) if a != b]
        if differ:
            raise RunError(f"the obstacle scenario puts its person, box and block in {CASES_BUILDING}'s corridor, "
                           f"and world {settings.world} is not that building as shipped (it differs in its "
                           f"{', '.join(differ)}): run it with --obstacles none")
    return worlds[0]


def _places_passed(engine: MissionEngine) -> list[str]:
    """The world's places the robot's true path went through, in turn (``["lab", "corridor",
    "office", ...]``), each named once for each time the robot was in it."""
    world, places = engine.world, []
    for _, x, y, _ in engine.simulation.path:
        place = world.place_at(x, y)
        if place is not None and (not places or places[-1] != place):
            places.append(place)
    return places


def _path_length(engine: MissionEngine) -> float:
    path = [(x, y) for _, x, y, _ in engine.simulation.path]
    return sum(math.dist(a, b) for a, b in zip(path, path[1:]))
