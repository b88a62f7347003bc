"""The ATLAS layers: the run of a mission, from a program to a robot moving.

- ``engine``: :class:`MissionEngine`, the one mission engine that ``atlas run``,
  ``atlas repl`` and ``atlas map build`` drive: programs loaded in one pass
  into a running world (or none), and time moved until the tasks end.
- ``executive``: what moves time: the multirate executive of a world
  (physics, skills, sequencer at their own rates) or the timers alone.
- ``picture``: an observer of a run that draws it as a PNG.
"""

from atlas_rap.layers.engine import DEFAULT_WORLD, Loaded, MissionEngine, RunResult
from atlas_rap.layers.executive import Executive, Rates, VirtualExecutive, wall_clock_pacer
from atlas_rap.layers.picture import RunPicture

__all__ = ["DEFAULT_WORLD", "Executive", "Loaded", "MissionEngine", "Rates", "RunPicture", "RunResult",
           "VirtualExecutive", "wall_clock_pacer"]
