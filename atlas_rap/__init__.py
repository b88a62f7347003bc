"""atlas-rap: task-level robot control in the 3T / ATLAS tradition.

The pieces (see DESIGN.md): ``lang`` reads RAP and AP files, ``logic`` holds
terms, unification, memory and queries shared by the sequencer and the
planner, ``cli`` is the ``atlas`` command.
"""

__version__ = "0.1.0"
