"""The ATLAS layers: a primary layer chosen by rules, mapping while driving, the seed's experiment.

The experiment (seed 000 §5.2) runs once for the module, seed 0, with exact
odometry: five errands lab → office → lab with no prior map, the grid
carried from run to run; the blocked-world run starts from its last map.
The obstacle scenario (Fig. 13b) runs as the experiment ships it, at the
default odometry noise, on a few seeds (:data:`OBSTACLE_SEEDS`).
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from atlas_rap.layers import MissionEngine, RunOptions
from atlas_rap.layers.tactical import LOOK_EVERY, TacticalLayer
from atlas_rap.maps.grid import OccupancyGrid
from atlas_rap.views.experiment import (
    CORRIDOR_BOX_WORLD,
    FULL_BLOCK_WORLD,
    OBSTACLE_CASES,
    PERSON_WORLD,
    STOREROOM_BOX_WORLD,
    Settings,
    errand_file,
    skill_acquisition,
)
from atlas_rap.views.experiment_seeds import skill_acquisition_seeds
from atlas_rap.sequencer import Trace
from atlas_rap.shipped import shipped_root
from atlas_rap.skills.beliefs import BUMP, GRID, POSE, POSE_TRACK, Belief, Beliefs, PlannedRoute

REPO = Path(__file__).resolve().parents[1]
RULES = shipped_root("rap_library") / "layers.rap"
# The layers' mechanism (Figs. 12 and 13) is tested with exact odometry, so that what it checks does not
# hang on how well the pose is corrected while mapping (docs/how-to/localise.md); the experiment at
# the default noise is tested on its own below and in test_mapping_correction.py.
EXACT = str(REPO / "tests" / "worlds" / "lab-corridor-office-exact.yaml")


@pytest.fixture(scope="module")
def experiment(tmp_path_factory):
    out = tmp_path_factory.mktemp("skill-acquisition")
    data = skill_acquisition(out, Settings(world=EXACT, runs=5, obstacles=None))
    return out, data


def traced_run(world: str, out: Path, map_in: Path | None, seed: int = 0, **options):
    """The errand once in ``world`` with no prior map: (engine, result, trace records)."""
    records: list[dict] = []
    trace = Trace()
    trace.add_sink(lambda record: records.append(record))
    engine = MissionEngine(RunOptions(world=world, seed=seed, prior_map=False, map_in=map_in, **options), trace=trace)
    engine.load_file(errand_file(out, Settings()), require_post=True)
    result = engine.run_mission(900)
    return engine, result, records


def capped_rules(out: Path) -> Path:
    """A copy of the shipped layer rules in ``out`` that caps the speed while Layer IV maps at 0.6 of
    top speed (``mapping-speed``; the shipped rules set no cap)."""
    rules = out / "capped-layers.rap"
    text = (shipped_root("rap_library") / "layers.rap").read_text(encoding="utf-8")
    rules.write_text(text + "(initial-memory (layer-setting mapping-speed 0.6))\n", encoding="utf-8")
    return rules


def switches(records: list[dict]) -> list[dict]:
    return [r for r in records if r["event"] == "layer-switched"]


def asserted(records: list[dict], prefix: str) -> list[dict]:
    return [r for r in records if r["event"] == "fact-asserted" and r["fact"].startswith(prefix)]


# -- skill acquisition (Figs. 12 and 13a) ---------------------------------------------------------


def test_map_quality_rises_run_over_run_and_crosses_the_threshold_within_five_runs(experiment):
    _, data = experiment
    qualities = [run["map_quality"] for run in data["runs"]]
    assert qualities[0] > 0.6  # one errand maps the way there and back
    for before, run in zip(qualities, data["runs"][1:]):
        if run["primary_s"]["IV"] > 0:  # a run that maps improves the map
            assert run["map_quality"] > before, qualities
        else:  # mapping is over: the map stays as it is
            assert run["map_quality"] == before, qualities
    assert max(qualities[:5]) >= data["threshold"] == 0.9, qualities
    first = data["runs"][0]
    assert first["timeline"][0]["layer"] == "IV" and "map-immature" in first["timeline"][0]["reason"]
    assert first["primary_s"]["IV"] > 0.5 * first["duration_s"]  # run 1 explores and maps, mostly


def test_once_the_map_is_good_layer_ii_drives_and_the_runs_near_the_optimal_time(experiment):
    _, data = experiment
    runs = data["runs"]
    mature = [run for before, run in zip(runs, runs[1:]) if before["map_quality"] >= data["threshold"]]
    assert mature, [run["map_quality"] for run in runs]
    for run in mature:
        assert run["ok"]
        assert run["primary_s"]["II"] > 0.95 * run["duration_s"], run["primary_s"]
        assert run["duration_s"] <= 1.25 * run["optimal_s"], (run["duration_s"], run["optimal_s"])
    # shorter than the runs before the switch that went to look where the survey was unsure: what the
    # switch saves is the exploring (the first run only finds the way, at top speed, and takes about
    # as long as Layer II's route)
    explored = [run["duration_s"] for run in runs[1:] if run["primary_s"]["IV"] > 0.5 * run["duration_s"]]
    durations = [run["duration_s"] for run in runs]
    assert explored and mature[-1]["duration_s"] < min(explored), durations


def test_every_run_reaches_the_office_and_comes_back(experiment):
    _, data = experiment
    assert all(run["ok"] and run["ended_by"] == "done" for run in data["runs"])


def test_the_optimal_time_is_the_shortest_route_there_and_back_at_top_speed(experiment):
    _, data = experiment
    optimal = data["runs"][0]["optimal_s"]
    straight = (math.dist((1.5, 1.5), (16.5, 8)) + math.dist((16.5, 8), (4, 2))) / 0.6
    assert straight < optimal < 1.3 * straight


# -- obstacles (Fig. 13b) -------------------------------------------------------------------------


# The seeds the obstacle scenario is checked on, as the experiment ships (the default odometry noise, the
# pose corrected against the map being built). The scenario stands on a map good enough for Layer II to
# drive the errand (seed §5.2, Fig. 13b starts in Layer II). Every seed of 0-19 gets there within the seven
# runs (docs/benchmarks.md); three are checked here for time, and seed 4's way goes through the storeroom
# (so its box stands in the storeroom's doorway).
OBSTACLE_SEEDS = (0, 2, 4)


@pytest.fixture(scope="module")
def obstacle_experiment(tmp_path_factory):
    """The experiment as it ships on :data:`OBSTACLE_SEEDS`: seven runs, then the three obstacle cases."""
    out = tmp_path_factory.mktemp("obstacles")
    return out, skill_acquisition_seeds(out, Settings(), OBSTACLE_SEEDS, jobs=2)


def case_table(data: dict) -> str:
    """A line per seed and case: the layers seen against the seed's, for a failure's message."""
    return "\n".join(f"seed {one['seed']} {case['case']:13} {case['world']:35} seen {' → '.join(case['seen']):22}"
                     f" the seed {' → '.join(case['expected'])}, errand {'ok' if case['ok'] else 'failed'}"
                     for one in data["per_seed"] for case in one.get("obstacles", []))


HANDOVER = {"person": ("I", "II"), "corridor-box": ("III", "II"), "full-block": ("IV", "II")}
"""The handover each case shows in the seed's Fig. 13b (issue 28): the layer that deals with it, then II."""


def test_every_obstacle_case_shows_the_seeds_handover_of_layers_and_the_errand_gets_there(obstacle_experiment):
    _, data = obstacle_experiment
    print(case_table(data))
    assert [one["seed"] for one in data["per_seed"]] == list(OBSTACLE_SEEDS)
    for one in data["per_seed"]:
        last = one["runs"][-1]
        assert last["primary_s"]["II"] > 0.95 * last["duration_s"], (one["seed"], "the map is not good yet")
        cases = one["obstacles"]
        assert [case["case"] for case in cases] == [case.key for case in OBSTACLE_CASES]
        for case in cases:
            seen, handover = case["seen"], HANDOVER[case["case"]]
            assert seen[0] == seen[-1] == "II" and seen[1] == "I", (one["seed"], case["case"])
            # the case's layer hands back to II; the robot may meet something once more after that
            # (the seed's exact order, case["as_expected"], is counted over seeds 0-39 in docs/benchmarks.md)
            assert handover in set(zip(seen, seen[1:])), (one["seed"], case["case"])
            assert case["ok"] and case["ended_by"] == "done", (one["seed"], case["case"])
    by_case = {case.key: list(case.expected) for case in OBSTACLE_CASES}
    assert by_case == {"person": ["II", "I", "II"], "corridor-box": ["II", "I", "III", "II"],
                       "full-block": ["II", "I", "IV", "II"]}


def test_the_box_of_one_way_stands_on_the_way_the_robot_takes(obstacle_experiment):
    _, data = obstacle_experiment
    for one in data["per_seed"]:
        places = one["runs"][-1]["places"]
        outward = places[:places.index("office")]
        box = next(case for case in one["obstacles"] if case["case"] == "corridor-box")
        assert box["world"] == (STOREROOM_BOX_WORLD if "storeroom" in outward else CORRIDOR_BOX_WORLD), places
        assert [case["world"] for case in one["obstacles"] if case["case"] != "corridor-box"] == \
            [PERSON_WORLD, FULL_BLOCK_WORLD]


@pytest.fixture(scope="module")
def traced_cases(obstacle_experiment):
    """Each case again on seed 0's last map, traced: {case: (engine, result, records)}."""
    out, data = obstacle_experiment
    seed = data["per_seed"][0]
    last = out / "seed-0" / f"map-run{len(seed['runs'])}.npz"
    return {case["case"]: traced_run(case["world"], out, last, errand=("office", "lab")) for case in seed["obstacles"]}


def test_a_person_crossing_is_handled_by_layer_i_with_no_re_route(traced_cases):
    _, result, records = traced_cases["person"]
    steps = switches(records)
    assert [s["layer"] for s in steps] == ["II", "I", "II"], steps
    assert "something-in-the-way" in steps[1]["reason"]
    assert "way-clear-map-done" in steps[2]["reason"] and "(obstacle none)" in steps[2]["reason"]  # it went
    assert steps[2]["t"] - steps[1]["t"] < 4.0  # back before it could count as long-lived
    assert not asserted(records, "(route-blocked") and not asserted(records, "(rerouted")
    assert result.ok, result


def test_a_box_blocking_one_way_makes_layer_iii_re_route_for_one_tick_and_the_robot_still_arrives(traced_cases):
    engine, result, records = traced_cases["corridor-box"]
    steps = switches(records)
    assert [s["layer"] for s in steps] == ["II", "I", "III", "II"], steps
    assert "something-in-the-way" in steps[1]["reason"]
    assert "blocked-with-a-way-round" in steps[2]["reason"] and "(way-round " in steps[2]["reason"]
    assert "found-a-way-round" in steps[3]["reason"] and "(rerouted " in steps[3]["reason"]
    assert steps[3]["t"] - steps[2]["t"] == pytest.approx(TacticalLayer.period)  # selected at its next tick
    blocked = asserted(records, "(route-blocked")
    assert blocked and blocked[0]["t"] == steps[2]["t"]
    assert not asserted(records, "(no-route)")
    assert result.ok, result
    x, y, _ = engine.simulation.pose
    assert math.dist((x, y), engine.world.places["lab"].point) < 0.5


def test_a_block_on_every_known_way_makes_layer_iv_remap_a_way_it_had_never_mapped(traced_cases, obstacle_experiment):
    engine, result, records = traced_cases["full-block"]
    steps = switches(records)
    assert [s["layer"] for s in steps] == ["II", "I", "IV", "II"], steps
    assert "every-route-cut" in steps[2]["reason"] and "(no-route)" in steps[2]["reason"]
    assert "remapped-a-way-round" in steps[3]["reason"]
    assert not asserted(records, "(way-round ")  # Layer III found no way round: it never took over
    # the way round goes through the workshop (x 8-12.5, y 1-4), which the runs' map had not mapped
    workshop = [(t, x, y) for t, x, y, _ in engine.simulation.path if 8.3 < x < 12.2 and 1.3 < y < 3.7]
    assert workshop
    out, _ = obstacle_experiment
    before = OccupancyGrid.load_npz(out / "seed-0" / "map-run7.npz")
    inside = workshop_cells(before)
    assert before.updated[inside].mean() < 0.5 < engine.grid.updated[inside].mean()
    # Layer II took over once the robot, at the office, was sent back and the rebuilt map had a way there
    arrived = [r for r in records if r["event"] == "task-succeeded" and r.get("task") == "(go-to office)"]
    assert arrived and arrived[0]["t"] <= steps[3]["t"] <= arrived[0]["t"] + LOOK_EVERY + TacticalLayer.period
    assert result.ok, result
    x, y, _ = engine.simulation.pose
    assert math.dist((x, y), engine.world.places["lab"].point) < 0.5


def workshop_cells(grid: OccupancyGrid):
    """The grid's cells in the full-block world's workshop, away from its walls."""
    rows, cols = np.indices(grid.frame.shape)
    x, y = grid.frame.cell_to_world(rows, cols)
    return (x > 8.5) & (x < 12.0) & (y > 1.5) & (y < 3.5)


def test_a_world_with_every_way_cut_ends_with_layer_iv_primary_and_says_so(experiment):
    out, data = experiment
    # the experiment's errand on its last map, measured over the errand's area as the runs were: good
    # enough for Layer II to drive, which meets the block. It must say so, not hang (the run's limit is
    # 900 s). On this map, which runs 2-4 explored, the robot dithers inside the lab door for 7 minutes
    # first (538.5 s; 415.9 s at 703ae74's code; under 120 s on the map of runs that did not explore):
    # the box filling the doorway never enters the grid, whose corridor the earlier runs drew free.
    engine, result, records = traced_run("lab-corridor-office-blocked", out, out / "map-run5.npz",
                                         errand=("office", "lab"))
    assert not result.ok and result.ended_by == "done" and result.time < 600
    assert engine.stack.primary == "IV"
    assert asserted(records, "(no-route)")
    failures = [r.get("because", "") for r in records if r["event"] == "task-failed"]
    assert any("no way to office" in reason and "every way is blocked" in reason for reason in failures)


# -- each layer can drive alone ----------------------------------------------------------------------


def bumps(records: list[dict]) -> int:
    return len(asserted(records, "(bumped robot)"))


def travelled(engine: MissionEngine) -> float:
    path = [(x, y) for _, x, y, _ in engine.simulation.path]
    return sum(math.dist(a, b) for a, b in zip(path, path[1:]))


def mission_with_layers(layers: tuple[str, ...]):
    records: list[dict] = []
    trace = Trace()
    trace.add_sink(lambda record: records.append(record))
    engine = MissionEngine(RunOptions(layers=tuple(layers)), trace=trace)
    engine.load_file(REPO / "rap_library" / "missions" / "deliver.rap")
    return engine, engine.run_mission(300), records


def test_with_only_layer_i_the_robot_heads_for_its_goal_and_never_hits_anything():
    engine, result, records = mission_with_layers(("I",))
    assert travelled(engine) > 3.0
    assert bumps(records) == 0 and not engine.simulation.bumped
    assert {s["layer"] for s in switches(records)} == {"I"}


def test_with_only_layer_ii_the_robot_follows_its_route_to_the_office_and_back():
    engine, result, records = mission_with_layers(("II",))
    assert result.ok
    assert bumps(records) == 0
    assert {s["layer"] for s in switches(records)} == {"II"}


# -- the rules are data ------------------------------------------------------------------------------


def test_a_rules_file_with_a_threshold_of_0_5_stops_mapping_in_the_first_run(tmp_path, experiment):
    _, data = experiment
    first = data["runs"][0]
    shipped_ii = [s["t"] for s in first["timeline"] if s["layer"] == "II"]
    assert not shipped_ii or shipped_ii[0] > 0.5 * first["duration_s"]  # the shipped rules map most of run 1
    rules = tmp_path / "layers.rap"
    text = RULES.read_text(encoding="utf-8")
    assert "(layer-setting map-quality-threshold 0.9)" in text
    rules.write_text(text.replace("(layer-setting map-quality-threshold 0.9)",
                                  "(layer-setting map-quality-threshold 0.5)"), encoding="utf-8")
    engine, result, records = traced_run("lab-corridor-office", tmp_path, None, layer_rules=rules)
    to_ii = [s for s in switches(records) if s["layer"] == "II"]
    assert to_ii and "map-mature" in to_ii[0]["reason"]
    assert to_ii[0]["t"] < 0.5 * result.time
    assert result.ok  # where Layer II has no route on so young a map, Layer IV takes the drive back


def test_each_switch_is_traced_with_the_layer_the_previous_one_and_the_rule_that_chose_it(traced_cases):
    rule_names = {line.split()[1] for line in RULES.read_text().splitlines() if line.startswith("(define-memory-rule")}
    for _, _, records in traced_cases.values():
        steps = switches(records)
        assert steps[0]["previous"] is None
        for before, step in zip(steps, steps[1:]):
            assert step["previous"] == before["layer"] != step["layer"]
        for step in steps:
            assert step["reason"].startswith("rule ") and step["reason"].split()[1] in rule_names, step


def test_layer_iii_says_what_the_built_map_connects(experiment):
    out, data = experiment
    _, _, records = traced_run(EXACT, out, out / "map-run5.npz")
    connected = {r["fact"] for r in asserted(records, "(connected ") if r.get("by") == "layer III"}
    assert "(connected lab corridor)" in connected and "(connected corridor lab)" in connected


def test_the_same_files_and_seed_give_the_same_trace_with_no_prior_map(tmp_path):
    first = traced_run("lab-corridor-office", tmp_path, None)[2]
    second = traced_run("lab-corridor-office", tmp_path, None)[2]
    assert first == second


# -- beliefs ------------------------------------------------------------------------------------------


def test_a_belief_refuses_a_value_of_the_wrong_type_where_it_is_written():
    beliefs = Beliefs()
    with pytest.raises(TypeError, match="belief grid holds OccupancyGrid, not dict"):
        beliefs[GRID] = {}
    with pytest.raises(TypeError, match="keyed by Belief constants"):
        beliefs["grid"] = 1  # type: ignore[index]
    speed: Belief[float] = Belief("speed", float)
    beliefs[speed] = 0.5
    assert beliefs[speed] == 0.5 and beliefs.get(GRID) is None
    with pytest.raises(KeyError, match="no belief grid yet"):
        beliefs[GRID]


# -- the command line ---------------------------------------------------------------------------------


def atlas(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "atlas_rap", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=600)


def test_map_in_and_map_out_carry_the_grid_from_run_to_run(tmp_path):
    mission = errand_file(tmp_path, Settings())
    first = atlas("run", str(mission), "-q", "--no-prior-map", "--map-out", "maps/one.npz", cwd=tmp_path)
    assert first.returncode == 0, first.stdout + first.stderr
    second = atlas("run", str(mission), "-q", "--map-in", "maps/one.npz", "--no-prior-map",
                   "--map-out", "maps/two.npz", "--trace", "two.jsonl", cwd=tmp_path)
    assert second.returncode == 0, second.stdout + second.stderr
    from atlas_rap.maps.grid import OccupancyGrid

    one, two = (OccupancyGrid.load_npz(tmp_path / "maps" / f"{n}.npz") for n in ("one", "two"))
    assert two.updated.sum() >= one.updated.sum() > 10_000
    records = [json.loads(line) for line in (tmp_path / "two.jsonl").read_text().splitlines()]
    quality = [r for r in records if r["event"] == "fact-asserted" and r["fact"].startswith("(map-quality")][0]
    # the second run starts from the first's map (its survey after one errand: about 0.8; from nothing, 0)
    assert float(quality["fact"].split()[1].rstrip(")")) > 0.7


def test_bad_layer_options_are_refused_clearly(tmp_path):
    mission = str(REPO / "rap_library" / "missions" / "deliver.rap")
    done = atlas("run", mission, "--layers", "I,V", cwd=tmp_path)
    assert done.returncode == 2 and "V: the layers are I, II, III and IV" in done.stderr
    done = atlas("run", mission, "--layers", "IV", cwd=tmp_path)  # with a prior map, nothing to map
    assert done.returncode == 1 and "Layer IV maps, so it runs only when the robot maps" in done.stderr
    done = atlas("run", mission, "--map-out", "grid.npz", cwd=tmp_path)
    assert done.returncode == 2 and "--map-out needs a map built while driving" in done.stderr
    (tmp_path / "bad.npz").write_text("not a grid", encoding="utf-8")
    done = atlas("run", mission, "--map-in", "bad.npz", cwd=tmp_path)
    assert done.returncode == 1 and "bad.npz: not an occupancy grid" in done.stderr
    assert "Traceback" not in done.stderr
    (tmp_path / "no-rules.rap").write_text("(initial-memory (layer-setting map-quality-threshold 0.5))\n",
                                           encoding="utf-8")
    done = atlas("run", mission, "-q", "--layer-rules", "no-rules.rap", cwd=tmp_path)
    assert done.returncode == 1 and "no layer is primary: the layer rules (no-rules.rap)" in done.stdout
    done = atlas("experiment", "skill-acquisition", "--world", "maze", "--out", "out", cwd=tmp_path)
    assert done.returncode == 1 and "world maze has no place named lab" in done.stderr
    assert "Traceback" not in done.stderr
    (tmp_path / "other-building.yaml").write_text(  # lab and office, but a wall the corridor lacks
        f"base: {json.dumps((REPO / 'worlds' / 'lab-corridor-office.yaml').as_posix())}\n"
        "walls:\n  - [18, 4, 18, 5]\n", encoding="utf-8")
    done = atlas("experiment", "skill-acquisition", "--world", "other-building.yaml", "--out", "out", cwd=tmp_path)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "world other-building.yaml is not that building as shipped (it differs in its walls)" in done.stderr
    assert "--obstacles none" in done.stderr and "Traceback" not in done.stderr
    assert not (tmp_path / "out" / "figures.json").exists()


def test_the_obstacle_cases_take_the_odometry_of_the_runs_world(tmp_path):
    # Runs with exact odometry: the person's case (a world of its own, a variant of the shipped
    # building) runs with exact odometry too, not the noise the shipped case world gives the robot.
    data = skill_acquisition(tmp_path, Settings(world=EXACT, runs=1, obstacles=("person",)))
    assert data["runs"][0]["pose_rmse_m"] == 0.0
    (case,) = data["obstacles"]
    assert case["ok"] and case["world"] == "lab-corridor-office-person", case
    assert case["pose_rmse_m"] == 0.0, case  # the shipped case world's noise would leave an error
    assert (tmp_path / "world-lab-corridor-office-person.yaml").is_file()


def test_the_experiment_command_writes_its_figures_json_csv_and_pngs(tmp_path):
    done = atlas("experiment", "skill-acquisition", "--runs", "2", "--seed", "0", "--out", "out", cwd=tmp_path)
    assert done.returncode == 0, done.stdout + done.stderr
    out = tmp_path / "out"
    data = json.loads((out / "figures.json").read_text())
    assert [run["run"] for run in data["runs"]] == [1, 2]
    for run in data["runs"]:
        assert set(run) >= {"run", "map_quality", "duration_s", "optimal_s", "primary_s"}
        assert set(run["primary_s"]) == {"I", "II", "III", "IV"}
        assert math.isclose(sum(run["primary_s"].values()), run["duration_s"], abs_tol=0.1)
    assert [case["case"] for case in data["obstacles"]] == ["person", "corridor-box", "full-block"]
    for case in data["obstacles"]:
        assert set(case) >= {"case", "title", "world", "expected", "seen", "as_expected", "timeline", "events", "ok"}
        assert case["timeline"] and set(case["timeline"][0]) >= {"t", "layer", "reason"}
        assert f"obstacles, {case['case']}: {' → '.join(case['seen'])}" in done.stdout
    rows = (out / "runs.csv").read_text().splitlines()
    assert rows[0].startswith("run,map_quality,map_agreement,pose_rmse_m,duration_s,optimal_s") and len(rows) == 3
    # at the default odometry noise, the pose corrected against the map: every run gets there, and the map
    # it carries agrees with the true walls on at least 90 % of the cells it labels
    assert all(run["ok"] for run in data["runs"])
    assert all(run["map_agreement"] >= 0.9 and run["pose_rmse_m"] > 0 for run in data["runs"]), data["runs"]
    for name in ("fig12a-map-quality", "fig12b-durations", "fig13a-layers-per-run", "fig13b-obstacles"):
        assert (out / f"{name}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "run 2: map quality" in done.stdout


def test_the_repl_drives_with_the_layers_and_says_which_is_primary(tmp_path):
    script = f'(include "{REPO / "rap_library" / "navigation.rap"}")\n(post (go-to office))\n:run\n:layers\n'
    done = subprocess.run([sys.executable, "-m", "atlas_rap", "repl", "--world", "lab-corridor-office",
                           "--no-prior-map", "--map-out", "grid.npz"], input=script, cwd=tmp_path,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "primary: Layer IV" in done.stdout and "rule map-immature on (map-quality 0.0)" in done.stdout
    assert (tmp_path / "grid.npz").exists()
    done = subprocess.run([sys.executable, "-m", "atlas_rap", "repl"], input=":layers\n", cwd=tmp_path,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 1 and ":layers needs a world" in done.stderr and "Traceback" not in done.stderr


def test_a_block_met_while_every_route_is_cut_already_gives_the_drive_back_to_layer_iv():
    # Layer IV drives because every route was cut: (no-route) holds. A block that stays makes Layer III
    # assert (no-route) again, which changes nothing; Layer I must not hold the robot for ever.
    from atlas_rap.logic import Compound, term_to_str

    engine = MissionEngine(RunOptions(world=EXACT, seed=0, prior_map=False))
    engine.start()
    sequencer = engine.sequencer

    def primary() -> list[str]:
        return [term_to_str(f) for f in sequencer.memory if f.functor == "primary-layer"]

    sequencer.change([("assert", Compound("no-route", ()))], "layer III")
    assert primary() == ["(primary-layer iv)"], primary()  # every route cut: Layer IV drives
    sequencer.change([("assert", Compound("obstacle", ("short-lived",)))], "layer I")
    assert primary() == ["(primary-layer i)"], primary()  # something in the way: Layer I stops the robot
    sequencer.change([("assert", Compound("no-route", ()))], "layer III")  # its assessment: nothing new
    sequencer.change([("assert", Compound("obstacle", ("long-lived",)))], "layer I")
    assert primary() == ["(primary-layer iv)"], primary()


def _layers_on_a_known_free_grid():
    """A run on lab-corridor-office without a prior map, its layers started, and Layer IV's grid
    known free everywhere: the engine, its stack and the grid, for a test to draw walls on."""
    engine = MissionEngine(RunOptions(world="lab-corridor-office", seed=0, prior_map=False))
    engine.advance(0.1)  # the layers started
    stack = engine.stack
    grid = stack.beliefs[GRID]
    grid.log_odds = np.full(grid.frame.shape, -5.0, dtype=np.float32)
    grid.updated[...] = True
    return engine, stack, grid


def test_with_no_way_on_its_map_layer_iv_goes_back_the_way_the_robot_came_but_not_through_a_block():
    # A sonar map can close a doorway behind the robot. Here a wall closes the whole building at
    # x = 5 m on a grid otherwise known free; the robot's believed track of this run crosses it.
    _, stack, grid = _layers_on_a_known_free_grid()
    col = grid.frame.world_to_cell(5.0, 0.0)[1]
    grid.log_odds[:, col:col + 2] = 8.0
    stack.grid_version += 1
    stack.beliefs[POSE] = (1.5, 1.5, 0.0)
    layer = stack.layers["IV"]
    assert isinstance(layer.route("office", (1.5, 1.5), set()), str)  # no way at all: it says so
    stack.beliefs[POSE_TRACK] = [(0.1 * i, 1.5 + 0.1 * i, 1.5, 0.0) for i in range(70)]  # x 1.5 -> 8.4
    route = layer.route("office", (1.5, 1.5), set())
    assert isinstance(route, PlannedRoute)
    crossing = [(p, q) for p, q in zip(route.waypoints, route.waypoints[1:]) if (p[0] - 5.0) * (q[0] - 5.0) < 0]
    assert len(crossing) == 1 and all(abs(y - 1.5) < 0.3 for p, q in crossing for y in (p[1], q[1]))
    stack.blocks.append((5.0, 1.5))  # a block Layer III assessed on that way: the track does not pass it
    assert isinstance(layer.route("office", (1.5, 1.5), set()), str)


def test_where_the_bumper_touched_something_layer_iv_marks_it_and_plans_round_it_even_beside_the_robot():
    # A door jamb met edge-on, a wall the beams graze: sonar can miss what the body then touches.
    # The grid is known free everywhere; the robot, standing at its start, feels a contact in front.
    engine, stack, grid = _layers_on_a_known_free_grid()
    stack.grid_version += 1
    x, y, heading = stack.beliefs[POSE]
    ahead = (x + 1.5 * math.cos(heading), y + 1.5 * math.sin(heading))
    assert stack.holds("mapping", "on")
    assert len(stack.grid_planner(unknown_passable=True).plan((x, y), ahead).waypoints) == 2  # straight on
    revision = stack.revision
    stack.beliefs[BUMP] = (engine.now(), 0.0)  # body-frame angle 0: its front
    engine.advance(0.6)  # Layer I logs the contact, Layer IV's next tick marks it
    contact = (x + stack.robot_radius * math.cos(heading), y + stack.robot_radius * math.sin(heading))
    assert stack.contacts == [pytest.approx(contact)]
    assert grid.log_odds[grid.frame.world_to_cell(*contact)] == grid.model.clamp
    assert stack.revision > revision  # the route being driven is asked for again
    # felt, not seen: the disc round the robot, which the planner otherwise takes as free, keeps it
    planner = stack.grid_planner(unknown_passable=True)
    assert planner.impassable[planner.frame.world_to_cell(*contact)]
    path = planner.plan((x, y), ahead)
    legs = list(zip(path.waypoints, path.waypoints[1:]))
    assert len(legs) > 1 and min(_distance_to_segment(contact, p, q) for p, q in legs) > stack.robot_radius


def _distance_to_segment(point, p, q) -> float:
    a, b, c = np.asarray(point), np.asarray(p), np.asarray(q)
    t = np.clip(np.dot(a - b, c - b) / max(np.dot(c - b, c - b), 1e-12), 0.0, 1.0)
    return float(np.linalg.norm(a - (b + t * (c - b))))


def test_a_robot_that_rubs_on_the_lab_door_jamb_its_sonar_missed_gets_through_at_once(tmp_path):
    # Seed 6's first run (no map, the default noise, mapping at 0.6 of top speed as the rules then
    # capped it; at top speed this seed's run goes otherwise): the lab door's east jamb, met from the
    # south-west, returns no echo (specular). Before the contacts were marked, the robot pressed
    # on it for 87 s: 21 bumps and eight navigate-to failures ("no progress"), run 1 200.7 s.
    engine, result, records = traced_run("lab-corridor-office", tmp_path, None, seed=6, errand=("office", "lab"),
                                         layer_rules=str(capped_rules(tmp_path)))
    assert result.ok, result
    failures = [r for r in records if r["event"] == "step-outcome" and r["outcome"] == ":fail"]
    assert failures == [], failures
    assert len(asserted(records, "(bumped robot)")) <= 2
    assert result.time < 130.0  # the other seeds' first runs: 87-115 s
    jamb = [c for c in engine.stack.contacts if math.dist(c, (7.0, 4.0)) < 0.35]
    assert jamb, engine.stack.contacts


@pytest.mark.parametrize("seed", [2, 9])
def test_a_doorway_the_sonar_closed_on_the_map_is_looked_at_again_and_the_robot_gets_out(tmp_path, seed):
    # A building we did not tune on: office-building, no prior map, the robot starting in office-1
    # facing its 1 m door. Echoes off the jambs, met at a slant, spread occupied arcs across the
    # doorway: no way out on Layer IV's map, and the robot used to give up where it stood.
    # navigation.rap's go-to then turns once on the spot (look-around). Seed 2: beams straight
    # through the doorway clear the arcs. Seed 9 stands 5 m from the door, where the sonar's reach
    # ends, and the arcs stay; Layer IV's last try takes the faintly occupied cells for unknown,
    # and its way leads the robot near enough for the sonar to see through. (Mapping at 0.6 of top
    # speed, as the rules then capped it: at top speed these seeds' rings happen to see through.)
    world = (REPO / "worlds" / "office-building.yaml").read_text(encoding="utf-8")
    assert "start: [27.5, 8.5, 180]" in world
    (tmp_path / "from-office-1.yaml").write_text(world.replace("start: [27.5, 8.5, 180]", "start: [3, 3.5, 90]"),
                                                 encoding="utf-8")
    mission = tmp_path / "out.rap"
    mission.write_text(f'(include "{shipped_root("rap_library") / "navigation.rap"}")\n(post (go-to office-4))\n',
                       encoding="utf-8")
    records: list[dict] = []
    trace = Trace()
    trace.add_sink(lambda record: records.append(record))
    engine = MissionEngine(RunOptions(world=str(tmp_path / "from-office-1.yaml"), seed=seed, prior_map=False,
                                      layer_rules=str(capped_rules(tmp_path))), trace=trace)
    engine.load_file(mission, require_post=True)
    result = engine.run_mission(400)
    assert result.ok, result
    steps = [r for r in records if r["event"] in ("step-outcome", "method-selected")]
    no_way = next(i for i, r in enumerate(steps) if "no way to office-4" in r.get("reason", ""))
    then = steps[no_way + 1:]
    assert then[0]["event"] == "method-selected" and then[0]["method"] == "look-again", then[:3]
    assert then[1]["step"] == "step t1 (look-around)" and then[1]["outcome"] == ":succeed", then[:3]
    assert then[2]["step"] == "step t2 (navigate-to office-4)" and then[2]["outcome"] == ":succeed", then[:3]


def _where_it_crosses(route: PlannedRoute, x: float) -> list[float]:
    """The y at which each leg of ``route`` crosses the line x = ``x``."""
    return [p[1] + (q[1] - p[1]) * (x - p[0]) / (q[0] - p[0])
            for p, q in zip(route.waypoints, route.waypoints[1:]) if (p[0] - x) * (q[0] - x) < 0]


def test_layer_iv_s_last_try_takes_faintly_occupied_cells_for_unknown_once_no_way_was_said(tmp_path):
    # A wall across the lab at x = 5 m, sure everywhere but a doorway's width of faint cells
    # (P 0.82): no way on the first asking; once (no-route) holds for the goal, the last try
    # goes through the faint cells, and only there. A sure wall stays shut.
    _, stack, grid = _layers_on_a_known_free_grid()
    col = grid.frame.world_to_cell(5.0, 0.0)[1]
    grid.log_odds[:, col:col + 3] = 8.0
    door = [grid.frame.world_to_cell(5.0, y)[0] for y in (2.5, 1.5)]
    grid.log_odds[door[0]:door[1], col:col + 3] = 1.5
    stack.grid_version += 1
    stack.beliefs[POSE], stack.beliefs[POSE_TRACK] = (1.5, 1.5, 0.0), []
    layer = stack.layers["IV"]
    reason = layer.route("office", (1.5, 1.5), set())
    assert isinstance(reason, str) and "faintly" not in reason, reason
    assert stack.holds("no-route")
    route = layer.route("office", (1.5, 1.5), set())
    assert isinstance(route, PlannedRoute), route
    crossing = _where_it_crosses(route, 5.0)
    assert len(crossing) == 1 and 1.5 + stack.robot_radius <= crossing[0] <= 2.5 - stack.robot_radius, route
    grid.log_odds[door[0]:door[1], col:col + 3] = 3.0  # the sonar has made the doorway's cells sure
    stack.grid_version += 1
    reason = layer.route("office", (1.5, 1.5), set())
    assert isinstance(reason, str) and "nor where it is only faintly occupied" in reason, reason


def test_layer_iv_s_last_try_doubts_the_walls_it_cannot_see_when_nothing_else_opens_a_way():
    # Every way cut, and no block Layer III assessed (Layer IV drives, so none is): a sure wall
    # across the building at x = 11 m, the robot in the corridor west of it at (10, 5). The wall
    # between lab and corridor (y = 4 m, its door at x 6-7 m) hides the wall's stretch south of
    # y = 4 m; the last try doubts that stretch, and the way goes back through the lab and on east.
    _, stack, grid = _layers_on_a_known_free_grid()
    frame = grid.frame
    col = frame.world_to_cell(11.0, 0.0)[1]
    grid.log_odds[:, col:col + 3] = 8.0
    row = frame.world_to_cell(0.0, 4.0)[0]
    for x0, x1 in ((0.0, 6.0), (7.0, 10.9)):
        grid.log_odds[row - 1:row + 2, frame.world_to_cell(x0, 4.0)[1]:frame.world_to_cell(x1, 4.0)[1]] = 8.0
    stack.grid_version += 1
    stack.beliefs[POSE], stack.beliefs[POSE_TRACK] = (10.0, 5.0, 0.0), []
    layer = stack.layers["IV"]
    hidden = frame.world_to_cell(11.0, 2.0)
    assert isinstance(layer.route("office", (10.0, 5.0), set()), str)
    assert grid.log_odds[hidden] == 8.0  # the first asking doubts nothing
    route = layer.route("office", (10.0, 5.0), set())
    assert isinstance(route, PlannedRoute), route
    assert grid.log_odds[hidden] < 1.0  # doubted
    assert grid.log_odds[frame.world_to_cell(11.0, 6.0)] == 8.0  # in sight: as sure as it was
    crossing = _where_it_crosses(route, 11.0)
    assert crossing and all(y < 4.0 for y in crossing), route


def test_layer_iv_s_last_try_doubts_the_walls_round_the_goal_that_its_map_closed():
    # The office walled in on the map, every wall sure (a door shut when the robot passed, or a
    # wall drawn where a drifting pose put it), and the robot in the lab, beyond the sonar's reach
    # of them: no way at the first asking; the last try doubts the walls within the sonar's reach
    # of the goal and the way goes in. Once the sonar has made them sure again, the robot gives up.
    _, stack, grid = _layers_on_a_known_free_grid()
    frame = grid.frame
    x, y = frame.cell_to_world(*np.indices(frame.shape))
    inside = (x > 13.0) & (x < 20.0) & (y > 6.0) & (y < 10.0)
    ring = ~inside & (x > 12.8) & (x < 20.2) & (y > 5.8) & (y < 10.2)
    grid.log_odds[ring] = 8.0
    stack.grid_version += 1
    stack.beliefs[POSE], stack.beliefs[POSE_TRACK] = (1.5, 1.5, 0.0), []
    layer = stack.layers["IV"]
    assert isinstance(layer.route("office", (1.5, 1.5), set()), str)
    route = layer.route("office", (1.5, 1.5), set())
    assert isinstance(route, PlannedRoute), route
    assert route.waypoints[-1] == stack.world.places["office"].point
    grid.log_odds[ring] = 8.0  # the robot went and looked: walls
    grid.updated[ring] = True
    stack.grid_version += 1
    reason = layer.route("office", (1.5, 1.5), set())
    assert isinstance(reason, str) and "every way is blocked" in reason, reason


def test_layer_iv_looks_for_a_way_within_the_world_s_extent_not_round_the_outside():
    # A sure wall across the whole building at x = 5 m, and the margin the bounds leave round the
    # building (1 m) never seen: the way round the wall's end through that margin is no way. A
    # stretch of the wall inside the building the sonar has not seen is one.
    _, stack, grid = _layers_on_a_known_free_grid()
    frame = grid.frame
    assert stack.world.extent == (0.0, 0.0, 20.0, 10.0)  # lab-corridor-office's walls
    x, y = frame.cell_to_world(*np.indices(frame.shape))
    beyond = (x < 0.0) | (x > 20.0) | (y < 0.0) | (y > 10.0)
    grid.log_odds[beyond], grid.updated[beyond] = 0.0, False
    wall = (np.abs(x - 5.0) < 0.1) & ~beyond
    grid.log_odds[wall] = 8.0
    stack.grid_version += 1
    stack.beliefs[POSE], stack.beliefs[POSE_TRACK] = (1.5, 1.5, 0.0), []
    layer = stack.layers["IV"]
    reason = layer.route("office", (1.5, 1.5), set())
    assert isinstance(reason, str), reason
    unseen = wall & (np.abs(y - 2.0) < 0.5)
    grid.log_odds[unseen], grid.updated[unseen] = 0.0, False
    stack.grid_version += 1
    route = layer.route("office", (1.5, 1.5), set())
    assert isinstance(route, PlannedRoute), route
    crossing = _where_it_crosses(route, 5.0)
    assert len(crossing) == 1 and 1.5 < crossing[0] < 2.5, route
    assert all(0.0 <= py <= 10.0 for _, py in route.waypoints), route


def test_a_carried_map_that_closed_a_doorway_lets_layer_iv_through_where_earlier_runs_drove(tmp_path):
    # The wall at x = 5 m again, in a map carried from an earlier run: this run has no track yet,
    # but the grid remembers where the robot's centre went before (OccupancyGrid.driven, in the file).
    engine = MissionEngine(RunOptions(world="lab-corridor-office", seed=0, prior_map=False))
    engine.run(0.1)
    grid = engine.stack.beliefs[GRID]
    grid.log_odds = np.full(grid.frame.shape, -5.0, dtype=np.float32)
    grid.updated[...] = True
    col = grid.frame.world_to_cell(5.0, 0.0)[1]
    grid.log_odds[:, col:col + 2] = 8.0
    for i in range(70):  # an earlier run drove x 1.5 -> 8.4 along y = 1.5
        grid.mark_driven(1.5 + 0.1 * i, 1.5, 0.1)
    carried = grid.save_npz(tmp_path / "carried.npz")

    engine = MissionEngine(RunOptions(world="lab-corridor-office", seed=0, prior_map=False, map_in=carried))
    engine.run(0.1)
    stack = engine.stack
    grid = stack.beliefs[GRID]
    assert grid.driven[grid.frame.world_to_cell(5.0, 1.5)]  # the earlier run's way came with the map
    grid.log_odds[:, col:col + 2] = 8.0  # the wall as the file has it, whatever this run's first rings saw
    stack.grid_version += 1
    stack.beliefs[POSE], stack.beliefs[POSE_TRACK] = (1.5, 1.5, 0.0), []
    layer = stack.layers["IV"]
    driven = grid.driven.copy()
    grid.driven[...] = False
    assert isinstance(layer.route("office", (1.5, 1.5), set()), str)  # without it: no way at all
    grid.driven[...] = driven
    route = layer.route("office", (1.5, 1.5), set())
    assert isinstance(route, PlannedRoute), route
    crossing = [(p, q) for p, q in zip(route.waypoints, route.waypoints[1:]) if (p[0] - 5.0) * (q[0] - 5.0) < 0]
    assert len(crossing) == 1 and all(abs(y - 1.5) < 0.3 for p, q in crossing for y in (p[1], q[1]))
    stack.blocks.append((5.0, 1.5))  # a block assessed on that way: the old way does not pass it
    assert isinstance(layer.route("office", (1.5, 1.5), set()), str)
    stack.blocks.clear()
    assert isinstance(layer.route("office", (1.5, 1.5), set()), PlannedRoute)
    grid.log_odds[:, col:col + 2] = 9.0  # this run's sonar sees the wall, surer than the old map did
    stack.grid_version += 1
    assert isinstance(layer.route("office", (1.5, 1.5), set()), str)  # what it sees now overrules the memory
