"""Moving a running System's time: run until the posted tasks end, advance a while, finish, halt.

Functions over a :class:`~atlas_rap.layers.system.System` (its driver moves
the world, the skills and the timers; the sequencer is asked what is live),
which the mission engine calls for ``atlas run``, the REPL, ``atlas map
build`` and the experiment. How a run stopped is a :class:`RunEnd`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from atlas_rap.layers.executive import Pace, Stop
from atlas_rap.layers.system import System
from atlas_rap.sequencer import Task
from atlas_rap.sequencer.introspect import waiting_for
from atlas_rap.sequencer.task import SUCCEEDED
from atlas_rap.trace_events import TextEnum

__all__ = ["DEFAULT_TIME_LIMIT", "RunEnd", "RunResult", "advance", "finish", "halt_live", "run", "take_fault"]

DEFAULT_TIME_LIMIT = 3600.0
"""Simulated seconds a mission may run before its remaining tasks fail (``--until``)."""


class RunEnd(TextEnum):
    """How a run stopped. A ``str``: its value is what traces, JSON and messages have always said."""

    DONE = "done"
    """Every posted task ended."""
    STALLED = "stalled"
    """Nothing more could happen: no timer is due and no event can arrive."""
    TIME_LIMIT = "time-limit"
    """The simulated time limit (``--until``) came."""
    STOPPED = "stopped"
    """The caller's ``stop()`` said so (the REPL's Ctrl-C during ``:run``)."""
    INTERRUPTED = "interrupted"
    """Ctrl-C during the run; the live tasks were halted."""
    ERROR = "error"
    """A memory rule broke; the run's notes say how."""


@dataclass
class RunResult:
    """How a run ended: the posted tasks (with their outcomes), the time, and why it stopped."""

    tasks: list[Task]
    time: float
    ended_by: RunEnd = RunEnd.DONE
    notes: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """True when every posted task succeeded."""
        return bool(self.tasks) and all(task.status == SUCCEEDED for task in self.tasks)


def take_fault(system: System) -> str | None:
    """Why memory rules stopped the run, if they did since the last call (then forgotten)."""
    seq = system.sequencer
    fault, seq.fault = seq.fault, None
    return fault


def run(system: System, until: float = DEFAULT_TIME_LIMIT, *, pace: Pace | None = None,
        stop: Stop | None = None) -> RunEnd:
    """Run until every posted task has ended, ``until`` or ``stop()``; how it stopped. Tasks still
    running are left running."""
    ended = system.driver.run(until, pace, stop)
    return RunEnd.ERROR if system.sequencer.fault is not None else RunEnd(ended)


def advance(system: System, seconds: float, *, pace: Pace | None = None, stop: Stop | None = None) -> None:
    """Let ``seconds`` of simulated time pass (world, skills, timers), tasks or not."""
    system.driver.advance(seconds, pace, stop)


def finish(system: System, ended_by: RunEnd | str, until: float = DEFAULT_TIME_LIMIT) -> RunResult:
    """The result of a run that ended by ``ended_by``; tasks still live fail, saying what they waited for."""
    seq = system.sequencer
    fault = take_fault(system)
    result = RunResult(list(seq.roots), seq.now(), RunEnd(ended_by), [fault] if fault else [])
    for task in seq.live_roots():
        waits = waiting_for(task)
        waiting = f"; it was waiting for {', '.join(waits)}" if waits else ""
        if ended_by == RunEnd.STALLED:
            why = f"nothing more can happen (no timer is due and no event can arrive){waiting}"
        else:
            why = f"still running at the time limit of {until:g} s{waiting}"
        seq.cancel(task, why)
    return result


def halt_live(system: System, why: str) -> list[Task]:
    """Halt every live posted task (and disable every skill they enabled); the tasks halted."""
    seq = system.sequencer
    live = seq.live_roots()
    for task in live:
        seq.halt(task, why)
    return live
