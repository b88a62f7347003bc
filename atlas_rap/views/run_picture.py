"""The picture of a run: an observer that watches the trace, then draws the world and the robot's path
(or, for a run with no world, a timeline of what the 3T loop did).

Attach one to an engine before it runs, render it when you like (also after
a failed or interrupted run)::

    picture = RunPicture(engine)
    engine.run_mission(until)
    picture.render("run.png", "deliver.rap")

It marks where each task at most one level below a posted one started
(first selection) and ended, on the robot's path, and where each plan step
started and how it ended (the plan executive's records, ``views.world_render.PLAN_EVENTS``).

When the robot's pose was estimated (odometry with noise), the picture also
shows the path the robot believed it drove (the localiser's
:data:`~atlas_rap.skills.beliefs.POSE_TRACK`) beside the true one, and the
last estimate's 2-sigma ellipse (:data:`~atlas_rap.skills.beliefs.POSE_ESTIMATE`);
a run without them draws the picture it always did.

A run with no world (``--world none``: virtual skills only) has no map, so
:meth:`RunPicture.render` draws its timeline instead (``views.timeline``):
a lane per agent of the plan steps, re-plans and abandoned plans, and the
tasks at most one level below a posted one, in simulated time. For it the
picture keeps those tasks' posting, first selection, methods, waits, skills
taken from them and end, and the methods, halts, waits and skills taken of
the plan steps' tasks.
"""

from __future__ import annotations

from bisect import bisect_left
from typing import TYPE_CHECKING

from atlas_rap.trace_events import Event

if TYPE_CHECKING:  # the engine does not import its observers
    from atlas_rap.layers.engine import MissionEngine

_KINDS = {Event.TASK_SELECTED: "started", Event.TASK_SUCCEEDED: "succeeded", Event.TASK_FAILED: "failed"}
_TIMELINE_TASK_EVENTS = frozenset({Event.TASK_SELECTED, Event.METHOD_SELECTED, Event.TASK_SUCCEEDED,
                                   Event.TASK_FAILED, Event.TASK_HALTED, Event.TASK_WAITING, Event.TASK_RESUMED,
                                   Event.SKILL_PREEMPTED})


class RunPicture:
    """A trace sink keeping the task marks, and the drawing of the run."""

    def __init__(self, engine: MissionEngine) -> None:
        self.engine = engine
        self.events: list[dict] = []
        self.depth: dict[int, int] = {}
        self.plan_events: list[dict] = []
        self.timeline: list[dict] = []  # the records the timeline of a run with no world needs
        self._selected: set[int] = set()
        self._step_tasks: set[int] = set()
        engine.trace.add_sink(self)

    def __call__(self, record: dict) -> None:
        event = record["event"]
        if event == Event.TASK_POSTED:
            parent = record.get("parent")
            depth = self.depth[record["id"]] = self.depth.get(parent, 0) + 1 if parent is not None else 0
            if depth <= 1:
                self.timeline.append(record)
            return
        if event in _TIMELINE_TASK_EVENTS:
            self._keep_for_timeline(record)
        if event in _KINDS and self.depth.get(record["id"], 9) <= 1:
            self.events.append(record)
        elif event.startswith("plan-") or event == Event.REPLANNED:
            self.plan_events.append(record)
            self.timeline.append(record)
            if event == Event.PLAN_STEP_STARTED and record.get("step_task") is not None:
                self._step_tasks.add(record["step_task"])

    def _keep_for_timeline(self, record: dict) -> None:
        """A task record the timeline shows: of a task at most one level below a posted one
        (its first selection, methods, waits, skills taken and end), or of a plan step's task
        (methods, halt, waits, skills taken)."""
        event, task = record["event"], record["id"]
        if self.depth.get(task, 9) <= 1:
            if event == Event.TASK_SELECTED:
                if task in self._selected:
                    return
                self._selected.add(task)
            self.timeline.append(record)
        elif task in self._step_tasks and event in (Event.METHOD_SELECTED, Event.TASK_HALTED, Event.TASK_WAITING,
                                                    Event.TASK_RESUMED, Event.SKILL_PREEMPTED):
            self.timeline.append(record)

    def render(self, out_png: str, title: str) -> None:
        """Draw the run so far: world, doors as they are, obstacles, path (and the believed one),
        task marks; with no world, the timeline of the run (plan steps by agent, re-plans, tasks)."""
        from atlas_rap.views.world_render import render_run

        engine = self.engine
        if engine.world is None:
            from atlas_rap.views.timeline import render_timeline

            end = engine.now() if engine.built else None
            render_timeline(self.timeline, out_png, f"{title}, seed {engine.seed}", end=end)
            return
        from atlas_rap.skills.beliefs import POSE_ESTIMATE, POSE_TRACK

        sim = engine.simulation
        beliefs = engine.manager.context.beliefs
        render_run(engine.world, out_png, path=sim.path, doors_open=sim.doors_open, obstacles=sim.obstacles(),
                   task_marks=self.marks(), title=f"{title}, seed {engine.seed}", plan_events=self.plan_events,
                   objects=self.objects(), believed_path=beliefs.get(POSE_TRACK) or (),
                   estimate=beliefs.get(POSE_ESTIMATE), kidnaps=sim.kidnaps)

    def objects(self) -> list[tuple[str, str, str, tuple[float, float]]]:
        """The world's objects where they are now: (name, colour, kind, (x, y)); what lies in a
        bin is named with the bin (``bin-lab: can-1, cup-1``) rather than drawn on it."""
        from atlas_rap.skills.beliefs import OBJECTS

        devices = self.engine.manager.context.beliefs.get(OBJECTS)
        if devices is None:
            return []
        inside: dict[str, list[str]] = {}
        for item, bin_ in sorted(devices.in_bin.items()):
            inside.setdefault(bin_, []).append(item)
        return [(f"{name}: {', '.join(inside[name])}" if name in inside else name, obj.colour, obj.kind,
                 devices.position(name))
                for name, obj in sorted(devices.objects.items()) if name not in devices.in_bin]

    def marks(self) -> list:
        """Where each marked task started (first selection) and ended, on the robot's path
        (a plan step's task is drawn as the plan step, not again as a task)."""
        from atlas_rap.views.world_render import TaskMark

        path = self.engine.simulation.path
        times = [p[0] for p in path]
        marks, started = [], set()
        plan_steps = {r["step_task"] for r in self.plan_events if r["event"] == Event.PLAN_STEP_STARTED}
        for record in self.events:
            if record["id"] in plan_steps:
                continue
            kind = _KINDS[record["event"]]
            if kind == "started":
                if record["id"] in started:
                    continue
                started.add(record["id"])
            if not path:
                break
            _, x, y, _ = path[min(bisect_left(times, record["t"]), len(path) - 1)]
            marks.append(TaskMark(record["t"], x, y, record["task"], kind))
        return marks
