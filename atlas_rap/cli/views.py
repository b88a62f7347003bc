"""How the CLI shows a run: live trace lines, the task tree, memory, the summary.

Everything here turns sequencer data into rich renderables; ``cli/`` is the
only place that prints. The REPL uses the same views.
"""

from __future__ import annotations

import re

from rich.console import Console
from rich.table import Table
from rich.text import Text
from rich.tree import Tree

from atlas_rap.sequencer.introspect import STATUS_MARKS, TaskView, describe
from atlas_rap.sequencer.net import FAILURE_OUTCOMES
from atlas_rap.sequencer.task import Failure
from atlas_rap.trace_events import Event

_STATUS_STYLES = {"pending": "dim", "running": "cyan", "succeeded": "green", "failed": "red", "halted": "yellow"}


QUIET_FACTS = ("(layer-setting ", "(map-quality ", "(primary-layer ", "(mapping ")
"""Facts the live trace shows only with ``--verbose``: the layers' settings, the map quality
every 2 s, and the primary layer (shown as its own ``⇄`` line)."""


DEEPEST_INDENT = 16
"""Task depth up to which the live trace indents; deeper tasks (a runaway recursion) show their depth."""


def _indent(depth: int) -> str:
    if depth <= DEEPEST_INDENT:
        return "  " * depth
    return "  " * DEEPEST_INDENT + f"[depth {depth}] "


class LiveTrace:
    """A trace sink that prints each record as one readable line, indented by task depth.

    ``verbose`` also shows task selections and skill disables, which are
    frequent and mostly predictable, and the layers' bookkeeping facts
    (:data:`QUIET_FACTS`).
    """

    def __init__(self, console: Console, *, verbose: bool = False) -> None:
        self.console = console
        self.verbose = verbose
        self._depth: dict[int, int] = {}
        self._because: str | None = None  # the cause of the last failure shown, not repeated up a chain

    def __call__(self, record: dict) -> None:
        line = self.format(record)
        if line is not None:
            self.console.print(line, soft_wrap=True)

    def format(self, record: dict) -> Text | None:
        """The line for one record, or None for records this view leaves out."""
        event = record["event"]
        task_id = record.get("id")
        if event == Event.TASK_POSTED:
            parent = record.get("parent")
            self._depth[task_id] = self._depth.get(parent, -1) + 1 if parent is not None else 0
        indent = _indent(self._depth.get(task_id, 0)) if task_id is not None else ""
        who = f"[{task_id}] {record.get('task', '')}"
        text = Text(f"{record['t']:9.2f}  ", style="dim")
        if event == Event.TASK_POSTED:
            extra = "" if record.get("parent") is not None else f" (priority {record['priority']:g}"
            if extra:
                extra += f", deadline {record['deadline']:g} s)" if "deadline" in record else ")"
            return text.append(f"{indent}○ {who} posted{extra}")
        if event == Event.TASK_SELECTED:
            return text.append(f"{indent}  {who} selected", style="dim") if self.verbose else None
        if event == Event.METHOD_SELECTED:
            return text.append(f"{indent}▶ {who} method {record['method']} (attempt {record['attempt']})",
                               style="cyan")
        if event == Event.TASK_SUCCEEDED:
            return text.append(f"{indent}✓ {who} succeeded", style="green")
        if event == Event.TASK_FAILED:
            because = record.get("because")
            if because is not None and because == self._because:  # a parent failing for its child's cause
                because = " (the same cause)"
            else:
                self._because = because
                because = f" (because {because})" if because is not None else ""
            return text.append(f"{indent}✗ {who} failed: {record['reason']}{because}", style="bold red")
        if event == Event.TASK_HALTED:
            return text.append(f"{indent}⊘ {who} halted: {record['reason']}", style="yellow")
        if event == Event.STEP_OUTCOME:
            failed = record["outcome"] in FAILURE_OUTCOMES
            why = f": {record['reason']}" if "reason" in record else ""
            return text.append(f"{indent}  → {record['step']} {record['outcome']}{why}",
                               style="red" if failed else "dim")
        if event == Event.SKILL_ENABLED:
            return text.append(f"{indent}  ⚙ enable {record['skill']}", style="magenta")
        if event == Event.SKILL_DISABLED:
            return text.append(f"{indent}  ⚙ disable {record['skill']}", style="dim") if self.verbose else None
        if event == Event.SKILL_PREEMPTED:
            then = "it waits to resume" if record["outcome"] == ":halted" else "its step fails"
            return text.append(f"{indent}  ⚠ [{record['winner_id']}] {record['winner']} took {record['skill']} "
                               f"from {who}: {then}", style="yellow")
        if event == Event.TASK_WAITING:
            return text.append(f"{indent}⏸ {who} waits for {_waited_for(record)}", style="yellow")
        if event == Event.TASK_RESUMED:
            after = f"after {record['waited']:g} s"
            if "skill" in record:
                then = f": it chooses its method again ({record['rechoose']})" if "rechoose" in record else ""
                return text.append(f"{indent}⏵ {who} has {record['skill']} {after}{then}", style="yellow")
            return text.append(f"{indent}⏵ {who} tries again {after} ({record['by']})", style="yellow")
        if event in (Event.SKILL_WAITING, Event.SKILL_RESUMED):
            mark = "⏸" if event == Event.SKILL_WAITING else "⏵"
            return text.append(f"  {mark} {record['skill']}: {record['reason']}", style="yellow")
        if event == Event.MEMORY_ERROR:
            return text.append(f"  ✗ memory error on {record['fact']}: {record['error']}", style="bold red")
        if event == Event.LAYER_SWITCHED:
            was = f" (was {record['previous']})" if record.get("previous") else ""
            return text.append(f"  ⇄ Layer {record['layer']} primary{was}: {record['reason']}", style="bold cyan")
        if event.startswith("plan-") or event == Event.REPLANNED:
            line = _plan_line(text, indent, record)
            if line is not None:
                return line
        if event in (Event.FACT_ASSERTED, Event.FACT_RETRACTED):
            if not self.verbose and record["fact"].startswith(QUIET_FACTS):
                return None
            sign = "+" if event == Event.FACT_ASSERTED else "-"
            by = f"  ({record['by']})" if "by" in record else ""
            return text.append(f"  {sign} {record['fact']}", style="blue").append(by, style="dim")
        return text.append(f"{event} " + " ".join(f"{k}={v}" for k, v in record.items() if k not in ("t", "event")))


def _waited_for(record: dict) -> str:
    """What a ``task-waiting`` record waits for: a skill and its holder, or a change before a retry."""
    if "skill" in record:
        holder = f" held by [{record['holder_id']}] {record['holder']}" if "holder_id" in record else ""
        return f"{record['skill']}{holder}"
    changes = f"a change of {', '.join(record['watching'])} or " if record.get("watching") else ""
    return f"{changes}t={record['until']:g} s before its next attempt"


def _plan_line(text: Text, indent: str, record: dict) -> Text | None:
    """A plan executive's record (``sequencer.deliberation``) as one line marked ◆ (None: not one
    this view knows)."""
    event = record["event"]
    version = f" v{record['version']}" if record.get("version", 1) > 1 else ""
    n = f"{record['plan']}{version}" if event.startswith("plan-step") else record["plan"]
    if event == Event.PLAN_REQUESTED:
        deadline = f" by t={record['deadline']:g} s" if "deadline" in record else ""
        return text.append(f"{indent}  ◆ plan {n}: planning for {' '.join(record['goals'])}{deadline}", style="cyan")
    if event == Event.PLAN_READY:
        steps = f"{record['steps']} step{'' if record['steps'] == 1 else 's'}"
        return text.append(f"{indent}  ◆ plan {n}{version} ready after {record['latency']:g} s: "
                           f"{steps}, makespan {record['makespan']:g} s: "
                           + ", ".join(record["actions"]), style="bold cyan")
    if event == Event.PLAN_STEP_STARTED:
        agent = f" [{record['agent']}]" if record.get("agent") else ""
        return text.append(f"{indent}  ◆ plan {n} s{record['step']} {record['action']}{agent} starts", style="cyan")
    if event == Event.PLAN_STEP_DONE:
        return text.append(f"{indent}  ◆ plan {n} s{record['step']} {record['action']} done", style="green")
    if event == Event.PLAN_STEP_FAILED:
        return text.append(f"{indent}  ◆ plan {n} s{record['step']} {record['action']} failed: {record['reason']}",
                           style="red")
    if event == Event.REPLANNED:
        moved = "; ".join(f"{r['action']} {r['from']}→{r['to']}" for r in record["reassigned"])
        parts = [f"kept {len(record['kept'])}", f"new {len(record['new'])}", f"halted {len(record['halted'])}",
                 f"done before {len(record['done'])}"] + ([f"re-assigned {moved}"] if moved else [])
        return text.append(f"{indent}  ◆ plan {n} re-planned{version} ({record['cause']}): " + ", ".join(parts),
                           style="bold yellow")
    if event == Event.PLAN_ABANDONED:
        what = "gave up " + " ".join(record["goals"]) if record["scope"] == "goal" else "abandoned"
        return text.append(f"{indent}  ◆ plan {n} {what}: {record['reason']}", style="bold red")
    if event == Event.PLAN_DONE:
        return text.append(f"{indent}  ◆ plan {n} done: {' '.join(record['goals'])}", style="bold green")
    return None  # another plan record: the generic line


def task_tree(nodes: list[TaskView], title: str = "agenda") -> Tree:
    """The agenda as a rich tree with status marks."""
    tree = Tree(Text(title, style="bold"))

    def add(branch: Tree, node: TaskView) -> None:
        child = branch.add(Text(describe(node), style=_STATUS_STYLES.get(node.status, "")))
        for sub in node.children:
            add(child, sub)

    for node in nodes:
        add(tree, node)
    return tree


def memory_table(memory, pattern=None) -> Table:
    """Memory as a table: each fact and when it was asserted, in assertion order."""
    from atlas_rap.logic import term_to_str

    table = Table(title="memory", show_lines=False)
    table.add_column("fact")
    table.add_column("since (s)", justify="right")
    rows = memory.items() if pattern is None else ((fact, memory.time_of(fact)) for fact in memory.facts(pattern))
    for fact, time in rows:
        table.add_row(term_to_str(fact), f"{time:g}")
    return table


def summary(result, mission_name: str, wall_seconds: float) -> list[Text]:
    """Lines that say how the run ended: each posted task and, for failures, the chain of causes."""
    done = sum(task.status == "succeeded" for task in result.tasks)
    ending = {"done": "", "stalled": " (stalled: nothing more could happen)",
              "time-limit": " (time limit reached)", "interrupted": " (interrupted)",
              "error": " (stopped by a memory error)"}[result.ended_by]
    style = "bold green" if result.ok else "bold red"
    lines = [Text(f"{mission_name}: {done} of {len(result.tasks)} posted tasks succeeded in "
                  f"{result.time:g} s simulated ({wall_seconds:.2f} s wall){ending}", style=style)]
    lines += [Text(f"  {note}", style="red") for note in result.notes]
    for task in result.tasks:
        mark = STATUS_MARKS[task.status]
        when = f" at {task.ended:g} s" if task.ended is not None else ""
        lines.append(Text(f"  {mark} {task.text} {task.status}{when}", style=_STATUS_STYLES[task.status]))
        if task.failure is not None:
            lines += [Text("      " + line, style="red") for line in failure_lines(task.failure)]
    return lines


FOLD_AFTER = 2
"""Repeats of a stretch of a failure chain shown before the rest of the run is folded."""

LONGEST_CHAIN = 24
"""Levels of a failure chain shown in full; a longer one that does not repeat is cut in the middle."""


def failure_lines(failure: Failure) -> list[str]:
    """A failure chain as indented lines, outermost first, for people.

    A chain that repeats itself (a RAP that calls itself without end, with
    the same arguments or new ones at each level) is folded: its root cause
    comes first, then the first repeats, then one line such as
    ``… 60 more levels of (loop) …`` (or ``… 57 more levels of (count …),
    (count 3) to (count 59) …``), then the innermost levels. A long chain
    that does not repeat keeps its ends and says how many levels are left out.
    """
    first, *causes = failure.chain()
    levels = [(0, first.reason)] + [(depth, f"{f.what}: {f.reason}") for depth, f in enumerate(causes, 1)]
    period, start, repeats = _repetition([(_shape(f.what), _shape(f.reason)) for f in causes])
    root = failure.root()
    if repeats <= FOLD_AFTER + 1:
        if len(levels) <= LONGEST_CHAIN:
            return ["  " * depth + text for depth, text in levels]
        keep = LONGEST_CHAIN // 2
        cut = len(levels) - 2 * keep
        return ([f"cause: {root.what}: {root.reason}"] + ["  " * d + text for d, text in levels[:keep]]
                + ["  " * keep + f"… {cut} more levels …"]
                + ["  " * (keep + 1 + i) + text for i, (_, text) in enumerate(levels[-keep:])])
    shown = max(1, min(FOLD_AFTER, 6 // period))  # a cycle through several RAPs is shown once
    head = levels[:1 + start + period * shown]
    folded = repeats - shown - 1
    tail = levels[1 + start + period * (repeats - 1):]
    depth = head[-1][0]
    lines = [f"cause: {root.what}: {root.reason}"]
    lines += ["  " * d + text for d, text in head]
    what = _folded_what(causes[start + period * shown:start + period * (repeats - 1)], first.what)
    plural = "s" if folded != 1 else ""
    more = f"{folded} more time{plural} round" if " > " in what else f"{folded} more level{plural} of"
    lines.append("  " * (depth + 1) + f"… {more} {what} …")  # a cycle through several RAPs counts rounds
    lines += ["  " * (depth + 1 + i) + text for i, (_, text) in enumerate(tail, 1)]
    return lines


def _folded_what(folded: list[Failure], default: str) -> str:
    """What repeats in the folded levels: ``(loop)``, ``(pong 1) > (ping 1)`` for RAPs that call each other,
    or ``(count …), (count 3) to (count 59)`` when the arguments change from level to level."""
    tasks = [f.what for f in folded if f.what.startswith("(")]
    if not tasks:
        return default
    cycle = list(dict.fromkeys(tasks))
    shapes = list(dict.fromkeys(_shape(task) for task in tasks))
    if len(cycle) == len(shapes):
        return " > ".join(cycle)
    return " > ".join(shape.replace(")", " …)", 1) for shape in shapes) + f", {tasks[0]} to {tasks[-1]}"


def _shape(text: str) -> str:
    """``text`` with every parenthesised task or fact cut to its name: ``step (count 3): ...`` and
    ``step (count 4): ...`` have one shape, so a recursion whose arguments change still folds."""
    shaped = _ARGS.sub(r"(\1)", text)
    while shaped != text:
        text, shaped = shaped, _ARGS.sub(r"(\1)", shaped)
    return shaped


_ARGS = re.compile(r"\(([^()\s]+)\s[^()]*\)")


def _repetition(items: list[tuple[str, str]]) -> tuple[int, int, int]:
    """The longest run of one repeated stretch in ``items``: (period, start, repeats)."""
    best = (1, 0, 1)
    for period in range(1, 7):
        for start in range(0, min(period, len(items))):
            repeats = 1
            while (start + period * (repeats + 1) <= len(items)
                   and items[start + period * repeats:start + period * (repeats + 1)] == items[start:start + period]):
                repeats += 1
            if repeats * period > best[2] * best[0]:
                best = (period, start, repeats)
    return best
