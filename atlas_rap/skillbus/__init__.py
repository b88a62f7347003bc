"""The skill bus: the seam between the sequencer and the skills (3T's sequencer ↔ skill manager).

Both tiers import it and it imports neither: the sequencer and the skills
meet here, as the 3T tiers should (docs/explanation/architecture.md), through narrow messages.

- ``skill_link``: the :class:`SkillLink` protocol (enable, disable, facts
  back) and :class:`SkillHost`, what a link may use of the sequencer. The
  **in-process backend** is this protocol called directly (the skill manager
  and the virtual skills are links; :class:`CombinedSkills` puts several
  together): nothing is serialised, so a run in one process is as fast as
  it ever was. It is the default.
- ``timers``: the one queue of things due on the simulated clock.
- ``messages``: the typed, versioned messages (enable, disable, done, why,
  fact asserted or retracted, tick, ack ...) and their one serialisation
  (JSON with terms as a compact structure), :class:`DecodeError`.
- ``keys``: the Zenoh key expressions, per robot.
- ``protocol``: positions on the clock and the turns of the lock step.
- ``zenoh_bus``: the Eclipse Zenoh transport (``pip install
  'atlas-rap[zenoh]'``); ``remote``: the sequencer's side over it (a skill
  link to skill hosts); ``host``: the skill host's side.

The skill host itself (world, skills, layers) and the executive that
drives it in lock step are ``layers.skill_host`` and ``layers.remote``.
"""

from atlas_rap.skillbus.messages import DecodeError, VersionError
from atlas_rap.skillbus.skill_link import CombinedSkills, NoSkills, SkillHost, SkillLink
from atlas_rap.skillbus.timers import Timer, Timers

__all__ = ["CombinedSkills", "DecodeError", "NoSkills", "SkillHost", "SkillLink", "Timer", "Timers", "VersionError"]
