"""A layer of ATLAS, and the stack of them that shares one robot, one memory and one drive.

ATLAS (seed 000 §2, §5) replicates control over layers that each see the
world through their own representation and each can drive the robot on its
own; at any time one of them is the **primary layer**, whose plan the robot
follows. Here a :class:`Layer` has a roman ``name`` (I-IV), a ``period``
and a :meth:`Layer.tick`; the executive runs each at its period on one
clock. The :class:`LayerStack` is what they share:

- the robot's beliefs (:mod:`atlas_rap.skills.beliefs`: pose, sonar, grid,
  topology, route), typed, never string keys;
- RAP memory: layers say what they find as facts (:meth:`LayerStack.post`,
  ``(map-quality 0.93)``, ``(obstacle short-lived)``, ``(route-blocked A
  B)``, ``(no-route)``), and read their settings from it
  (``(layer-setting NAME VALUE)``);
- the choice of the primary layer, which is *data*: memory rules (the
  shipped ``rap_library/layers.rap``, or ``atlas run --layer-rules``)
  conclude ``(primary-layer II)`` from those facts, and the stack follows
  memory. Each change is a ``layer-switched`` trace event (layer, previous
  layer, reason: the rule and the fact that fired it);
- the drive: the stack is the :class:`~atlas_rap.skills.beliefs.RouteSource`
  that ``navigate-to`` asks, and it asks the primary layer, so a RAP that
  says ``(navigate-to office)`` is driven by whichever layer is primary
  without knowing which.

A layer that is not enabled (``atlas run --layers I,II``) neither ticks nor
drives; when the rules choose it, the nearest enabled layer below it (else
above it) drives instead, and the trace says so.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from atlas_rap.logic import Compound, Var, term_to_str
from atlas_rap.model import Point
from atlas_rap.skills.beliefs import GRID, HOLD, POSE, ROUTES, Beliefs, PlannedRoute
from atlas_rap.trace_events import Event

if TYPE_CHECKING:
    from atlas_rap.maps.frame import GridFrame
    from atlas_rap.sequencer import Sequencer
    from atlas_rap.sim.world import World

LAYER_NAMES = ("I", "II", "III", "IV")
BLOCK_RADIUS = 0.3
"""Metres round a point found blocked that grid routes keep out of."""
TITLES = {"I": "Monitoring", "II": "Operational", "III": "Tactical", "IV": "Strategic"}


class Layer:
    """One layer: a name (I-IV), a period in simulated seconds, a tick, and a way to drive.

    :meth:`route` is how the layer drives the robot when it is primary: a
    route to ``goal``, the reason there is none (a string), or None when it
    leaves the driving to the layer below (Layer I holds the robot still
    and lets the route stand).
    """

    name: ClassVar[str] = ""
    plans: ClassVar[bool] = False  # does the layer plan routes (II-IV), or only react (I)?
    period: float = 1.0

    def __init__(self, stack: LayerStack) -> None:
        self.stack = stack

    @property
    def title(self) -> str:
        return TITLES[self.name]

    def start(self) -> None:
        """Once, before the first tick."""

    def tick(self, now: float) -> None:
        """Every ``period`` seconds of simulated time."""

    def route(self, goal: str, start: Point, closed: set[str]) -> PlannedRoute | str | None:
        return None

    def __repr__(self) -> str:
        return f"<Layer {self.name} {self.title}>"


@dataclass(frozen=True, slots=True)
class Switch:
    """One change of the primary layer, as traced."""

    t: float
    layer: str
    previous: str | None
    reason: str


class LayerStack:
    """The layers of one run and what they share; see the module docstring."""

    def __init__(self, sequencer: Sequencer, beliefs: Beliefs, world: World, *,
                 enabled: Iterable[str] = LAYER_NAMES, prior_map: bool = True) -> None:
        self.sequencer = sequencer
        self.beliefs = beliefs
        self.world = world
        self.prior_map = prior_map
        self.blocks: list[Point] = []  # points found blocked (Layer III); grid routes leave them out
        self.contacts: list[Point] = []  # where the bumper touched something (Layer IV); grid routes keep off
        self.blocked_doors: set[str] = set()  # doors found blocked (Layer III); prior-map routes leave them out
        self.grid_version = 0  # grows each time Layer IV changes the grid
        self._planners: dict[bool, tuple[tuple[Any, ...], Any]] = {}
        self._beyond: tuple[GridFrame, np.ndarray] | None = None  # (frame, mask): _beyond_the_extent's cache
        self.enabled = frozenset(enabled)
        unknown = self.enabled - set(LAYER_NAMES)
        if unknown:
            raise ValueError(f"no layer {', '.join(sorted(unknown))}: the layers are I, II, III and IV")
        self.layers: dict[str, Layer] = {}
        self.primary: str | None = None
        self.chosen: str | None = None  # what the rules said, before enabling was taken into account
        self.timeline: list[Switch] = []
        self.revision = 0
        self.robot_radius = float(world.robot.radius)
        self.logging_rings = False  # Layer IV turns it on while it maps
        self.rules_source = "rap_library/layers.rap"  # the file of switching rules, for messages
        self._driver: str | None = None
        self._changed = True  # (primary-layer L) may have changed since observe() last looked
        sequencer.memory.subscribe(self._primary_changed, ["primary-layer"])
        beliefs[ROUTES] = self

    def add(self, layer: Layer) -> None:
        self.layers[layer.name] = layer

    def active(self) -> list[Layer]:
        """The enabled layers, I first."""
        return [self.layers[name] for name in LAYER_NAMES if name in self.layers and name in self.enabled]

    def start(self) -> None:
        """Start the layers from I up (Layer I says the way is clear before Layer IV measures
        the map, so the rules decide on both), then follow memory."""
        for layer in self.active():
            layer.start()
        if "I" not in self.enabled:  # nothing watches the way: it is taken as clear
            self.sequencer.change([("assert", Compound("obstacle", ("none",)))], "layers")
        self.observe()

    # -- memory -------------------------------------------------------------------

    def post(self, layer: Layer, changes: list[tuple[str, Compound]]) -> None:
        """Facts a layer found, into RAP memory (the rules may switch the primary layer)."""
        self.sequencer.change(changes, f"layer {layer.name}")
        if self._changed:
            self.observe(self._reason(changes))

    def assert_fact(self, layer: Layer, functor: str, *args: Any) -> None:
        """Assert ``(functor args...)`` unless memory holds it already (facts are said once)."""
        fact = Compound(functor, tuple(args))
        if fact not in self.sequencer.memory:
            self.post(layer, [("assert", fact)])

    def holds(self, functor: str, *args: Any) -> bool:
        return Compound(functor, tuple(args)) in self.sequencer.memory

    def setting(self, name: str, default: float) -> float:
        """A number from ``(layer-setting NAME VALUE)`` in memory (the rules file's settings)."""
        for fact in self.sequencer.memory.facts(Compound("layer-setting", (name, Var("value")))):
            value = fact.args[1]
            if isinstance(value, (int, float)) and not isinstance(value, bool):
                return float(value)
        return default

    def _reason(self, changes: list[tuple[str, Compound]]) -> str:
        """The rule that concluded the new primary layer, and the fact that fired it (the
        firings are forgotten once read, so a later switch is not charged to an old rule)."""
        fired = self.sequencer.rules.fired
        for rule, fact in reversed(fired):
            if any(kind == "assert" and effect.functor == "primary-layer" for kind, effect in rule.effects):
                fired.clear()
                return f"rule {rule.name} on {term_to_str(fact)}"
        if not changes:
            return "asserted in memory"
        return f"memory: {', '.join(term_to_str(fact) for _, fact in changes)}"

    # -- the primary layer ----------------------------------------------------------

    def _primary_changed(self, kind: str, fact: Compound, time: float) -> None:
        self._changed = True

    def observe(self, reason: str | None = None) -> None:
        """Follow memory's ``(primary-layer L)``: switch, trace it, and re-route when the driver
        changes. Memory tells the stack when a ``primary-layer`` fact comes or goes, so
        between changes this costs one test (the executive calls it after every skill and
        sequencer tick)."""
        if not self._changed:
            return
        self._changed = False
        chosen = None
        for fact in self.sequencer.memory.facts(Compound("primary-layer", (Var("layer"),))):
            chosen = str(fact.args[0]).upper()  # symbols read lower-case: (primary-layer II) is ii
        if chosen is None or chosen == self.chosen:
            return
        self.chosen = chosen
        if reason is None:
            reason = self._reason([])
        layer = self._enabled_near(chosen)
        if layer != chosen:
            reason += f"; {chosen} is not enabled, so {layer} drives"
        if chosen == "I":  # chosen by the rules, Layer I holds the robot; standing in for another, it drives
            self.beliefs[HOLD] = "Layer I holds the robot: something is in its way"
        else:
            self.beliefs.pop(HOLD)
        if layer == self.primary:
            return
        previous, self.primary = self.primary, layer
        now = self.sequencer.now()
        self.timeline.append(Switch(now, layer, previous, reason))
        self.sequencer.trace.emit(Event.LAYER_SWITCHED, layer=layer, previous=previous, reason=reason)
        driver = self._driving_layer()
        if driver != self._driver:
            self._driver = driver
            self.revision += 1

    def timeline_records(self) -> list[dict[str, Any]]:
        """The switches as the trace and ``figures.json`` have them."""
        return [{"t": round(s.t, 2), "layer": s.layer, "previous": s.previous, "reason": s.reason}
                for s in self.timeline]

    def primary_seconds(self, end: float) -> dict[str, float]:
        """Seconds each layer was primary, from the start of the run to ``end``."""
        return primary_seconds(self.timeline_records(), end)

    def primary_summary(self, end: float) -> str:
        """``IV 80.0 s, II 19.8 s``: how long each layer drove, the longest first."""
        seconds = sorted(((s, name) for name, s in self.primary_seconds(end).items() if s > 0), reverse=True)
        return ", ".join(f"{name} {s:.1f} s" for s, name in seconds)

    def _enabled_near(self, name: str) -> str:
        if name in self.enabled or name not in LAYER_NAMES:
            return name
        index = LAYER_NAMES.index(name)
        below = [n for n in LAYER_NAMES[:index][::-1] if n in self.enabled]
        above = [n for n in LAYER_NAMES[index + 1:] if n in self.enabled]
        return (below or above or [name])[0]

    def _driving_layer(self) -> str | None:
        """The layer whose routes the robot follows: the primary layer, or the one below it that plans."""
        if self.primary is None:
            return None
        if self.primary == "I" and self._driver is not None:
            return self._driver  # Layer I holds the robot; the route it was following stands
        index = LAYER_NAMES.index(self.primary) if self.primary in LAYER_NAMES else 0
        order = list(LAYER_NAMES[index::-1]) + list(LAYER_NAMES[index + 1:])
        for name in order:
            layer = self.layers.get(name)
            if layer is not None and name in self.enabled and layer.plans:
                return name
        return "I" if "I" in self.enabled and "I" in self.layers else None  # alone, Layer I drives reactively

    @property
    def driver(self) -> str | None:
        """The layer whose routes the robot follows now."""
        return self._driving_layer()

    def grid_planner(self, *, unknown_passable: bool, track: Sequence[Point] = (),
                     driven: np.ndarray | None = None, faint_below: float | None = None):
        """A path planner on the grid as it is now (cached while the grid and the robot's cell stay).

        The blocked points are obstacles; the disc round the robot is free (it
        stands there, whatever the sonar saw), but for the ``contacts``, where
        the bumper touched something (felt, not seen: Layer IV). With ``unknown_passable`` False
        (Layers II and III, which do not explore) unknown cells are obstacles; with it True
        (Layer IV) so are those beyond the world's extent (``World.extent``): the margin the
        bounds leave round the walls, places and start holds nothing to drive to, and a way
        through it would lead round the outside of a building the sonar has not yet seen whole.
        ``track`` (points the robot drove, in order) is passable but where it
        comes within reach of a blocked point
        (:class:`~atlas_rap.maps.gridpath.GridPlanner`'s ``tracks``); so are
        the cells of ``driven`` (a mask on the grid's frame: cells the robot
        drove in earlier runs, ``OccupancyGrid.driven``) but those within
        that reach. Neither is cached. ``faint_below`` (a P(occ)): the cells the grid holds
        occupied with less than it count as unknown, passable at its price (not cached either).
        """
        from atlas_rap.maps.gridpath import GridPlanner

        if track or driven is not None or faint_below is not None:
            p_occ, known = self._planning_grid(unknown_passable, faint_below)
            return GridPlanner(p_occ, self.beliefs[GRID].frame, self.robot_radius, known=known,
                               tracks=self._track_pieces(track),
                               driven=self._clear_of_blocks(driven) if driven is not None else None)

        grid = self.beliefs[GRID]
        frame = grid.frame
        pose = self.beliefs.get(POSE)
        here = frame.world_to_cell(*pose[:2]) if pose is not None else None
        key = (self.grid_version, len(self.blocks), len(self.contacts), here)
        cached = self._planners.get(unknown_passable)
        if cached is not None and cached[0] == key:
            return cached[1]
        p_occ, known = self._planning_grid(unknown_passable)
        planner = GridPlanner(p_occ, frame, self.robot_radius, known=known)
        self._planners[unknown_passable] = (key, planner)
        return planner

    def _planning_grid(self, unknown_passable: bool,
                       faint_below: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """P(occ) and the known cells for :meth:`grid_planner`: the grid (the cells occupied with
        P under ``faint_below`` unknown; with ``unknown_passable``, the unknown cells beyond the
        world's extent occupied), the disc round the robot free, the blocked points and the
        contacts occupied."""
        grid = self.beliefs[GRID]
        frame = grid.frame
        pose = self.beliefs.get(POSE)
        p_occ = grid.probabilities()
        known = grid.updated.copy() if unknown_passable else np.ones(p_occ.shape, dtype=bool)
        if faint_below is not None:
            known &= (p_occ <= 0.5) | (p_occ >= faint_below)
        if not unknown_passable:
            p_occ[~grid.updated] = 1.0
        else:
            beyond = self._beyond_the_extent(frame) & ~grid.updated
            p_occ[beyond], known[beyond] = 1.0, True
        robot = frame.disc(*pose[:2], self.robot_radius + 0.35) if pose is not None else None
        if robot is not None:
            window, disc = robot
            p_occ[window][disc] = np.minimum(p_occ[window][disc], 0.3)
            known[window][disc] = True
        # the contacts are felt, not seen: kept even in the disc round the robot
        occupied = [(point, BLOCK_RADIUS) for point in self.blocks]
        occupied += [(point, frame.resolution) for point in self.contacts]
        for (x, y), radius in occupied:
            found = frame.disc(x, y, radius)
            if found is not None:
                p_occ[found[0]][found[1]], known[found[0]][found[1]] = 1.0, True
        return p_occ, known

    def _beyond_the_extent(self, frame: GridFrame) -> np.ndarray:
        """The cells of ``frame`` whose centres lie outside ``World.extent`` (cached per frame)."""
        if self._beyond is None or self._beyond[0] != frame:
            xmin, ymin, xmax, ymax = self.world.extent
            x, y = frame.cell_to_world(*np.indices(frame.shape))
            self._beyond = (frame, (x < xmin) | (x > xmax) | (y < ymin) | (y > ymax))
        return self._beyond[1]

    def _clear_of_blocks(self, cells: np.ndarray) -> np.ndarray:
        """A copy of the mask ``cells`` (the grid's frame) without those within the robot's radius of
        a blocked point's disc."""
        frame = self.beliefs[GRID].frame
        driven = np.array(cells, dtype=bool)
        for x, y in self.blocks:
            found = frame.disc(x, y, BLOCK_RADIUS + self.robot_radius)
            if found is not None:
                driven[found[0]] &= ~found[1]
        return driven

    def _track_pieces(self, track: Sequence[Point]) -> list[list[Point]]:
        """``track`` cut where it comes within the robot's radius of a blocked point's disc."""
        reach = BLOCK_RADIUS + self.robot_radius
        pieces: list[list[Point]] = [[]]
        for point in track:
            if any(math.dist(point, block) < reach for block in self.blocks):
                if pieces[-1]:
                    pieces.append([])
            else:
                pieces[-1].append(point)
        return [piece for piece in pieces if piece]

    def replanned(self) -> None:
        """A layer has a better route than the one being driven (``navigate-to`` asks again)."""
        self.revision += 1

    # -- the RouteSource navigate-to asks -------------------------------------------

    def route(self, goal: str, start: Point, closed: set[str]) -> PlannedRoute | str:
        """A route from the layer that drives. When it has none and it is not Layer IV, memory
        hears ``(no-route)`` (the rules may hand over to Layer IV, which explores) and the
        layer that drives then is asked in turn."""
        if self.primary is None:
            return (f"no layer is primary: the layer rules ({self.rules_source}) concluded no (primary-layer L); "
                    f"write rules that do, or leave out --layer-rules for the shipped ones")
        asked: set[str] = set()
        answer: PlannedRoute | str = "no layer that plans routes is enabled"
        driver = self._driving_layer()
        while driver is not None and driver not in asked:
            asked.add(driver)
            found = self.layers[driver].route(goal, start, closed)
            answer = found if found is not None else f"Layer {driver} has no route to {goal}"
            if isinstance(answer, PlannedRoute) or driver == "IV":
                return answer
            self.post(self.layers[driver], [("assert", Compound("no-route", ()))])
            driver = self._driving_layer()
        return answer


def timeline_spans(timeline: Sequence[Mapping[str, Any]], end: float) -> list[tuple[str, float, float]]:
    """(layer, start, end) spans of a timeline of primary-layer switches, in time order, up to ``end``.

    Each entry's layer is primary from its ``t`` until the next entry's
    ``t`` (the last until ``end``). Times are clipped to [0, ``end``];
    entries are taken in order of ``t`` (ties keep their given order);
    spans of no length are dropped and consecutive spans of one layer
    merged into one. An empty timeline gives no spans. A layer that is
    not one of :data:`LAYER_NAMES` is a ``ValueError``.
    """
    end = max(float(end), 0.0)
    entries = sorted(timeline, key=lambda entry: float(entry["t"]))
    spans: list[tuple[str, float, float]] = []
    for i, entry in enumerate(entries):
        layer = entry["layer"]
        if layer not in LAYER_NAMES:
            raise ValueError(f"unknown layer {layer!r} at t = {entry['t']} (the layers are {', '.join(LAYER_NAMES)})")
        start = min(max(float(entry["t"]), 0.0), end)
        stop = min(max(float(entries[i + 1]["t"]), 0.0), end) if i + 1 < len(entries) else end
        if stop <= start:
            continue
        if spans and spans[-1][0] == layer and spans[-1][2] == start:
            spans[-1] = (layer, spans[-1][1], stop)
        else:
            spans.append((layer, start, stop))
    return spans


def primary_seconds(timeline: Sequence[Mapping[str, Any]], end: float) -> dict[str, float]:
    """Seconds each layer was primary up to ``end``: all of I..IV as keys, 0.0 for a layer never primary.

    For a timeline that starts at t = 0 the values sum to ``end``.
    """
    seconds = dict.fromkeys(LAYER_NAMES, 0.0)
    for layer, start, stop in timeline_spans(timeline, end):
        seconds[layer] += stop - start
    return seconds
