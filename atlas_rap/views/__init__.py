"""Views: the pictures and recordings of maps, plans and runs, and the experiment that draws figures.

Everything here looks at what the packages below it made and draws or
records it; nothing below imports it (cli → views → layers → ...).

- ``page``: the page layout every PNG shares, and the fast PNG writer;
- ``map_render``: the pictures of a map's levels (grid, edges, polygons,
  distance transform, places, stochastic SDT, topology, route);
  ``map_levels``: every level of a map written as files (data and pictures);
- ``world_render``: the picture of a run in its world (path, places, task marks);
- ``plan_render``: a plan's Gantt chart; ``order_picture``: its partial order;
  ``plan_dot``: the same as Graphviz DOT;
- ``timeline``: the timeline of a run with no world (plan steps, tasks, waits);
- ``run_picture``: :class:`RunPicture`, the observer of a run that draws it;
- ``recording``: the observer that records a run for Foxglove (MCAP, live
  WebSocket; ``foxglove_messages`` makes the messages); ``mcap_reader`` and
  ``mcap_picture`` read a recording back and draw it;
- ``experiment``: the seed's skill-acquisition experiment; ``experiment_seeds``: the same over
  many seeds in parallel processes, with its statistics (``seed_spec``: sets of seeds as
  ``0-9``); ``figures``: its plots, for one seed and over many.

The names below are imported from their modules at first use (``atlas_rap.exports``),
so importing the package costs nothing until a picture is drawn.
"""

from atlas_rap.exports import lazy_exports, public_names

_EXPORTS = {
    "map_levels": ("write_levels",),
    "map_render": ("render_grid",),
    "run_picture": ("RunPicture",),
    "world_render": ("render_run",),
}

__all__ = public_names(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
