"""How the CLI shows a run: live trace lines, the task tree, memory, the summary.

Everything here turns sequencer data into rich renderables; ``cli/`` is the
only place that prints. The REPL uses the same views.
"""

from __future__ import annotations

from rich.console import Console
from rich.table import Table
from rich.text import Text
from rich.tree import Tree

from atlas_rap.sequencer.introspect import STATUS_MARKS, TaskView, describe

_STATUS_STYLES = {"pending": "dim", "running": "cyan", "succeeded": "green", "failed": "red", "halted": "yellow"}


class LiveTrace:
    """A trace sink that prints each record as one readable line, indented by task depth.

    ``verbose`` also shows task selections and skill disables, which are
    frequent and mostly predictable.
    """

    def __init__(self, console: Console, *, verbose: bool = False) -> None:
        self.console = console
        self.verbose = verbose
        self._depth: dict[int, int] = {}

    def __call__(self, record: dict) -> None:
        line = self.format(record)
        if line is not None:
            self.console.print(line, soft_wrap=True)

    def format(self, record: dict) -> Text | None:
        """The line for one record, or None for records this view leaves out."""
        event = record["event"]
        task_id = record.get("id")
        if event == "task-posted":
            parent = record.get("parent")
            self._depth[task_id] = self._depth.get(parent, -1) + 1 if parent is not None else 0
        indent = "  " * self._depth.get(task_id, 0) if task_id is not None else ""
        who = f"[{task_id}] {record.get('task', '')}"
        text = Text(f"{record['t']:9.2f}  ", style="dim")
        if event == "task-posted":
            extra = "" if record.get("parent") is not None else f" (priority {record['priority']:g}"
            if extra:
                extra += f", deadline {record['deadline']:g} s)" if "deadline" in record else ")"
            return text.append(f"{indent}○ {who} posted{extra}")
        if event == "task-selected":
            return text.append(f"{indent}  {who} selected", style="dim") if self.verbose else None
        if event == "method-selected":
            return text.append(f"{indent}▶ {who} method {record['method']} (attempt {record['attempt']})",
                               style="cyan")
        if event == "task-succeeded":
            return text.append(f"{indent}✓ {who} succeeded", style="green")
        if event == "task-failed":
            because = f" (because {record['because']})" if "because" in record else ""
            return text.append(f"{indent}✗ {who} failed: {record['reason']}{because}", style="bold red")
        if event == "task-halted":
            return text.append(f"{indent}⊘ {who} halted: {record['reason']}", style="yellow")
        if event == "step-outcome":
            failed = record["outcome"] in (":fail", ":timeout")
            why = f": {record['reason']}" if "reason" in record else ""
            return text.append(f"{indent}  → {record['step']} {record['outcome']}{why}",
                               style="red" if failed else "dim")
        if event == "skill-enabled":
            return text.append(f"{indent}  ⚙ enable {record['skill']}", style="magenta")
        if event == "skill-disabled":
            return text.append(f"{indent}  ⚙ disable {record['skill']}", style="dim") if self.verbose else None
        if event in ("fact-asserted", "fact-retracted"):
            sign = "+" if event == "fact-asserted" else "-"
            by = f"  ({record['by']})" if "by" in record else ""
            return text.append(f"  {sign} {record['fact']}", style="blue").append(by, style="dim")
        return text.append(f"{event} " + " ".join(f"{k}={v}" for k, v in record.items() if k not in ("t", "event")))


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
              "time-limit": " (time limit reached)", "interrupted": " (interrupted)"}[result.ended_by]
    style = "bold green" if result.ok else "bold red"
    lines = [Text(f"{mission_name}: {done} of {len(result.tasks)} posted tasks succeeded in "
                  f"{result.time:g} s simulated ({wall_seconds:.2f} s wall){ending}", style=style)]
    for task in result.tasks:
        mark = STATUS_MARKS[task.status]
        when = f" at {task.ended:g} s" if task.ended is not None else ""
        lines.append(Text(f"  {mark} {task.text} {task.status}{when}", style=_STATUS_STYLES[task.status]))
        if task.failure is not None:
            first, *causes = task.failure.chain()
            lines.append(Text(f"      {first.reason}", style="red"))
            for depth, failure in enumerate(causes, 1):
                lines.append(Text("      " + "  " * depth + f"{failure.what}: {failure.reason}", style="red"))
    return lines
