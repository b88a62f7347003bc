"""The ATLAS layers: the run of a mission, from a program to a robot moving.

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
- ``experiment``: the seed's skill-acquisition experiment; ``figures``: its plots.
- ``picture``: an observer of a run that draws it as a PNG.
- ``recording``: an observer of a run that records it for Foxglove (MCAP, live
  WebSocket; in one process, or split between a skill host and the sequencer;
  ``foxglove_messages`` makes the messages); ``mcap_reader`` and
  ``mcap_picture`` read a recording back and draw it.
"""

from atlas_rap.layers.clock import Clock, WallClock, wall_clock_pacer
from atlas_rap.layers.engine import Loaded, MissionEngine
from atlas_rap.layers.executive import Executive, Rates, VirtualExecutive
from atlas_rap.layers.layer import LAYER_NAMES, Layer, LayerStack
from atlas_rap.layers.picture import RunPicture
from atlas_rap.layers.running import RunEnd, RunResult
from atlas_rap.layers.system import DEFAULT_WORLD, RunOptions, System

__all__ = ["Clock", "DEFAULT_WORLD", "Executive", "LAYER_NAMES", "Layer", "LayerStack", "Loaded", "MissionEngine",
           "Rates", "RunEnd", "RunOptions", "RunPicture", "RunResult", "System", "VirtualExecutive", "WallClock",
           "wall_clock_pacer"]
