"""Record a run for Foxglove: an MCAP file (``atlas run --record``), a live WebSocket view (``--live``), or both.

A :class:`RunRecorder` watches a :class:`~atlas_rap.layers.engine.MissionEngine`
the way :class:`~atlas_rap.layers.picture.RunPicture` does: it is a trace
sink (every trace record becomes a log line), and its :meth:`RunRecorder.pace`
is the engine's ``pace`` hook, called at every sequencer tick (10 Hz of
simulated time), where it samples the world. Make it before the mission is
loaded, pass ``pace`` to the run, and close it in a ``finally``, so that a
failed or interrupted run still leaves a whole file::

    recorder = RunRecorder(engine, path="run.mcap")
    try:
        engine.load_file("deliver.rap", require_post=True)
        result = engine.run_mission(until, pace=recorder.pace)
    finally:
        recorder.close()

Every timestamp (log time and the messages' own) is **simulated** time from
the run's start, so the same mission and seed give the same recording, in
order on every channel. The channels (:data:`TOPICS`), with Foxglove's
well-known schemas and what decides when a message is written:

- ``/robot/pose`` (``foxglove.PoseInFrame``) and ``/tf`` (``foxglove.FrameTransform``,
  ``map`` → ``base_link``): the robot's true pose at every **pose sample**:
  ``pose_rate`` per simulated second (10 Hz, at most the sequencer's rate),
  at ``1/rate, 2/rate, ...``, plus one at :meth:`~RunRecorder.close` when the run
  ended between two samples (an interrupted run);
- ``/robot/path`` (``foxglove.PosesInFrame``): the path so far (a pose kept each
  time the robot moved 2 cm or turned 0.05 rad), once a simulated second
  while it changes, and at the end; a long path is sent less often (every
  ``len(path) / 1000`` s), so the cost stays bounded;
- ``/robot/sonar`` (``foxglove.LaserScan``): each new sonar ring (the ring's own rate,
  10 Hz), seen at the next pose sample, from the robot's centre in ``map``;
  no echo is NaN;
- ``/map/grid`` (``foxglove.Grid``, field ``occupancy``: P(occupied) × 100 as uint8):
  the occupancy grid Layer IV builds (only in a run that maps:
  ``--no-prior-map`` or ``--map-in``), when it changed, at most once per
  ``grid_period`` simulated seconds (1 s), and the last one at the end;
- ``/world/scene`` (``foxglove.SceneUpdate``): the simulated world: entities
  ``walls`` and ``places`` (at t = 0), ``doors`` (open green, shut red) and
  ``obstacles`` (boxes, people), each again when it changes;
- ``/map/topology`` (``foxglove.SceneUpdate``, entity ``topology``): the graph routes
  are planned on: the prior map's places joined through their doors at t = 0,
  then each topology Layer III builds (or the ``--map`` file's);
- ``/robot/route`` (``foxglove.SceneUpdate``, entity ``route``): the route
  ``navigate-to`` drives, when it or its next waypoint changes; deleted when
  the robot no longer follows one;
- ``/atlas/primary_layer`` (JSON, schema ``atlas.PrimaryLayer``: ``layer``,
  ``previous``, ``reason``): each switch of the primary ATLAS layer;
- ``/atlas/trace`` (``foxglove.Log``): every trace record, ``name`` its event and
  ``message`` its other fields as JSON (the records ``--trace`` writes).

A run with no world (``--world none``) has only the last two. A live
viewer that connects late gets the latest scene, topology, route, grid,
path and primary layer when it subscribes (the WebSocket server forgets
what it sent before); the MCAP file is not affected by viewers.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from atlas_rap.errors import AtlasError
from atlas_rap.skills.beliefs import GRID, ROUTE, SONAR, TOPOLOGY

POSE_RATE = 10.0
"""Pose samples per simulated second (at most the sequencer's 10 Hz: samples are taken at its ticks)."""

GRID_PERIOD = 1.0
"""Simulated seconds between two grids sent, at least (a grid is sent only when it changed)."""

PATH_PERIOD = 1.0
"""Simulated seconds between two paths sent, at least (longer once the path has over 1000 poses)."""

PATH_STEP = 0.02
PATH_TURN = 0.05
"""A pose joins the path when the robot moved this many metres or turned this many radians since the last."""

TOPICS: dict[str, tuple[str, str]] = {
    "/robot/pose": ("foxglove.PoseInFrame", "PoseInFrameChannel"),
    "/tf": ("foxglove.FrameTransform", "FrameTransformChannel"),
    "/robot/path": ("foxglove.PosesInFrame", "PosesInFrameChannel"),
    "/robot/sonar": ("foxglove.LaserScan", "LaserScanChannel"),
    "/map/grid": ("foxglove.Grid", "GridChannel"),
    "/world/scene": ("foxglove.SceneUpdate", "SceneUpdateChannel"),
    "/map/topology": ("foxglove.SceneUpdate", "SceneUpdateChannel"),
    "/robot/route": ("foxglove.SceneUpdate", "SceneUpdateChannel"),
    "/atlas/primary_layer": ("atlas.PrimaryLayer", ""),
    "/atlas/trace": ("foxglove.Log", "LogChannel"),
}
"""Topic → (schema name, the SDK's channel class); see the module docstring for what each carries."""

_LATCHED = ("/world/scene", "/map/topology", "/robot/route", "/map/grid", "/robot/path", "/atlas/primary_layer")
"""What a live viewer connecting late is sent again: the latest of each (per scene entity)."""

_PRIMARY_SCHEMA = {
    "title": "atlas.PrimaryLayer", "type": "object",
    "properties": {"layer": {"type": "string"}, "previous": {"type": ["string", "null"]},
                   "reason": {"type": "string"}},
}

FOXGLOVE_MISSING = ("recording for Foxglove needs the Foxglove SDK, which is not installed: "
                    "install atlas-rap[foxglove] (pip install 'atlas-rap[foxglove]')")


def require_foxglove() -> Any:
    """The ``foxglove`` module (the SDK, ``foxglove-sdk`` on PyPI); a one-line
    :class:`AtlasError` saying how to install it when it is missing."""
    try:
        import foxglove
        import foxglove.channels  # noqa: F401
        import foxglove.messages  # noqa: F401
    except ImportError:
        raise AtlasError(FOXGLOVE_MISSING) from None
    return foxglove


class _Output:
    """One place messages go: a Foxglove context with a channel per topic, and its sink
    (an MCAP writer or a WebSocket server). A live one keeps the latest latched messages."""

    def __init__(self, fox: Any, live: bool) -> None:
        self.context = fox.Context()
        self.channels: dict[str, Any] = {}
        for topic, (_, kind) in TOPICS.items():
            if kind:
                self.channels[topic] = getattr(fox.channels, kind)(topic, context=self.context)
            else:
                self.channels[topic] = fox.Channel(topic, schema=_PRIMARY_SCHEMA, context=self.context)
        self.latched: dict[str, dict[str, Any]] | None = {topic: {} for topic in _LATCHED} if live else None
        self.pending: set[str] = set()  # topics a viewer subscribed to since the last sample
        self.writer: Any = None
        self.server: Any = None

    def send(self, topic: str, message: Any, ns: int, key: str) -> None:
        self.channels[topic].log(message, log_time=ns)
        if self.latched is not None and topic in self.latched:
            self.latched[topic][key] = message

    def resend(self, ns: int) -> None:
        """Send a late viewer the latest of each latched topic it subscribed to."""
        if not self.pending or self.latched is None:
            return
        pending, self.pending = self.pending, set()
        for topic in pending:
            for message in self.latched.get(topic, {}).values():
                self.channels[topic].log(message, log_time=ns)

    def close(self) -> None:
        if self.writer is not None:
            self.writer.close()
            self.writer = None
        if self.server is not None:
            self.server.stop()
            self.server = None


def _subscriptions(fox: Any, output: _Output) -> Any:
    """The WebSocket server's listener: a viewer subscribing to a topic is sent its latest again
    (at the next sample, on the run's thread; the SDK calls this on its own)."""

    class Subscriptions(fox.websocket.ServerListener):
        def on_subscribe(self, client: Any, channel: Any) -> None:
            output.pending.add(channel.topic)

    return Subscriptions()


class RunRecorder:
    """Records one run to an MCAP file (``path``) and/or serves it live (``live``) for Foxglove.

    ``host``/``port``: where the live WebSocket server listens (port 0: any
    free port; :attr:`url` says which). ``pose_rate``, ``grid_period``: see
    :data:`POSE_RATE`, :data:`GRID_PERIOD`. Raises :class:`AtlasError` when
    the SDK is missing, the file cannot be made or the port cannot be had.
    """

    def __init__(self, engine: Any, *, path: str | Path | None = None, live: bool = False,
                 host: str = "127.0.0.1", port: int = 8765, pose_rate: float = POSE_RATE,
                 grid_period: float = GRID_PERIOD) -> None:
        fox = require_foxglove()
        from atlas_rap.layers import foxglove_messages

        self.m = foxglove_messages
        self.engine = engine
        self.pose_rate = pose_rate
        self.grid_period = grid_period
        self.outputs: list[_Output] = []
        self.live: _Output | None = None
        self.closed = False
        self._host = host
        if path is not None:
            output = _Output(fox, live=False)
            try:
                output.writer = fox.open_mcap(path, allow_overwrite=True, context=output.context)
            except Exception as exc:  # the SDK's own errors: a folder, no permission
                raise AtlasError(f"--record {path}: cannot write it ({exc})") from None
            self.outputs.append(output)
        if live:
            output = _Output(fox, live=True)
            try:
                output.server = fox.start_server(name="atlas-rap", host=host, port=port, context=output.context,
                                                 capabilities=[fox.websocket.Capability.Time],
                                                 server_listener=_subscriptions(fox, output))
            except Exception as exc:  # the port is taken, the host is not this machine's
                self._close_outputs()
                raise AtlasError(f"--live: cannot serve on {host}:{port} ({exc})") from None
            self.outputs.append(output)
            self.live = output
        self._sample_index = 0
        self._last_sample: float | None = None
        self._started = False
        self._path: list[Any] = []
        self._path_at: tuple[float, float, float] | None = None
        self._path_sent = 0
        self._path_due = 0.0
        self._sonar: Any = None
        self._grid_key: tuple[int, int] | None = None
        self._grid_sent: tuple[int, int] | None = None
        self._grid_due = 0.0
        self._topology: Any = None
        self._route_key: tuple[int, int] | None = None
        self._doors: dict[str, bool] | None = None
        self._obstacles: list | None = None
        self.counts: dict[str, int] = {topic: 0 for topic in TOPICS}
        engine.trace.add_sink(self)

    @property
    def url(self) -> str | None:
        """The live view's ``ws://host:port`` (None without ``live``)."""
        if self.live is None or self.live.server is None:
            return None
        return f"ws://{self._host}:{self.live.server.port}"

    # -- writing ---------------------------------------------------------------

    def _send(self, topic: str, message: Any, t: float, key: str = "") -> None:
        ns = self.m.nanoseconds(t)
        for output in self.outputs:
            output.send(topic, message, ns, key)
        self.counts[topic] += 1

    def __call__(self, record: dict) -> None:
        """The trace sink: a log line per record; a primary-layer message per switch."""
        if self.closed:
            return
        t = record["t"]
        self._send("/atlas/trace", self.m.log_line(record), t)
        if record["event"] == "layer-switched":
            self._send("/atlas/primary_layer", {"layer": record.get("layer"), "previous": record.get("previous"),
                                                "reason": record.get("reason", "")}, t)

    def pace(self, t: float) -> None:
        """The engine's ``pace`` hook (``run_mission(until, pace=recorder.pace)``): samples the
        world when a pose sample is due at simulated time ``t``."""
        index = math.floor(t * self.pose_rate + 1e-9)
        if index <= self._sample_index or self.closed:
            return
        self._sample_index = index
        self.sample(t)

    def sample(self, t: float) -> None:
        """Everything that is sampled, at simulated time ``t``: the pose, and what changed since."""
        live = self.live
        if live is not None:
            ns = self.m.nanoseconds(t)
            live.server.broadcast_time(ns)
            live.resend(ns)
        engine = self.engine
        sim = engine.simulation
        if sim is None:
            return
        if not self._started:
            self._start()
        self._last_sample = t
        m = self.m
        x, y, heading = sim.pose
        where = m.pose(x, y, heading)
        self._send("/robot/pose", m.pose_in_frame(t, where), t)
        self._send("/tf", m.robot_transform(t, x, y, heading), t)
        self._grow_path(t, x, y, heading, where)
        beliefs = engine.manager.context.beliefs
        sonar = beliefs.get(SONAR)
        if sonar is not None and sonar is not self._sonar:
            self._sonar = sonar
            config = engine.world.sonar
            self._send("/robot/sonar", m.sonar_scan(t, where, sonar[0], sonar[1], sim.radius, config.max_range), t)
        grid = beliefs.get(GRID)
        if grid is not None:
            self._grid_key = (id(grid), engine.stack.grid_version if engine.stack is not None else 0)
            if self._grid_key != self._grid_sent and t >= self._grid_due:
                self._send_grid(t, grid)
        topology = beliefs.get(TOPOLOGY)
        if topology is not None and topology is not self._topology:
            self._topology = topology
            self._send("/map/topology", m.scene(m.topology_entity(t, topology)), t)
        route = beliefs.get(ROUTE)
        route_key = (id(route), route.index) if route is not None else None
        if route_key != self._route_key:
            self._route_key = route_key
            update = m.scene(m.route_entity(t, route)) if route is not None else m.scene(deleted=[(t, "route")])
            self._send("/robot/route", update, t)
        doors = sim.doors_open
        if doors != self._doors:
            self._doors = doors
            self._send("/world/scene", m.scene(m.doors_entity(t, engine.world, doors)), t, "doors")
        obstacles = sim.obstacles()
        if obstacles != self._obstacles:
            self._obstacles = obstacles
            self._send("/world/scene", m.scene(m.obstacles_entity(t, obstacles)), t, "obstacles")

    def _start(self) -> None:
        """The world as it starts (t = 0): walls, places, and the prior map's graph."""
        self._started = True
        m, engine = self.m, self.engine
        self._send("/world/scene", m.scene(m.walls_entity(0.0, engine.world)), 0.0, "walls")
        self._send("/world/scene", m.scene(m.places_entity(0.0, engine.world)), 0.0, "places")
        believed = engine.stack.world if engine.stack is not None else engine.world
        self._send("/map/topology", m.scene(m.prior_topology_entity(0.0, believed)), 0.0)

    def _grow_path(self, t: float, x: float, y: float, heading: float, where: Any) -> None:
        last = self._path_at
        if last is None or math.hypot(x - last[0], y - last[1]) >= PATH_STEP or \
                abs(math.remainder(heading - last[2], math.tau)) >= PATH_TURN:
            self._path_at = (x, y, heading)
            self._path.append(where)
        if t >= self._path_due and len(self._path) != self._path_sent:
            self._send_path(t)

    def _send_path(self, t: float) -> None:
        self._path_sent = len(self._path)
        self._path_due = t + max(PATH_PERIOD, len(self._path) / 1000.0)
        self._send("/robot/path", self.m.path(t, self._path), t)

    def _send_grid(self, t: float, grid: Any) -> None:
        self._grid_sent = self._grid_key
        self._grid_due = t + self.grid_period
        self._send("/map/grid", self.m.occupancy_grid(t, grid), t)

    # -- the end -----------------------------------------------------------------

    def close(self) -> None:
        """Finish the recording (safe to call twice, and after a failed or interrupted run): a last
        pose sample if the run ended after the last one, the last path and grid, then the MCAP
        file is closed and the live server stopped."""
        if self.closed:
            return
        try:
            engine = self.engine
            if engine.built and engine.simulation is not None:
                end = engine.now()
                if self._last_sample is None or end > self._last_sample + 1e-9:
                    self.sample(end)
                    end = self._last_sample
                if len(self._path) != self._path_sent:
                    self._send_path(end)
                grid = engine.grid
                if grid is not None and self._grid_key != self._grid_sent:
                    self._send_grid(end, grid)
        finally:
            self.closed = True
            self._close_outputs()

    def _close_outputs(self) -> None:
        for output in self.outputs:
            output.close()

