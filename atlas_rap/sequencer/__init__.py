"""The RAP sequencer: tasks on an agenda, methods chosen by context, task nets, wait-for.

- ``interpreter``: :class:`Sequencer`, the RAP interpreter.
- ``task``, ``agenda``: tasks, their statuses and failures; the agenda.
- ``net``: a running method's task net or primitive.
- ``waiting``: the wait index that wakes waiting branches.
- ``timers``, ``trace``: the simulated clock's timers; trace records and sinks.
- ``skill_link``: the narrow interface to skills (enable, disable, facts back).
- ``checks``: load-time checks of a program against its skills.
- ``mission``: loading and running a mission file.
- ``introspect``: the agenda as a task tree.
"""

from atlas_rap.sequencer.interpreter import DEFAULT_MAX_DEPTH, DEFAULT_RETRIES, Sequencer
from atlas_rap.sequencer.introspect import TaskView, agenda_tree, tree_text
from atlas_rap.sequencer.mission import Mission, RunResult, load_mission
from atlas_rap.sequencer.skill_link import NoSkills, SkillHost, SkillLink
from atlas_rap.sequencer.task import FAILED, HALTED, PENDING, RUNNING, SUCCEEDED, Failure, Task
from atlas_rap.sequencer.timers import Timers
from atlas_rap.sequencer.trace import EVENTS, JsonlSink, Trace

__all__ = [
    "DEFAULT_MAX_DEPTH", "DEFAULT_RETRIES", "EVENTS", "FAILED", "Failure", "HALTED", "JsonlSink",
    "Mission", "NoSkills", "PENDING", "RUNNING", "RunResult", "SUCCEEDED", "Sequencer", "SkillHost",
    "SkillLink", "Task", "TaskView", "Timers", "Trace", "agenda_tree", "load_mission", "tree_text",
]
