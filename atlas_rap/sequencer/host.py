"""The host: what the parts of a running task need from the interpreter that runs them.

A method's live net (``net.MethodRun`` and its nodes) and a plan being carried
out (``deliberation.PlanExecution``) are run by the
:class:`~atlas_rap.sequencer.interpreter.Sequencer`, but they do not hold it
as a ``Sequencer``: each sees it through a narrow protocol made of the roles
below, and ``Sequencer`` satisfies them structurally (it names none of them).
So the parts depend on a few named members, not on the whole interpreter, and
their modules do not import the interpreter's.

- :class:`Knowledge`: memory, the defined relations, and changing memory;
- :class:`Subtasks`: spawning a subtask for a step, and halting one;
- :class:`Watching`: knowledge, and waiting for queries to hold (the wait index) and for time
  to pass (the timers), as a ``net.WaitGroup`` does;
- :class:`PlanHost`: what a plan execution needs: knowledge and subtasks, the
  clock and timers, the trace, the RAPs to dispatch plan steps to, and the
  plans' own bookkeeping facts.

A method run's host (``net.NetHost``: knowledge, watching, subtasks, the skills
as resources, starting plans, and where steps and methods report) is declared
in ``net``, beside the types its members take. This module imports nothing of
the modules that use it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Iterable, Mapping, Protocol

from atlas_rap.logic import Compound, Memory, Relation
from atlas_rap.logic.rules import Change
from atlas_rap.sequencer.task import Spawner, Task
from atlas_rap.sequencer.trace import Trace
from atlas_rap.sequencer.waiting import WaitIndex

if TYPE_CHECKING:
    from atlas_rap.lang import ast
    from atlas_rap.skillbus.timers import Timers


class Knowledge(Protocol):
    """Memory as the parts read and change it."""

    memory: Memory
    relations: dict[str, list[Relation]]

    def change(self, changes: Iterable[Change], source: str = "", *, task: Task | None = None,
               skill: Compound | None = None) -> list[Change]:
        """Assert/retract facts (memory rules run, waiters wake); the changes made."""
        ...


class Subtasks(Protocol):
    """Subtasks: started for a step, halted when the step no longer needs them."""

    def spawn(self, call: Compound, parent: Task, step: Spawner) -> Task:
        """A subtask of ``parent`` for ``step``, on the agenda."""
        ...

    def halt(self, task: Task, why: str) -> None:
        """Stop ``task`` and everything under it."""
        ...


class Watching(Knowledge, Protocol):
    """Knowledge, and waiting for a query to hold or for time to pass."""

    waits: WaitIndex  # wakes a waiter when a fact it could match changes
    timers: Timers


class PlanHost(Knowledge, Subtasks, Protocol):
    """What a plan execution needs of the interpreter."""

    timers: Timers
    trace: Trace
    library: Mapping[tuple[str, int], ast.RapDef]  # the RAPs, by name and arity: plan steps go to them
    plan_beliefs: set[Compound]  # facts plans asserted as the planner's bookkeeping

    def now(self) -> float:
        """The current simulated time, in seconds."""
        ...

    def next_plan_number(self) -> int:
        """The number of the next plan of this run, as the trace names plans."""
        ...
