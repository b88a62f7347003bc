"""The RAP sequencer: tasks on an agenda, methods chosen by context, task nets, wait-for.

Loading and running missions is the mission engine's (``atlas_rap.layers.engine``),
which drives this package for ``atlas run`` and ``atlas repl`` alike.

- ``interpreter``: :class:`Sequencer`, the RAP interpreter.
- ``status``: task statuses, step states and step outcomes, as ``str`` enums.
- ``task``, ``agenda``: tasks and their failures; the agenda.
- ``host``: what a method's net and a plan execution need of the interpreter
  (narrow protocols by role, which :class:`Sequencer` satisfies).
- ``net``: a running method's task net or primitive.
- ``deliberation``: a plan carried out, watched and repaired.
- ``waiting``: the wait index that wakes waiting branches.
- ``trace``: trace records and sinks.
- ``checks``: load-time checks of a program against its skills.
- ``introspect``: the agenda as a task tree.

The skill link and the timers are the skill bus's (``atlas_rap.skillbus``):
the seam the sequencer shares with the skills.
"""

from atlas_rap.sequencer.interpreter import DEFAULT_MAX_DEPTH, DEFAULT_RETRIES, Sequencer
from atlas_rap.sequencer.introspect import TaskView, agenda_tree, tree_text
from atlas_rap.sequencer.status import Outcome, Status
from atlas_rap.sequencer.task import FAILED, HALTED, PENDING, RUNNING, SUCCEEDED, Failure, Task
from atlas_rap.sequencer.trace import EVENTS, JsonlSink, Trace

__all__ = [
    "DEFAULT_MAX_DEPTH", "DEFAULT_RETRIES", "EVENTS", "FAILED", "Failure", "HALTED", "JsonlSink", "Outcome",
    "PENDING", "RUNNING", "SUCCEEDED", "Sequencer", "Status", "Task", "TaskView", "Trace", "agenda_tree", "tree_text",
]
