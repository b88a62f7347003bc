"""The ATLAS layers and the run: from a program to a robot moving.

- ``system``: :class:`RunOptions` (what a run is asked for) and :class:`System`
  (what it is made of, every part typed); ``builders``: the three ways one is
  built (a world here, none, the skill hosts over the bus; ``remote``).
- ``observers``: ``with observing(...)``: the outputs of a run (trace,
  recording, picture, map) opened and closed in one place.
- ``library``: what loaded programs define, and the steps that load one;
  ``running``: moving a System's time (:class:`RunEnd`, :class:`RunResult`).
- ``engine``: :class:`MissionEngine`, the one mission engine that ``atlas run``,
  ``atlas repl``, ``atlas map build`` and ``atlas experiment`` drive: programs
  loaded in one pass into a running world (or none), and time moved until
  the tasks end.
- ``executive``: what moves time: the multirate executive of a world
  (physics, skills, sequencer, layers at their own periods) or the timers alone;
  ``clock``: the one clock (simulated, or paced to the wall).
- ``layer``: :class:`Layer` and the :class:`LayerStack` the four layers share,
  with the primary layer chosen by memory rules (``rap_library/layers.rap``);
  ``monitoring``, ``operational``, ``tactical``, ``strategic``: Layers I-IV.
- ``skill_host``: a robot's skill host (world, skills, layers I-III) on the
  skill bus; ``remote``: the lock-step executive of the sequencer's side.

The pictures and recordings of a run (and the experiment that draws figures)
are :mod:`atlas_rap.views`, which observes a run from above.
"""

from atlas_rap.layers.clock import Clock, WallClock, wall_clock_pacer
from atlas_rap.layers.engine import Loaded, MissionEngine
from atlas_rap.layers.executive import Executive, Rates, VirtualExecutive
from atlas_rap.layers.layer import LAYER_NAMES, Layer, LayerStack
from atlas_rap.layers.running import RunEnd, RunResult
from atlas_rap.layers.system import DEFAULT_WORLD, RunOptions, System

__all__ = ["Clock", "DEFAULT_WORLD", "Executive", "LAYER_NAMES", "Layer", "LayerStack", "Loaded", "MissionEngine",
           "Rates", "RunEnd", "RunOptions", "RunResult", "System", "VirtualExecutive", "WallClock",
           "wall_clock_pacer"]
