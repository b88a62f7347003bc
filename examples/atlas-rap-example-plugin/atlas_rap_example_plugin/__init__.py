"""An example atlas-rap plugin: a light sensor (``light-sensor``), a motion skill (``creep``), a world
(``greenhouse``) with a lamp in it, and a mission that uses them (``find-the-lamp.rap``).

atlas finds them through the entry points in this package's ``pyproject.toml``.
"""

from pathlib import Path

MISSION = Path(__file__).parent / "find-the-lamp.rap"
"""The example mission: creep toward the lamp until the light sensor says it is bright."""
