"""The timeline of a run: what the 3T loop did, in simulated time (``atlas run --render`` with no world).

A run in ``(world none)`` has no map to draw, so its picture is a chart of
time, read from the trace records (the plan executive's, see
``sequencer.deliberation``, and the sequencer's task records):

- **Plan steps**, a lane per agent in order of first use (steps with no
  agent in a lane of their own, last; :func:`lanes`). Each step is a bar
  from its start to its end, green when it was done, red when it failed,
  grey when it was halted (a re-plan dropped it, or the plan was
  abandoned), blue while it still runs, labelled ``s3 repair-site site-b``
  (the agent, named by the lane, is left out; ``v2`` after a re-plan, ``p2``
  when the run has several plans). A step a re-plan gave to another agent
  while it ran (``reassigned`` with ``running``) is cut there: light purple
  in the lane of the agent it left, and it goes on in the new agent's lane
  (:func:`step_bars`). Labels go inside a bar when they fit, else beside it;
  a lane takes as many rows as its bars and labels need (:func:`pack_rows`).
- **Re-plans and abandoned plans** are vertical lines across the chart
  (purple dashed, dark red), each with a short label above the chart
  ("re-plan v2: agent left-arm was lost", "abandoned (repaired site-b): 3
  failures"; :func:`plan_lines`), wrapped to a few lines. A label reaches
  right of its line; labels are stacked so that no line crosses a label
  (:func:`stack_labels`).
- **Tasks** posted (bold) and one level below them, as thin bars from their
  first selection to their end, coloured by outcome, in tree order
  (:func:`task_bars`). A task that is a plan step is drawn as the step, not
  again here. A failed or halted task says why, briefly, beside its bar.
- **Method changes** (``method-selected`` with ``attempt`` > 1:
  :func:`method_changes`) are small ticks on the bar of the task or plan step;
  where the method changed (not a retry of the same method) a task's tick is
  named (``→ give-up``), and a plan step's label ends with the new method
  (``s2 attach-at fx-b → handrail``).
- **Waits** (``task-waiting`` to ``task-resumed``: :func:`wait_spans`) are
  lighter parts of a task's or plan step's bar: hatched ``////`` while the
  task, or a task below it, waited for a skill instance another task held
  ("waits for a skill"), dotted while it waited out a failed attempt's
  back-off ("waits before retrying"). A wait no ``task-resumed`` ended runs
  to the task's next method choice or its end, else to the end of the bar.
  Where a task of higher priority took a skill from the task or one below
  it (``skill-preempted``, :func:`preemptions`; halted to resume, when the
  holder's wait starts there, or failed) a small orange triangle sits on
  the bar. The legend names each only when the chart has one
  (:func:`legend_labels`), so a run without waits is drawn as before. (An
  ``atlas run`` picture keeps these records for the tasks it shows, not
  for tasks two levels down: ``views.run_picture``.)

The title is the mission and seed, the time axis simulated seconds.
:func:`render_timeline` draws with matplotlib's object-oriented API on an Agg
canvas (imported inside it) and writes the PNG with
``views.plan_render.save_figure``, so the same records give the same bytes.

Over 25 KB on purpose: one picture, whose named steps (rows, lanes, bars, labels, legend)
share the layout they compute.
"""

from __future__ import annotations

import re
import textwrap
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

from atlas_rap.trace_events import Event
from atlas_rap.views.page import cut_text, plain_text

__all__ = ["NO_AGENT", "OUTCOME_COLOURS", "MethodChange", "PlanLine", "Preemption", "StepBar", "TaskBar", "WaitSpan",
           "lanes", "legend_labels", "method_changes", "pack_rows", "plan_lines", "preemptions", "render_timeline",
           "short_action", "stack_labels", "step_bars", "task_bars", "wait_spans"]

NO_AGENT = "(no agent)"
"""The lane of plan steps that have no agent."""

OUTCOME_COLOURS = {"done": "#2f9e44", "failed": "#e03131", "halted": "#868e96", "running": "#1971c2",
                   "handed-over": "#b197fc"}
"""Bar colours by outcome (``handed-over``: the part of a step before a re-plan gave it to another agent)."""

_OUTCOME_WORDS = {"done": "done / succeeded", "failed": "failed", "halted": "halted", "running": "still running",
                  "handed-over": "handed to another agent by a re-plan"}
_LINE_STYLE = {"replanned": ("#9c36b5", (0, (4, 2)), 1.1), "abandoned": ("#862e2e", "-", 1.4)}
_LINE_WORDS = {"replanned": "re-plan", "abandoned": "plan or goal abandoned"}
_TICK_COLOUR = "#212529"
_TICK_WORD = "method changed (or retried)"
_WAIT_HATCH = {"skill": "////", "retry": "...."}
_WAIT_WORDS = {"skill": "waits for a skill", "retry": "waits before retrying"}
_WAIT_KEY_COLOUR = "#495057"
_PREEMPT_COLOUR = "#e8590c"
_PREEMPT_WORD = "skill taken by a task of higher priority"
_LANE_SHADE = "#f1f3f5"

CHART_WIDTH = 8.0  # inches of the time axis
ROW = 0.24  # inches per row
STEP_BAR = 0.66  # bar height of a plan step, in rows
TASK_BAR = 0.36  # bar height of a task, in rows
FONT = 7.0  # points, bar labels
LEFT_FONT = 7.5  # points, lane names and tasks left of the chart
LINE_FONT = 7.0  # points, the labels of re-plans and abandons
CHAR_WIDTH = 0.6  # a character's width in ems (DejaVu Sans averages about 0.55; a margin)
LINE_LABEL_CHARS = 40  # characters per line of a re-plan's label...
LINE_LABEL_LINES = 3  # ...and lines at most
MAX_TASK_ROWS = 40
MAX_TASK_CHARS = 40
INDENT = 9  # points a subtask's name is indented
MAX_ACTION_CHARS = 30
MAX_REASON_CHARS = 60


class MethodChange(NamedTuple):
    """A task's ``attempt``-th method (2 or more) chosen at ``t``; ``previous`` is the
    method it tried before ("" when not known). Same as ``previous``: a retry."""

    t: float
    method: str
    attempt: int
    previous: str = ""

    @property
    def changed(self) -> bool:
        return self.method != self.previous


class WaitSpan(NamedTuple):
    """Task ``task`` waited from ``start`` to ``end`` (None: still waiting where the records
    end): ``kind`` ``skill`` for the skill instance ``what`` another task held, or ``retry``
    for the back-off before its next attempt (``what`` is "")."""

    start: float
    end: float | None
    kind: str
    task: int
    what: str = ""


class Preemption(NamedTuple):
    """At ``t`` task ``winner`` (of higher priority) took the skill ``skill`` from task ``task``,
    whose step was halted to resume (``outcome`` ``:halted``) or failed (``:preempted``)."""

    t: float
    task: int
    skill: str
    winner: str
    outcome: str


@dataclass(frozen=True, slots=True)
class StepBar:
    """A plan step (or the part of it one agent did): in ``lane`` from ``start`` to ``end``
    (None: still running). ``outcome`` is done, failed, halted, running or handed-over;
    ``label`` e.g. ``"v2 s1 repair-site site-b"`` (``→ METHOD`` after it for each change
    of method); ``task`` the step's RAP task; ``from_agent`` the agent it was taken from
    when a re-plan gave it to this lane's agent; ``ticks`` its task's method changes then,
    ``waits`` and ``preempted`` its task's waits and lost skills then (as a :class:`TaskBar`'s)."""

    lane: str
    start: float
    end: float | None
    outcome: str
    label: str
    action: str
    plan: int
    version: int
    step: int
    task: int | None = None
    reason: str = ""
    from_agent: str | None = None
    ticks: tuple[MethodChange, ...] = ()
    waits: tuple[WaitSpan, ...] = ()
    preempted: tuple[Preemption, ...] = ()


@dataclass(frozen=True, slots=True)
class PlanLine:
    """A re-plan (``kind`` replanned) or an abandoned plan or goal (abandoned) at ``time``;
    ``label`` is its short text, ``lines`` the same wrapped."""

    time: float
    kind: str
    label: str
    plan: int
    version: int

    @property
    def lines(self) -> list[str]:
        return _wrap(self.label, LINE_LABEL_CHARS, LINE_LABEL_LINES)


@dataclass(frozen=True, slots=True)
class TaskBar:
    """A task posted (``depth`` 0) or one level below (1), from its first selection (or its
    posting) to its end; ``outcome`` done, failed, halted or running; ``reason`` why it
    failed or was halted; ``ticks`` its method changes; ``waits`` the spans in which it or a
    task below it waited (:func:`wait_spans`), within the bar; ``preempted`` the times a task
    of higher priority took a skill from it or from a task below it."""

    task: int
    text: str
    depth: int
    start: float
    end: float | None
    outcome: str
    reason: str = ""
    ticks: tuple[MethodChange, ...] = ()
    waits: tuple[WaitSpan, ...] = ()
    preempted: tuple[Preemption, ...] = ()


# Reading the records --------------------------------------------------------


def step_bars(records: Iterable[Mapping[str, Any]]) -> list[StepBar]:
    """The plan steps in ``records`` (trace records in time order; others are ignored), by start.

    A step is matched to its end by its RAP task (``step_task``), else by plan, version
    and step; it is done or failed by ``plan-step-done``/``-failed``, halted by a
    ``replanned`` that lists its action in ``halted``, by a ``plan-abandoned`` of the
    whole plan or by a ``task-halted`` of its task, and running when nothing ended it.
    A running step that a ``replanned`` re-assigns (``reassigned`` with ``running``)
    is cut there: the part before is ``handed-over``, the rest a new bar in the new
    agent's lane. A step that ends with another agent than it started with, with no such
    record, is cut at the plan's last re-plan (if it ran then).
    """
    records = list(records)
    segments: list[dict[str, Any]] = []
    current: dict[object, dict[str, Any]] = {}  # a step's key -> its latest segment
    last_replan: dict[int, tuple[float, int]] = {}
    versions: dict[int, set[int]] = {}
    for record in records:
        event = record.get("event")
        t = float(record.get("t", 0.0))
        if event not in _PLAN_RECORDS and event != Event.TASK_HALTED:
            continue
        plan = int(record.get("plan", 0))
        if "version" in record and event in _PLAN_RECORDS:
            versions.setdefault(plan, set()).add(int(record["version"]))
        if event == Event.PLAN_STEP_STARTED:
            key = _step_key(record)
            if key in current:  # started again (the same task): the first start counts
                continue
            current[key] = _segment(segments, key, record.get("agent"), t, plan, int(record.get("version", 1)),
                                    int(record.get("step", 0)), str(record.get("action", "")),
                                    record.get("step_task"))
        elif event in (Event.PLAN_STEP_DONE, Event.PLAN_STEP_FAILED):
            key = _step_key(record)
            seg = current.get(key)
            if seg is None or seg["outcome"] != "running":
                continue
            agent = record.get("agent") or NO_AGENT
            if agent != seg["lane"]:
                cut, ver = last_replan.get(plan, (t, 0))
                if seg["start"] < cut < t:  # handed over at that re-plan
                    seg = current[key] = _hand_over(segments, seg, agent, cut, ver or seg["version"],
                                                    int(record.get("step", seg["step"])),
                                                    str(record.get("action", seg["action"])))
            seg.update(end=t, outcome="done" if event == Event.PLAN_STEP_DONE else "failed",
                       reason=str(record.get("reason", "")))
        elif event == Event.TASK_HALTED:
            seg = current.get(("task", record.get("id")))
            if seg is not None and seg["outcome"] == "running":
                seg.update(end=t, outcome="halted", reason=str(record.get("reason", "")))
        elif event == Event.REPLANNED:
            ver = int(record.get("version", 1))
            last_replan[plan] = (t, ver)
            halted = set(map(str, record.get("halted") or ()))
            for seg in list(current.values()):
                if seg["plan"] == plan and seg["outcome"] == "running" and seg["action"] in halted:
                    seg.update(end=t, outcome="halted", reason=f"re-plan v{ver} dropped it")
            for entry in record.get("reassigned") or ():
                if not isinstance(entry, Mapping) or not entry.get("running"):
                    continue
                old, new, action = str(entry.get("from")), str(entry.get("to")), str(entry.get("action", ""))
                for key, seg in list(current.items()):
                    if (seg["plan"] == plan and seg["outcome"] == "running" and seg["lane"] == old
                            and _swap_agent(seg["action"], old, new) == action):
                        current[key] = _hand_over(segments, seg, new, t, ver, _step_number(entry.get("step")),
                                                  action)
                        break
        elif event == Event.PLAN_ABANDONED and record.get("scope", "plan") == "plan":
            for seg in current.values():
                if seg["plan"] == plan and seg["outcome"] == "running":
                    seg.update(end=t, outcome="halted", reason="the plan was abandoned")
    several_plans = len({s["plan"] for s in segments} | set(versions)) > 1
    changes = method_changes(records)
    waits = _Waits.read(records)
    bars = []
    for seg in segments:
        end = seg["end"] if seg["end"] is not None else float("inf")
        ticks = tuple(c for c in changes.get(seg["task"], ()) if seg["start"] <= c.t < end
                      or (c.t == end and seg["outcome"] != "handed-over"))
        prefix = (f"p{seg['plan']} " if several_plans else "") + \
                 (f"v{seg['version']} " if len(versions.get(seg["plan"], ())) > 1 else "")
        agent = None if seg["lane"] == NO_AGENT else seg["lane"]
        label = f"{prefix}s{seg['step']} {short_action(seg['action'], agent)}"
        if seg["from_agent"]:
            label += f" (from {seg['from_agent']})"
        label += "".join(f" \u2192 {cut_text(c.method, 16)}" for c in ticks if c.changed)
        bars.append(StepBar(seg["lane"], seg["start"], seg["end"], seg["outcome"], label, seg["action"], seg["plan"],
                            seg["version"], seg["step"], seg["task"], seg["reason"], seg["from_agent"], ticks,
                            **waits.on(seg["task"], seg["start"], seg["end"])))
    order = {id(b): i for i, b in enumerate(bars)}
    return sorted(bars, key=lambda b: (b.start, order[id(b)]))


def lanes(bars: Sequence[StepBar]) -> list[str]:
    """The lanes of ``bars``: agents in order of first use (the earliest start; ties in
    the order given), and :data:`NO_AGENT` last when a step has no agent."""
    first: dict[str, tuple[float, int]] = {}
    for i, bar in enumerate(bars):
        if bar.lane not in first or (bar.start, i) < first[bar.lane]:
            first[bar.lane] = (bar.start, i)
    agents = sorted((lane for lane in first if lane != NO_AGENT), key=lambda lane: first[lane])
    return agents + ([NO_AGENT] if NO_AGENT in first else [])


def plan_lines(records: Iterable[Mapping[str, Any]]) -> list[PlanLine]:
    """The re-plans and abandoned plans (or goals) in ``records``, in time order, with a
    short label: ``"re-plan v2: agent left-arm was lost"``, ``"abandoned (repaired site-b):
    3 failures"``, ``"plan abandoned: no plan meets the deadline: ..."`` (``p2 ``
    before it when the run has several plans)."""
    records = list(records)
    plans = {int(r.get("plan", 0)) for r in records if r.get("event") in _PLAN_RECORDS}
    out: list[PlanLine] = []
    for record in records:
        event = record.get("event")
        if event not in (Event.REPLANNED, Event.PLAN_ABANDONED):
            continue
        plan, ver, t = int(record.get("plan", 0)), int(record.get("version", 1)), float(record.get("t", 0.0))
        prefix = f"p{plan} " if len(plans) > 1 else ""
        if event == Event.REPLANNED:
            label = f"{prefix}re-plan v{ver}: {short_cause(str(record.get('cause', '')))}"
            out.append(PlanLine(t, "replanned", label.rstrip(": "), plan, ver))
        else:
            reason = short_cause(str(record.get("reason", "")))
            if record.get("scope") == "goal":
                goals = " ".join(_one_line(g) for g in record.get("goals") or ())
                head = f"{prefix}abandoned {goals}".rstrip()
            else:
                head = f"plan {plan} abandoned" if prefix else "plan abandoned"
            out.append(PlanLine(t, "abandoned", f"{head}: {reason}" if reason else head, plan, ver))
    return out


def method_changes(records: Iterable[Mapping[str, Any]]) -> dict[int, list[MethodChange]]:
    """Each task's method changes, by task id in time order: its ``method-selected``
    records with ``attempt`` > 1, each with the method selected before it (if recorded)."""
    out: dict[int, list[MethodChange]] = {}
    last: dict[int, str] = {}
    for record in records:
        if record.get("event") != Event.METHOD_SELECTED:
            continue
        task, method = record.get("id"), str(record.get("method", ""))
        if int(record.get("attempt", 1)) > 1:
            out.setdefault(task, []).append(
                MethodChange(float(record.get("t", 0.0)), method, int(record["attempt"]), last.get(task, "")))
        last[task] = method
    return out


def wait_spans(records: Iterable[Mapping[str, Any]]) -> dict[int, list[WaitSpan]]:
    """Each task's own waits, by task id in time order: from a ``task-waiting`` (with a
    ``skill``: for that skill; without: a retry's back-off) to the ``task-resumed`` that ends
    it (the same skill; no skill for a back-off), else to the task's next method choice or its
    end; ``end`` None when the records end first. A wait of no length is left out."""
    out: dict[int, list[WaitSpan]] = {}
    waiting: dict[int, dict[str | None, int]] = {}  # task -> skill (None: back-off) -> index in out[task]
    for record in records:
        event, task = record.get("event"), record.get("id")
        t = float(record.get("t", 0.0))
        skill = None if record.get("skill") is None else str(record["skill"])
        if event == Event.TASK_WAITING and skill not in waiting.get(task, {}):
            spans = out.setdefault(task, [])
            waiting.setdefault(task, {})[skill] = len(spans)
            spans.append(WaitSpan(t, None, "retry" if skill is None else "skill", task, skill or ""))
        elif event == Event.TASK_RESUMED:
            _end_waits(out, waiting, task, [skill], t)
        elif event in _TASK_ENDS or event == Event.METHOD_SELECTED:
            _end_waits(out, waiting, task, list(waiting.get(task, ())), t)
    return {task: [s for s in spans if s.end is None or s.end > s.start] for task, spans in out.items()}


def preemptions(records: Iterable[Mapping[str, Any]]) -> dict[int, list[Preemption]]:
    """The skills taken from each task (``skill-preempted``), by the holder's task id in time order."""
    out: dict[int, list[Preemption]] = {}
    for record in records:
        if record.get("event") == Event.SKILL_PREEMPTED:
            task = record.get("id")
            out.setdefault(task, []).append(Preemption(float(record.get("t", 0.0)), task, str(record.get("skill", "")),
                                                       str(record.get("winner", "")), str(record.get("outcome", ""))))
    return out


class _Waits(NamedTuple):
    """The waits and lost skills of a run's tasks, and each task's parent, to put on bars."""

    spans: dict[int, list[WaitSpan]]
    taken: dict[int, list[Preemption]]
    parents: dict[Any, Any]

    @classmethod
    def read(cls, records: Sequence[Mapping[str, Any]]) -> _Waits:
        parents = {r.get("id"): r.get("parent") for r in records if r.get("event") == Event.TASK_POSTED}
        return cls(wait_spans(records), preemptions(records), parents)

    def on(self, task: Any, start: float, end: float | None) -> dict[str, tuple]:
        """A bar's ``waits`` and ``preempted`` (of ``task`` and the tasks below it, from ``start``
        to ``end``), as keyword arguments."""
        if task is None or not (self.spans or self.taken):
            return {"waits": (), "preempted": ()}
        waits = []
        for span in self._below(self.spans, task):
            s0 = max(span.start, start)
            s1 = span.end if end is None else min(end, span.end if span.end is not None else end)
            if s1 is None or s1 > s0:
                waits.append(span._replace(start=s0, end=s1))
        taken = [p for p in self._below(self.taken, task) if start <= p.t and (end is None or p.t <= end)]
        return {"waits": tuple(waits), "preempted": tuple(taken)}

    def _below(self, by_task: Mapping[int, Sequence[Any]], task: Any) -> list[Any]:
        """The entries of ``task`` and of every task below it, by time (then task order)."""
        items = [item for other, entries in by_task.items() if self._is_under(other, task) for item in entries]
        return sorted(items, key=lambda item: item[0])

    def _is_under(self, other: Any, task: Any) -> bool:
        seen = set()
        while other is not None and other not in seen:
            if other == task:
                return True
            seen.add(other)
            other = self.parents.get(other)
        return False


def _end_waits(out: dict[int, list[WaitSpan]], waiting: dict[int, dict[str | None, int]], task: Any,
               skills: Sequence[str | None], t: float) -> None:
    for skill in skills:
        index = waiting.get(task, {}).pop(skill, None)
        if index is not None:
            out[task][index] = out[task][index]._replace(end=t)


def task_bars(records: Iterable[Mapping[str, Any]], skip: Iterable[int] = ()) -> list[TaskBar]:
    """The tasks posted (depth 0) and one level below them (depth 1) in ``records``, less
    those in ``skip`` (the plan steps' tasks), in tree order: each posted task, then its
    subtasks, in the order they were posted."""
    skip = set(skip)
    records = list(records)
    depth: dict[int, int] = {}
    parent_of: dict[int, int | None] = {}
    info: dict[int, dict[str, Any]] = {}
    for record in records:
        event = record.get("event")
        if event == Event.TASK_POSTED:
            tid, parent = record["id"], record.get("parent")
            depth[tid] = depth.get(parent, 0) + 1 if parent is not None else 0
            if depth[tid] <= 1 and tid not in skip:
                parent_of[tid] = parent
                info[tid] = {"text": str(record.get("task", "")), "posted": float(record.get("t", 0.0)),
                             "start": None, "end": None, "outcome": "running", "reason": ""}
        elif record.get("id") in info:
            item = info[record["id"]]
            t = float(record.get("t", 0.0))
            if event == Event.TASK_SELECTED and item["start"] is None:
                item["start"] = t
            elif event in _TASK_ENDS and item["end"] is None:
                item.update(end=t, outcome=_TASK_ENDS[event], reason=str(record.get("reason", "")))
    ticks = method_changes(records)
    waits = _Waits.read(records)
    order: list[int] = []
    for tid in info:  # posting order; each posted task followed by its subtasks
        if depth[tid] == 0:
            order.append(tid)
            order.extend(child for child in info if parent_of[child] == tid)
    order.extend(tid for tid in info if tid not in order)
    bars = []
    for tid in order:
        start = info[tid]["start"] if info[tid]["start"] is not None else info[tid]["posted"]
        bars.append(TaskBar(tid, info[tid]["text"], depth[tid], start, info[tid]["end"], info[tid]["outcome"],
                            info[tid]["reason"], tuple(ticks.get(tid, ())), **waits.on(tid, start, info[tid]["end"])))
    return bars


# Text ------------------------------------------------------------------------


def short_action(action: str, agent: str | None = None) -> str:
    """An action for a bar: without its parentheses and without ``agent`` (named by the
    lane), cut to :data:`MAX_ACTION_CHARS`: ``(repair-site left-arm site-b)`` ->
    ``repair-site site-b``."""
    text = _one_line(action)
    if text.startswith("(") and text.endswith(")"):
        text = text[1:-1]
    if agent:
        text = re.sub(rf"(?:(?<=\s)|(?<=\()){re.escape(agent)}(?=[\s)]|$)\s?", "", text).strip()
    return cut_text(text, MAX_ACTION_CHARS)


def short_cause(text: str) -> str:
    """Why a plan was repaired or given up, briefly: a failed step keeps its step and the
    last reason (``step s3 (repair-site left-arm site-b) failed: skill (...): finished
    :fail: the arm's tool is jammed`` -> ``s3 (repair-site left-arm site-b) failed: the arm's
    tool is jammed``); a reason with a ``; the last: ...`` keeps its first part (``3
    failures``); a closing ``((fact))`` goes."""
    text = _one_line(text)
    text = text.split("; the last:", 1)[0]
    text = re.sub(r"\s*\(\([^()]*(?:\([^()]*\)[^()]*)*\)\)$", "", text)
    failed = re.match(r"^(?:step )?(s\d+ \(.*?\)) failed: (.*)$", text)
    if failed:
        detail = re.split(r":\s+", failed.group(2))[-1]
        text = f"{failed.group(1)} failed: {detail}"
    return text


def stack_labels(items: Sequence[tuple[float, float, float]], gap: float = 0.0) -> list[float]:
    """Heights for labels above vertical lines so that no line crosses a label.

    ``items`` are ``(x, width, height)``: a line at ``x`` carrying a label that
    reaches from ``x`` to ``x + width``; each label sits at the top of its line, and
    a line reaches up to its label's top. The result is each label's bottom: on 0
    unless a later line (at an ``x`` under the label) reaches that high, then just above
    it (plus ``gap``)."""
    bottoms = [0.0] * len(items)
    order = sorted(range(len(items)), key=lambda i: (items[i][0], i), reverse=True)
    placed: list[int] = []
    for i in order:  # right to left: a label lies over lines placed already
        x, w, _ = items[i]
        under = [j for j in placed if x <= items[j][0] < x + w]
        bottoms[i] = max((bottoms[j] + items[j][2] + gap for j in under), default=0.0)
        placed.append(i)
    return bottoms


def pack_rows(extents: Sequence[tuple[float, float]]) -> list[int]:
    """The row of each ``(start, end)`` extent (in the order given, which should be by
    start): the first row whose extents so far all end at or before its start."""
    ends: list[float] = []
    rows = []
    for start, end in extents:
        for row, row_end in enumerate(ends):
            if row_end <= start:
                ends[row] = end
                rows.append(row)
                break
        else:
            ends.append(end)
            rows.append(len(ends) - 1)
    return rows


# Drawing ----------------------------------------------------------------------


def render_timeline(records: Iterable[Mapping[str, Any]], out_png: str | Path, title: str,
                    *, end: float | None = None) -> Path:
    """Draw the run in ``records`` (trace records in time order) as a timeline to the PNG
    ``out_png``; return its path. ``title`` is e.g. ``"evahr.rap, seed 0"``; ``end`` is
    the time the run has reached (bars still running reach it; default the last record's).
    The parent directory of ``out_png`` is created if needed."""
    from atlas_rap.views.plan_render import save_figure

    records = list(records)
    out = Path(out_png)
    out.parent.mkdir(parents=True, exist_ok=True)
    bars = step_bars(records)
    notes = plan_lines(records)
    tasks = task_bars(records, skip={b.task for b in bars if b.task is not None})
    axis = _time_axis(records, end)
    rows = _chart_rows(bars, tasks, axis)
    labels = _line_labels(notes, axis)
    fig, ax, head, key = _figure(rows.total, labels.height, axis, title)
    column = _name_column(rows)
    _draw_lanes(ax, rows, column)
    _draw_steps(ax, rows.steps, axis)
    _draw_tasks(ax, rows.tasks, column, axis)
    _draw_plan_lines(ax, head, notes, labels, axis)
    _legend(key, legend_labels(bars, tasks, notes))
    return save_figure(fig, out)


class _TimeAxis(NamedTuple):
    """The chart's time axis: the time the run has reached, the axis' limits and the seconds per inch."""

    t_end: float
    xmin: float
    xmax: float
    sec_per_inch: float


def _time_axis(records: Sequence[Mapping[str, Any]], end: float | None) -> _TimeAxis:
    """The time axis for ``records``, to the last record's time or ``end``, whichever is later."""
    last = max((float(r.get("t", 0.0)) for r in records), default=0.0)
    t_end = max(last, float(end) if end is not None else 0.0)
    span = t_end if t_end > 0 else 1.0
    xmin, xmax = -0.01 * span, t_end + 0.01 * span
    return _TimeAxis(t_end, xmin, xmax, (xmax - xmin) / CHART_WIDTH)


@dataclass
class _Rows:
    """The chart's rows, top to bottom (plan heading, lanes packed, task heading, tasks), in rows from
    the top: each step bar with its row's centre and where its label goes, each lane's name and span,
    the headings, each task shown with its row's centre, and the rows in all."""

    steps: list[tuple[StepBar, float, str]]
    lane_spans: list[tuple[str, float, float]]
    headings: list[tuple[float, str]]
    tasks: list[tuple[TaskBar, float]]
    total: float


def _chart_rows(bars: Sequence[StepBar], tasks: Sequence[TaskBar], axis: _TimeAxis) -> _Rows:
    """Lay out the rows: the plan steps in their lanes, each lane as few rows as its bars and labels
    take, then at most :data:`MAX_TASK_ROWS` tasks."""
    rows = _Rows([], [], [], [], 0.0)
    y = 0.0
    if bars:
        rows.headings.append((y + 0.45, "plan steps, a lane per agent"))
        y += 0.9
        for lane in lanes(bars):
            mine = [b for b in bars if b.lane == lane]
            places = [_label_place(b, axis.t_end, axis.sec_per_inch, axis.xmax) for b in mine]
            packed = pack_rows([extent for _, extent in places])
            for bar, (where, _), row in zip(mine, places, packed):
                rows.steps.append((bar, y + row + 0.5, where))
            rows.lane_spans.append((lane, y, y + max(packed) + 1))
            y += max(packed) + 1
        y += 0.35
    if tasks:
        rows.headings.append((y + 0.45, "tasks posted (bold) and their subtasks; plan steps above"
                              if bars else "tasks posted (bold) and their subtasks"))
        y += 0.9
        for task in tasks[:MAX_TASK_ROWS]:
            rows.tasks.append((task, y + 0.5))
            y += 1
        if len(tasks) > MAX_TASK_ROWS:
            rows.headings.append((y + 0.5, f"\u2026 and {len(tasks) - MAX_TASK_ROWS} more tasks"))
            y += 1
    if not bars and not tasks:
        rows.headings.append((0.5, "no tasks yet"))
        y = 1.0
    rows.total = y
    return rows


class _LineLabels(NamedTuple):
    """The labels of the re-plan and abandon lines, stacked above the chart: each one's (time, width
    in seconds, height in inches), each one's bottom, and the height of the band they take."""

    sizes: list[tuple[float, float, float]]
    bottoms: list[float]
    height: float


def _line_labels(notes: Sequence[PlanLine], axis: _TimeAxis) -> _LineLabels:
    """Stack the lines' labels so that no line crosses a label (:func:`stack_labels`)."""
    line_h = LINE_FONT * 1.22 / 72  # inches per text line
    sizes = [(n.time, (max(len(s) for s in n.lines) * CHAR_WIDTH * LINE_FONT / 72 + 0.08) * axis.sec_per_inch,
              len(n.lines) * line_h + 0.04) for n in notes]
    bottoms = stack_labels(sizes, gap=0.03)
    height = max((b + s[2] for b, s in zip(bottoms, sizes)), default=0.0) + 0.08
    return _LineLabels(sizes, bottoms, height)


def _name_column(rows: _Rows) -> float:
    """The width in points of the column left of the chart that names the lanes and tasks."""
    names = [len(lane) for lane, _, _ in rows.lane_spans] + [
        len(_task_text(t)) + INDENT / LEFT_FONT / CHAR_WIDTH * t.depth for t, _ in rows.tasks]
    return max(names, default=0) * CHAR_WIDTH * LEFT_FONT + 10


def _figure(total_rows: float, header_h: float, axis: _TimeAxis, title: str) -> tuple[Any, Any, Any, Any]:
    """The figure and its three axes: the chart (``total_rows`` rows), the band of line labels above
    it (``header_h`` inches, under the title) and the legend's below it."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    chart_h = total_rows * ROW
    legend_h, xlabel_h, title_h = 0.3, 0.45, 0.35
    fig_w = CHART_WIDTH + 2.5
    fig_h = legend_h + xlabel_h + chart_h + header_h + title_h
    fig = Figure(figsize=(fig_w, fig_h), dpi=_dpi())
    FigureCanvasAgg(fig)
    left = 2.2 / fig_w
    chart_bottom = legend_h + xlabel_h
    ax = fig.add_axes((left, chart_bottom / fig_h, CHART_WIDTH / fig_w, chart_h / fig_h))
    head = fig.add_axes((left, (chart_bottom + chart_h) / fig_h, CHART_WIDTH / fig_w, header_h / fig_h))
    key = fig.add_axes((left, 0.02 / fig_h, CHART_WIDTH / fig_w, (legend_h - 0.04) / fig_h))

    ax.set_xlim(axis.xmin, axis.xmax)
    ax.set_ylim(total_rows, 0)
    ax.set_yticks([])
    ax.set_xlabel("simulated time (s)", fontsize=8.5)
    ax.tick_params(axis="x", labelsize=8)
    ax.grid(True, axis="x", color="#e9ecef", linewidth=0.6, zorder=0)
    ax.set_axisbelow(True)
    for spine in ax.spines.values():
        spine.set_color("#adb5bd")
    head.set_xlim(axis.xmin, axis.xmax)
    head.set_ylim(0, header_h)
    head.axis("off")
    head.set_title(plain_text(f"{title} \u2014 timeline of the run (no world to draw)"), fontsize=11, loc="left",
                   pad=4)
    key.axis("off")
    return fig, ax, head, key


def _draw_lanes(ax, rows: _Rows, column: float) -> None:
    """The lanes (shaded every other one) and their names, the headings, and the rule between the
    plan steps and the tasks."""
    for i, (lane, top, bottom) in enumerate(rows.lane_spans):
        if i % 2 == 0:
            ax.axhspan(top, bottom, color=_LANE_SHADE, zorder=0.5, linewidth=0)
        _left_label(ax, (top + bottom) / 2, lane, column, bold=True)
    for yy, text in rows.headings:
        _left_label(ax, yy, text, column, italic=True, colour="#495057", size=7)
    if rows.lane_spans and rows.tasks:
        ax.axhline(rows.lane_spans[-1][2] + 0.175, color="#ced4da", linewidth=0.8, zorder=1)


def _draw_steps(ax, steps: Sequence[tuple[StepBar, float, str]], axis: _TimeAxis) -> None:
    """The plan steps' bars, with their waits, labels and method changes."""
    sec_per_inch = axis.sec_per_inch
    for bar, yc, where in steps:
        _draw_bar(ax, bar.start, bar.end if bar.end is not None else axis.t_end, yc, STEP_BAR, bar.outcome,
                  bar.end is None, edge=True)
        x0, x1 = bar.start, bar.end if bar.end is not None else axis.t_end
        _draw_waits(ax, bar, x1, yc, STEP_BAR)
        label = plain_text(bar.label)
        if where == "inside":
            ax.text(x0 + 0.05 * sec_per_inch, yc, label, ha="left", va="center", fontsize=FONT, color="white",
                    fontweight="bold", zorder=4, clip_on=False, **_inside_halo(bar))
        elif where == "left":
            ax.text(x0 - 0.05 * sec_per_inch, yc, label, ha="right", va="center", fontsize=FONT, color="#212529",
                    zorder=4, path_effects=_halo())
        else:
            ax.text(x1 + 0.05 * sec_per_inch, yc, label, ha="left", va="center", fontsize=FONT, color="#212529",
                    zorder=4, path_effects=_halo())
        _draw_ticks(ax, bar.ticks, yc, STEP_BAR, named=False)


def _draw_tasks(ax, tasks: Sequence[tuple[TaskBar, float]], column: float, axis: _TimeAxis) -> None:
    """The tasks' names left of the chart and their bars, with their waits, method changes, and why
    a task failed or was halted."""
    for task, yc in tasks:
        _left_label(ax, yc, _task_text(task), column, bold=task.depth == 0, indent=INDENT * task.depth)
        x1 = task.end if task.end is not None else axis.t_end
        _draw_bar(ax, task.start, x1, yc, TASK_BAR, task.outcome, task.end is None, edge=False)
        _draw_waits(ax, task, x1, yc, TASK_BAR)
        _draw_ticks(ax, task.ticks, yc, TASK_BAR, named=True, sec_per_inch=axis.sec_per_inch)
        if task.outcome in ("failed", "halted") and task.reason:
            _draw_reason(ax, task, x1, yc, axis)


def _draw_reason(ax, task: TaskBar, x1: float, yc: float, axis: _TimeAxis) -> None:
    """Why ``task`` failed or was halted, briefly: beside the end of its bar, or over the bar, ending
    where it ends, when there is no room after it."""
    sec_per_inch = axis.sec_per_inch
    words = plain_text(cut_text(f"{task.outcome}: {short_cause(task.reason).split('; ')[0]}", MAX_REASON_CHARS))
    width = len(words) * CHAR_WIDTH * 6.5 / 72 * sec_per_inch
    style = {"fontsize": 6.5, "color": _darker(task.outcome), "zorder": 4, "path_effects": _halo()}
    if x1 + width + 0.1 * sec_per_inch <= axis.xmax:  # beside the end of the bar
        ax.text(x1 + 0.06 * sec_per_inch, yc, words, ha="left", va="center", **style)
    else:  # no room after it: over the bar, ending where it ends
        ax.text(x1, yc - TASK_BAR / 2 - 0.05, words, ha="right", va="bottom", **style)


def _draw_plan_lines(ax, head, notes: Sequence[PlanLine], labels: _LineLabels, axis: _TimeAxis) -> None:
    """Re-plans and abandons: lines across the chart (under bars and text), labels above it."""
    for note, bottom, (_, _, h) in zip(notes, labels.bottoms, labels.sizes):
        colour, style, width = _LINE_STYLE[note.kind]
        ax.axvline(note.time, color=colour, linestyle=style, linewidth=width, zorder=1.5)
        head.plot([note.time, note.time], [0, bottom + h], color=colour, linestyle=style, linewidth=width,
                  clip_on=False, solid_capstyle="butt")
        head.text(note.time + 0.04 * axis.sec_per_inch, bottom + h - 0.02, plain_text("\n".join(note.lines)),
                  ha="left", va="top", fontsize=LINE_FONT, color=colour, linespacing=1.05)


def _halo(width: float = 2.4, colour: str = "white") -> list:
    from matplotlib import patheffects

    return [patheffects.withStroke(linewidth=width, foreground=colour)]


def _darker(outcome: str) -> str:
    return {"failed": "#c92a2a", "halted": "#495057"}.get(outcome, "#212529")


def _task_text(task: TaskBar) -> str:
    return cut_text(_one_line(task.text), MAX_TASK_CHARS)


def _draw_bar(ax, x0: float, x1: float, yc: float, height: float, outcome: str, running: bool, edge: bool) -> None:
    from matplotlib.patches import Rectangle

    colour = OUTCOME_COLOURS.get(outcome, "#495057")
    width = max(x1 - x0, 0.0)
    ax.add_patch(Rectangle((x0, yc - height / 2), width, height, facecolor=colour,
                           edgecolor="white" if edge else "none", linewidth=0.8 if edge else 0, zorder=2))
    if width == 0:  # an instant: a thin mark, so it shows
        ax.plot([x0, x0], [yc - height / 2, yc + height / 2], color=colour, linewidth=2, zorder=2)
    if running:  # no end yet: an open arrow head at the end of the run
        ax.plot([x1], [yc], marker=">", markersize=5, color=colour, linestyle="none", zorder=2.5, clip_on=False)


def _draw_ticks(ax, ticks: Sequence[MethodChange], yc: float, height: float, named: bool,
                sec_per_inch: float = 1.0) -> None:
    """Method changes on a bar: a tick each; with ``named``, the name of a new method above it
    (not of a retry), when it does not run into the last name written."""
    free_from = float("-inf")
    for t, method, _, previous in ticks:
        ax.plot([t, t], [yc - height / 2 - 0.12, yc + height / 2 + 0.12], color=_TICK_COLOUR, linewidth=1.3,
                zorder=3, solid_capstyle="butt")
        if named and method != previous and t >= free_from:
            text = plain_text(f"\u2192 {cut_text(method, 16)}")
            ax.text(t + 0.03 * sec_per_inch, yc - height / 2 - 0.08, text, ha="left", va="bottom", fontsize=6,
                    color=_TICK_COLOUR, zorder=4, path_effects=_halo(2.0))
            free_from = t + (len(text) * CHAR_WIDTH * 6 / 72 + 0.08) * sec_per_inch


def _left_label(ax, y: float, text: str, column: float, *, bold: bool = False, italic: bool = False,
                indent: float = 0, colour: str = "#212529", size: float = LEFT_FONT) -> None:
    """Text in the column (``column`` points wide) left of the chart, at row ``y``, ``indent`` points in."""
    ax.annotate(plain_text(text), (0, y), xycoords=("axes fraction", "data"), xytext=(-column + indent, 0),
                textcoords="offset points", ha="left", va="center", fontsize=size, color=colour,
                fontweight="bold" if bold else "normal", fontstyle="italic" if italic else "normal",
                annotation_clip=False, zorder=4, path_effects=_halo())


def legend_labels(bars: Sequence[StepBar], tasks: Sequence[TaskBar], notes: Sequence[PlanLine]) -> list[str]:
    """The legend's entries, in order: the outcomes shown, the kinds of line, method changes,
    waits (for a skill, before retrying) and skills taken, each only when the chart has it."""
    every: list[StepBar | TaskBar] = [*bars, *tasks]
    outcomes = {b.outcome for b in every}
    kinds = {n.kind for n in notes}
    waited = {w.kind for b in every for w in b.waits}
    return ([_OUTCOME_WORDS[o] for o in OUTCOME_COLOURS if o in outcomes]
            + [word for kind, word in _LINE_WORDS.items() if kind in kinds]
            + ([_TICK_WORD] if any(b.ticks for b in every) else [])
            + [word for kind, word in _WAIT_WORDS.items() if kind in waited]
            + ([_PREEMPT_WORD] if any(b.preempted for b in every) else []))


def _legend(key, labels: Sequence[str]) -> None:
    handles = [_legend_handle(label) for label in labels]
    if handles:
        # one row when it fits under the chart, else as few columns per row as it takes
        inches = [(len(h.get_label()) * CHAR_WIDTH * 7 + 40) / 72 for h in handles]
        ncol = len(handles)
        while ncol > 1 and sum(sorted(inches)[-ncol:]) > CHART_WIDTH:
            ncol -= 1
        key.legend(handles=handles, loc="upper left", ncol=ncol, fontsize=7, frameon=False,
                   handlelength=1.5, columnspacing=1.2, borderaxespad=0.0, bbox_to_anchor=(0.0, 1.0))


def _legend_handle(label: str) -> Any:
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    outcome = {word: o for o, word in _OUTCOME_WORDS.items()}.get(label)
    kind = {word: k for k, word in _LINE_WORDS.items()}.get(label)
    wait = {word: k for k, word in _WAIT_WORDS.items()}.get(label)
    if outcome is not None:
        return Patch(facecolor=OUTCOME_COLOURS[outcome], label=label)
    if kind is not None:
        colour, style, width = _LINE_STYLE[kind]
        return Line2D([], [], color=colour, linestyle=style, linewidth=width, label=label)
    if wait is not None:
        return Patch(facecolor=_tint(_WAIT_KEY_COLOUR), edgecolor=_WAIT_KEY_COLOUR, linewidth=0,
                     hatch=_WAIT_HATCH[wait], label=label)
    if label == _PREEMPT_WORD:
        return Line2D([], [], color=_PREEMPT_COLOUR, linestyle="none", marker="v", markersize=5, label=label)
    return Line2D([], [], color=_TICK_COLOUR, linestyle="none", marker="|", markersize=8,
                  markeredgewidth=1.3, label=label)


def _draw_waits(ax, bar: StepBar | TaskBar, x1: float, yc: float, height: float) -> None:
    """A bar's waits (drawn from its start to ``x1``): lighter and hatched, a pattern per kind;
    and a small mark above it where a task of higher priority took a skill."""
    from matplotlib.patches import Rectangle

    colour = OUTCOME_COLOURS.get(bar.outcome, "#495057")
    for span in bar.waits:
        s0, s1 = span.start, min(span.end if span.end is not None else x1, x1)
        if s1 > s0:
            ax.add_patch(Rectangle((s0, yc - height / 2), s1 - s0, height, facecolor=_tint(colour), edgecolor=colour,
                                   linewidth=0, hatch=_WAIT_HATCH[span.kind], zorder=2.2))
    for taken in bar.preempted:
        ax.plot([taken.t], [yc - height / 2 - 0.09], marker="v", markersize=4.5, color=_PREEMPT_COLOUR,
                linestyle="none", zorder=3.5, clip_on=False)


def _inside_halo(bar: StepBar) -> dict[str, Any]:
    """A white label inside a step bar keeps its contrast over a lighter (waiting) part."""
    return {"path_effects": _halo(1.5, OUTCOME_COLOURS.get(bar.outcome, "#495057"))} if bar.waits else {}


def _tint(colour: str, white: float = 0.6) -> str:
    """``colour`` mixed with ``white`` parts of white (a ``#rrggbb``)."""
    rgb = [int(colour[i:i + 2], 16) for i in (1, 3, 5)]
    return "#" + "".join(f"{round(c + (255 - c) * white):02x}" for c in rgb)


def _label_place(bar: StepBar, t_end: float, sec_per_inch: float, xmax: float) -> tuple[str, tuple[float, float]]:
    """Where a step's label goes (inside its bar, right of it, or left of it at the end of
    the chart) and the time the bar and label take, for packing into rows."""
    x0, x1 = bar.start, bar.end if bar.end is not None else t_end
    width = (len(bar.label) * CHAR_WIDTH * FONT / 72 + 0.1) * sec_per_inch
    pad = 0.06 * sec_per_inch
    if x1 - x0 >= width:
        return "inside", (x0, x1)
    if x1 + width + pad <= xmax:
        return "right", (x0, x1 + width + pad)
    return "left", (x0 - width - pad, x1 + pad)


def _segment(segments: list, key: object, agent: Any, t: float, plan: int, version: int, step: int, action: str,
             task: Any, from_agent: str | None = None) -> dict[str, Any]:
    seg = {"key": key, "lane": agent or NO_AGENT, "start": t, "end": None, "outcome": "running", "plan": plan,
           "version": version, "step": step, "action": action, "task": task, "reason": "", "from_agent": from_agent}
    segments.append(seg)
    return seg


def _hand_over(segments: list, seg: dict[str, Any], agent: str, t: float, version: int, step: int,
               action: str) -> dict[str, Any]:
    """End ``seg`` at ``t`` as handed over, and go on in ``agent``'s lane: the new segment."""
    seg.update(end=t, outcome="handed-over", reason=f"re-plan v{version} gave it to {agent}")
    return _segment(segments, seg["key"], agent, t, seg["plan"], version, step, action, seg["task"],
                    from_agent=seg["lane"])


def _swap_agent(action: str, old: str, new: str) -> str:
    return re.sub(rf"(?:(?<=\s)|(?<=\()){re.escape(old)}(?=[\s)])", new, action)


def _step_number(text: Any) -> int:
    match = re.search(r"\d+", str(text))
    return int(match.group()) if match else 0


def _step_key(record: Mapping[str, Any]) -> object:
    task = record.get("step_task")
    if task is not None:
        return ("task", task)
    return ("step", record.get("plan"), record.get("version"), record.get("step"))


_PLAN_RECORDS = frozenset({Event.PLAN_REQUESTED, Event.PLAN_READY, Event.PLAN_STEP_STARTED, Event.PLAN_STEP_DONE,
                           Event.PLAN_STEP_FAILED, Event.REPLANNED, Event.PLAN_ABANDONED, Event.PLAN_DONE})
_TASK_ENDS = {Event.TASK_SUCCEEDED: "done", Event.TASK_FAILED: "failed", Event.TASK_HALTED: "halted"}


def _wrap(text: str, width: int, lines: int) -> list[str]:
    wrapped = textwrap.wrap(text, width, break_long_words=True, break_on_hyphens=False) or [""]
    if len(wrapped) > lines:
        wrapped = wrapped[:lines]
        wrapped[-1] = cut_text(wrapped[-1] + " \u2026", width) if len(wrapped[-1]) < width - 1 \
            else wrapped[-1][: width - 1] + "\u2026"
    return wrapped


def _one_line(text: Any) -> str:
    return " ".join(str(text).split())



def _dpi() -> float:
    from atlas_rap.views.page import DPI

    return DPI
