"""The RAP sequencer: tasks on an agenda, methods chosen by context, task nets, wait-for.

Loading and running missions is the mission engine's (``atlas_rap.layers.engine``),
which drives this package for ``atlas run`` and ``atlas repl`` alike.

- ``interpreter``: :class:`Sequencer`, the RAP interpreter.
- ``task``, ``agenda``: tasks, their statuses and failures; the agenda.
- ``net``: a running method's task net or primitive.
- ``waiting``: the wait index that wakes waiting branches.
- ``trace``: trace records and sinks.
- ``checks``: load-time checks of a program against its skills.
- ``introspect``: the agenda as a task tree.

The skill link and the timers are the skill bus's (``atlas_rap.skillbus``):
the seam the sequencer shares with the skills.
"""

from atlas_rap.sequencer.interpreter import DEFAULT_MAX_DEPTH, DEFAULT_RETRIES, Sequencer
from atlas_rap.sequencer.introspect import TaskView, agenda_tree, tree_text
from atlas_rap.sequencer.task import FAILED, HALTED, PENDING, RUNNING, SUCCEEDED, Failure, Task
from atlas_rap.sequencer.trace import EVENTS, JsonlSink, Trace

__all__ = [
    "DEFAULT_MAX_DEPTH", "DEFAULT_RETRIES", "EVENTS", "FAILED", "Failure", "HALTED", "JsonlSink",
    "PENDING", "RUNNING", "SUCCEEDED", "Sequencer", "Task", "TaskView", "Trace", "agenda_tree", "tree_text",
]
