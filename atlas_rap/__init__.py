"""atlas-rap: task-level robot control in the 3T / ATLAS tradition.

The pieces (see docs/explanation/architecture.md): ``lang`` reads RAP and AP files, ``logic`` holds
terms, unification, memory and queries shared by the sequencer and the
planner, ``cli`` is the ``atlas`` command. Every error a user can see is an
:class:`AtlasError`, of its area's class (``atlas_rap.errors``).
"""

from atlas_rap.errors import (AtlasError, LanguageError, MapError, MapFileError, PlanError, PlanFileError, RunError,
                              RunFileError, SkillBusError, SourceError, WorldError, WorldFileError)

__version__ = "0.1.0"

__all__ = ["AtlasError", "LanguageError", "MapError", "MapFileError", "PlanError", "PlanFileError", "RunError",
           "RunFileError", "SkillBusError", "SourceError", "WorldError", "WorldFileError", "__version__"]
