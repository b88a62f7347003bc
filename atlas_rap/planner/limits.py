"""Limits that hold for a whole planner run: CPU time and memory, across every phase.

``atlas plan --timeout S --memory MB`` (and :func:`~atlas_rap.planner.solve.solve`)
give one :class:`Limits` to grounding, search, shortening and counterplanning;
each phase asks :meth:`Limits.expired` at its own checkpoints (every 8
expansions in a search) and stops when it says so. What the planner then
returns is decided once, in ``solve``: no plan yet is status ``timeout`` (or
``memory``); a plan whose shortening was cut keeps its last valid form and
says so (``Plan.limited``); a plan whose counterplanning was cut while
threats were left is never passed off as safe: status ``timeout``, with the
risk it has.

Time is CPU time of this process (``time.process_time``), as the planning
competitions count it. Memory is the process's peak resident size
(``getrusage``), which only grows: once past the limit, the run is over.
"""

from __future__ import annotations

import sys
import time


class LimitReached(Exception):
    """A phase that cannot hand back a partial result (grounding) stopped at a limit."""


def peak_memory_mb() -> float:
    """The peak resident memory of this process so far, in MiB."""
    import resource

    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / (1024 * 1024) if sys.platform == "darwin" else peak / 1024


class Limits:
    """A CPU-time and a memory budget for one planner run (None: no limit).

    ``reached`` says which limit ran out (``"timeout"`` or ``"memory"``), and
    ``during`` in which phase (``phase`` is set by ``solve`` as it goes), once
    :meth:`expired` has said True. ``whole_process`` counts the CPU time from the
    start of the process (``atlas plan``: the interpreter's start-up and reading
    the files count too), else from now.
    """

    def __init__(self, seconds: float | None = None, memory_mb: float | None = None, *,
                 whole_process: bool = False) -> None:
        self.seconds = seconds
        self.memory_mb = memory_mb
        self.started = 0.0 if whole_process else time.process_time()
        self.phase = "grounding"
        self.reached: str | None = None
        self.during: str | None = None

    def used(self) -> float:
        """CPU seconds since the run began."""
        return time.process_time() - self.started

    def left(self) -> float | None:
        """CPU seconds left (never below 0), or None without a time limit."""
        return None if self.seconds is None else max(0.0, self.seconds - self.used())

    def expired(self) -> bool:
        """Whether a limit has run out (and, the first time, note which and when)."""
        if self.reached is not None:
            return True
        if self.seconds is not None and self.used() > self.seconds:
            self.reached = "timeout"
        elif self.memory_mb is not None and peak_memory_mb() > self.memory_mb:
            self.reached = "memory"
        else:
            return False
        self.during = self.phase
        return True

    def share(self, fraction: float) -> Limits:
        """Limits for one phase: ``fraction`` of the time left (the memory limit as it is).
        When the share runs out the run goes on; when the run's limits do, so does the share."""
        return _Share(self, fraction)

    def to_dict(self) -> dict[str, object]:
        """The limits and what happened, for ``--json``."""
        return {"timeout_s": self.seconds, "memory_mb": self.memory_mb, "reached": self.reached,
                "during": self.during}

    def describe(self) -> str:
        """The limit that ran out, in words: ``the time limit of 5 s`` or ``the memory limit of 500 MB``."""
        if self.reached == "memory":
            return f"the memory limit of {self.memory_mb:g} MB"
        return f"the time limit of {self.seconds:g} s"


class _Share(Limits):
    """A phase's part of a run's limits (:meth:`Limits.share`)."""

    def __init__(self, run: Limits, fraction: float) -> None:
        left = run.left()
        super().__init__(None if left is None else fraction * left, run.memory_mb)
        self.run = run

    def expired(self) -> bool:
        return self.run.expired() or super().expired()
