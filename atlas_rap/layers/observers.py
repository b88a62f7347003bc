"""Observers of a run, opened and closed in one place: ``with observing(...)``.

An observer watches a run and writes one output when it ends: the JSONL
trace sink, the MCAP recorder (and ``--live``), the run picture, the map
built. :func:`observing` registers them for the whole run and closes them
on every exit, so no command closes sinks by hand:

- when the run never started (the program did not load, a bad output path),
  each is *discarded*: every output stays as it was;
- once :meth:`Observation.started` is called, each is *closed*, that is
  written, also when the run fails or is interrupted; one that cannot be
  written does not stop the others, and its error is kept in
  :attr:`Observation.failed` for the command to report after the summary.

::

    with observing({"--trace": sink, "--render": PictureFile(picture, "run.png", name)}) as run:
        engine.load_file(mission)      # raises: nothing is written
        run.started()
        result = engine.run_mission()
    for option, error in run.failed.items(): ...
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from atlas_rap.outputs import OutputError, write_all

if TYPE_CHECKING:  # same tier
    from atlas_rap.layers.engine import MissionEngine

__all__ = ["MapFile", "Observation", "Observer", "Picture", "PictureFile", "observing"]


class Observer(Protocol):
    """An output of a run: written by :meth:`close` when the run ends, dropped by :meth:`discard`
    when it never started."""

    def close(self) -> object:
        """Write the output (atomically: whole or not at all)."""
        ...

    def discard(self) -> None:
        """Leave the output as it was before the run."""
        ...


@dataclass
class Observation:
    """The observers of one run, by the option that asked for each (``--trace``, ``--record``, ...)."""

    observers: dict[str, Observer]
    running: bool = False
    failed: dict[str, OutputError] = field(default_factory=dict)

    def started(self) -> None:
        """The run has started: from now on every observer is written when the block ends."""
        self.running = True

    def written(self) -> list[str]:
        """The options whose outputs were written (after the block)."""
        return [option for option in self.observers if option not in self.failed]


@contextmanager
def observing(observers: Mapping[str, Observer | None]) -> Iterator[Observation]:
    """Run the block with ``observers`` (option name -> observer; None: not asked for); see the module."""
    observation = Observation({option: o for option, o in observers.items() if o is not None})
    try:
        yield observation
    finally:
        if observation.running:  # written also when the run failed or was interrupted
            observation.failed = _close(observation)
        else:  # the run never started: every output stays as it was
            for observer in observation.observers.values():
                observer.discard()


def _close(observation: Observation) -> dict[str, OutputError]:
    return write_all({option: observer.close for option, observer in observation.observers.items()})


@dataclass
class MapFile:
    """``--map-out``: the grid Layer IV built, written when the run ends (nothing when it built none)."""

    engine: MissionEngine
    path: str | Path

    def close(self) -> Path | None:
        return self.engine.save_map(self.path) if self.engine.grid is not None else None

    def discard(self) -> None:
        return None


class Picture(Protocol):
    """A picture of a run that is drawn when asked (:class:`atlas_rap.views.run_picture.RunPicture`)."""

    def render(self, out_png: str, title: str) -> None: ...


@dataclass
class PictureFile:
    """``--render``: the picture of the run, drawn when the run ends."""

    picture: Picture
    path: str
    title: str

    def close(self) -> None:
        self.picture.render(self.path, self.title)

    def discard(self) -> None:
        return None
