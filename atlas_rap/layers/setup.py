"""Putting a mission in a world: the skills, the simulation, the executive, the picture.

A mission names its world (``(world "lab-corridor-office")``, or ``none``
for virtual skills only); ``atlas run --world`` overrides it, and a mission
that names none runs in the default world. :class:`WorldSetup` builds what
that takes once the program is loaded: the simulation with the run's seed,
the stock skills' manager beside the file's virtual skills, the prior map
in memory, the multirate executive, and the picture of the run.

    setup = WorldSetup(world_flag, seed)
    mission = setup.load_mission(path, trace=trace)
    result = mission.run(until, driver=setup.executive)

A world given as a path in a mission file is found relative to that file.
"""

from __future__ import annotations

from pathlib import Path

DEFAULT_WORLD = "lab-corridor-office"
"""The world of a mission that names none: the seed's lab, corridor and office."""


class WorldSetup:
    """Builds what a run needs once the mission's program says which world: skills, simulation, executive."""

    def __init__(self, world_flag: str | None, seed: int, *, mapping: bool = False,
                 topology: str | None = None) -> None:
        self.world_flag = world_flag
        self.seed = seed
        self.mapping = mapping
        self.topology = topology
        self.world = None
        self.simulation = None
        self.executive = None
        self.manager = None
        self.events: list[dict] = []
        self.depth: dict[int, int] = {}

    def task_events(self, record: dict) -> None:
        """A trace sink keeping what the picture marks: tasks at most one level below a posted one."""
        event = record["event"]
        if event == "task-posted":
            parent = record.get("parent")
            self.depth[record["id"]] = self.depth[parent] + 1 if parent is not None else 0
        elif event in ("task-selected", "task-succeeded", "task-failed") and self.depth.get(record["id"], 9) <= 1:
            self.events.append(record)

    def skills_for(self, program):
        """The skill link for a loaded program (load_mission's ``skills``): builds the world's parts."""
        from atlas_rap.lang import ast
        from atlas_rap.sequencer.skill_link import CombinedSkills
        from atlas_rap.skills.virtual import VirtualSkills

        declared = program.of_type(ast.WorldDecl)
        chosen = self.world_flag or (declared[-1].world if declared else DEFAULT_WORLD)
        if not self.world_flag and declared and _is_path(chosen):
            chosen = str(Path(declared[-1].loc.file).resolve().parent / chosen)
        virtual = VirtualSkills.from_program(program)
        if chosen == "none":
            return virtual
        from atlas_rap.layers.executive import Rates
        from atlas_rap.sim.physics import Simulation
        from atlas_rap.sim.world import load_world
        from atlas_rap.skills.stock import stock_manager

        self.world = load_world(chosen)
        self.simulation = Simulation(self.world, seed=self.seed, dt=1.0 / Rates().physics)
        self.manager = stock_manager(self.world, self.simulation, self.simulation.rng, mapping=self.mapping)
        if self.topology is not None:
            from atlas_rap.maps.topology import Topology
            from atlas_rap.skills.navigation import TOPOLOGY

            self.manager.context.beliefs[TOPOLOGY] = Topology.from_json(self.topology)
        return CombinedSkills(self.manager, virtual)

    def load_mission(self, path, trace=None):
        """Load and check a mission with this setup's skills, then start its world (:meth:`start`).
        Each ``(plan GOAL ...)`` is planned now and carried out by RAPs (``planner.execute``)."""
        from atlas_rap.planner.execute import expand_plan_requests
        from atlas_rap.sequencer import load_mission

        mission = load_mission(path, skills=self.skills_for, trace=trace, planner=expand_plan_requests)
        self.start(mission)
        return mission

    def start(self, mission) -> None:
        """Put the world's prior map in memory and build the executive."""
        if self.world is None:
            return
        from atlas_rap.layers.executive import Executive
        from atlas_rap.sim.prior import prior_facts

        mission.sequencer.change([("assert", fact) for fact in prior_facts(self.world)], "world")
        self.executive = Executive(self.simulation, self.manager, mission.sequencer)

    def render(self, out_png: str, title: str) -> None:
        """The picture of the run so far: world, doors as they are, obstacles, path, task marks."""
        from atlas_rap.sim.render import render_run

        sim = self.simulation
        render_run(self.world, out_png, path=sim.path, doors_open=sim.doors_open, obstacles=sim.obstacles(),
                   task_marks=self.marks(), title=f"{title}, seed {self.seed}")

    def marks(self) -> list:
        """Where each marked task started (first selection) and ended, on the robot's path."""
        from bisect import bisect_left

        from atlas_rap.sim.render import TaskMark

        path = self.simulation.path
        times = [p[0] for p in path]
        marks, started = [], set()
        for record in self.events:
            kind = {"task-selected": "started", "task-succeeded": "succeeded", "task-failed": "failed"}[record["event"]]
            if kind == "started":
                if record["id"] in started:
                    continue
                started.add(record["id"])
            if not path:
                break
            _, x, y, _ = path[min(bisect_left(times, record["t"]), len(path) - 1)]
            marks.append(TaskMark(record["t"], x, y, record["task"], kind))
        return marks


def _is_path(world: str) -> bool:
    return "/" in world or world.endswith((".yaml", ".yml"))
