"""The simulated robot: worlds, pymunk physics and its parts, the sonar ring.

- ``world``: world files (:func:`load_world`, :func:`world_path`, :func:`shipped_worlds`);
- ``physics``: :class:`Simulation`, the robot in a pymunk space; ``sonar``: :class:`SonarRing`;
- ``objects``: :class:`ObjectSim`, the camera's and the gripper's objects;
- ``prior``: what a robot knows of its world at the start (:func:`prior_facts`);

The picture of a run is :mod:`atlas_rap.views.world_render`.

The names below are imported from their modules at first use (``atlas_rap.exports``).
"""

from atlas_rap.exports import lazy_exports, public_names

_EXPORTS = {
    "objects": ("ObjectSim",),
    "physics": ("Simulation",),
    "prior": ("prior_facts",),
    "sonar": ("SonarRing",),
    "world": ("load_world", "shipped_worlds", "world_path"),
}

__all__ = public_names(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
