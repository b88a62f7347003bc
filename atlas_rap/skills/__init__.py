"""Skills: the reactive tier (3T's skills, ATLAS's Layers I-II).

- ``skill``: the :class:`Skill` base class and its lifecycle.
- ``manager``: the :class:`SkillManager` (routing by name, rates, events).
- ``sensing``, ``safety``, ``motion``, ``navigation``, ``events``, ``camera``,
  ``handling``: the stock skills; ``catalog`` registers every skill once
  (name, typed parameters, events, rate, class, origin), the stock skills and
  the plugins' (:mod:`atlas_rap.plugins`), and ``stock`` builds them all. ``avoidance`` and
  ``routes`` are the steering and route-planning functions they share.
- ``virtual``: scripted skills for runs without physics.
"""

from atlas_rap.skills.manager import SkillContext, SkillManager
from atlas_rap.skills.skill import Skill

__all__ = ["Skill", "SkillContext", "SkillManager"]
