"""Record a run for Foxglove: an MCAP file (``atlas run --record``), a live WebSocket view (``--live``), or both.

A :class:`RunRecorder` watches a :class:`~atlas_rap.layers.engine.MissionEngine`
the way :class:`~atlas_rap.views.run_picture.RunPicture` does: it is a trace
sink (every trace record becomes a log line), and its :meth:`RunRecorder.pace`
is the engine's ``pace`` hook, called at every sequencer tick (10 Hz of
simulated time), where it samples the world. Make it before the mission is
loaded, pass ``pace`` to the run, and close it in a ``finally``, so that a
failed or interrupted run still leaves a whole file (written beside its
path and renamed into place at close: an old file stays until then)::

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
  ``map`` → ``base_link``): the robot's **true** pose (ground truth, as a
  simulator's ``/ground_truth``: for evaluation; the robot itself knows only
  its belief, ``/robot/estimate``) at every **pose sample**:
  ``pose_rate`` per simulated second (10 Hz, at most the sequencer's rate),
  at ``1/rate, 2/rate, ...``, plus one at :meth:`~RunRecorder.close` when the run
  ended between two samples (an interrupted run);
- ``/robot/path`` (``foxglove.PosesInFrame``): the true path so far (a pose kept each
  time the robot moved 2 cm or turned 0.05 rad), once a simulated second
  while it changes, and at the end; a long path is sent less often (every
  ``len(path) / 1000`` s), so the cost stays bounded;
- the robot's pose **belief**, when the localiser estimates it (odometry
  with noise: :mod:`atlas_rap.skills.localising`; a run whose odometry is
  exact has none of these channels, :data:`ESTIMATE_TOPICS`), in nav2's
  manner (AMCL's ``/amcl_pose`` and ``/particle_cloud``):

  - ``/robot/estimate`` (``foxglove.PoseInFrame``): the estimated pose, at
    each filter update (the latest at each pose sample), stamped when the
    filter made it;
  - ``/robot/estimate/covariance`` (JSON, schema ``atlas.PoseCovariance``:
    ``x``, ``y``, ``heading``, ``covariance`` 3 x 3 row-major in m² and
    rad², ``sigma_x``, ``sigma_y``, ``sigma_heading``, ``localised``,
    ``particles``): the same estimate's numbers (Foxglove has no
    ``PoseWithCovariance``; a Plot panel plots ``.sigma_x``);
  - ``/robot/estimate/ellipse`` (``foxglove.SceneUpdate``, entity
    ``estimate``): the same estimate's 2-sigma ellipse in x and y, a flat
    disc at the estimated position (red and named "lost" when the robot
    is not localised);
  - ``/robot/particles`` (``foxglove.PosesInFrame``): the particle cloud of
    an update, at most 500 poses (every k-th particle), at most twice a
    simulated second (:data:`PARTICLES_PERIOD`);
  - ``/robot/estimated_path`` (``foxglove.PosesInFrame``): the path the robot
    believes it drove (the localiser's track), kept and sent as ``/robot/path`` is;
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
paths, estimate and primary layer when it subscribes (the WebSocket server forgets
what it sent before); the MCAP file is not affected by viewers.

The world's channels (:data:`WORLD_TOPICS`) are sampled by one
:class:`WorldSampler`, which reads whatever holds the world: the engine in one
process, or a skill host's session (``atlas skills serve --record HOST.mcap``,
``--live``: a :class:`HostRecorder`, a file per session). With the skills on
another host (``atlas run --connect --record``) the sequencer's
:class:`RunRecorder` records the trace and the primary layer; both files
are in the same simulated time, so Foxglove opens them together.

Over 25 KB on purpose: the recorder: the world sampler, the outputs (file and live) and the
skill host's recorder share one channel set and one timing.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable

from atlas_rap.errors import AtlasError, RunError
from atlas_rap.outputs import AtomicFile, OutputError, write_all
from atlas_rap.skills.beliefs import GRID, POSE_ESTIMATE, POSE_TRACK, ROUTE, SONAR, TOPOLOGY
from atlas_rap.trace_events import Event

if TYPE_CHECKING:  # the engine does not import its observers
    from atlas_rap.layers.engine import MissionEngine

POSE_RATE = 10.0
"""Pose samples per simulated second (at most the sequencer's 10 Hz: samples are taken at its ticks)."""

GRID_PERIOD = 1.0
"""Simulated seconds between two grids sent, at least (a grid is sent only when it changed)."""

PATH_PERIOD = 1.0
"""Simulated seconds between two paths sent, at least (longer once the path has over 1000 poses)."""

PATH_STEP = 0.02
PATH_TURN = 0.05
"""A pose joins the path when the robot moved this many metres or turned this many radians since the last."""

MAX_PARTICLES = 500
"""Poses of the particle cloud sent at most (every k-th particle: nav2's ``/particle_cloud`` is as thin)."""

PARTICLES_PERIOD = 0.5
"""Simulated seconds between two particle clouds sent, at least. Every filter update's cloud (up to 10 Hz)
made ``deliver.rap`` at 5 % drift record 2.8 MB of clouds beside 1.5 MB of everything else."""

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
    # the pose belief (last, so the other channels keep their ids in the file)
    "/robot/estimate": ("foxglove.PoseInFrame", "PoseInFrameChannel"),
    "/robot/estimate/covariance": ("atlas.PoseCovariance", ""),
    "/robot/estimate/ellipse": ("foxglove.SceneUpdate", "SceneUpdateChannel"),
    "/robot/particles": ("foxglove.PosesInFrame", "PosesInFrameChannel"),
    "/robot/estimated_path": ("foxglove.PosesInFrame", "PosesInFrameChannel"),
}
"""Topic → (schema name, the SDK's channel class; "" for JSON); see the module docstring for what each carries."""

ESTIMATE_TOPICS = ("/robot/estimate", "/robot/estimate/covariance", "/robot/estimate/ellipse", "/robot/particles",
                   "/robot/estimated_path")
"""The channels of the pose belief: they get messages only when the localiser estimates the pose (a channel
with no message is not written into the file)."""

WORLD_TOPICS = tuple(topic for topic in TOPICS if not topic.startswith("/atlas/"))
"""The world's channels: all but the trace and the primary layer (what a skill host records)."""

_LATCHED = ("/world/scene", "/map/topology", "/robot/route", "/map/grid", "/robot/path", "/atlas/primary_layer",
            *ESTIMATE_TOPICS)
"""What a live viewer connecting late is sent again: the latest of each (per scene entity)."""

_JSON_SCHEMAS = {  # topic -> the JSON schema of its messages
    "/atlas/primary_layer": {
        "title": "atlas.PrimaryLayer", "type": "object",
        "properties": {"layer": {"type": "string"}, "previous": {"type": ["string", "null"]},
                       "reason": {"type": "string"}},
    },
    "/robot/estimate/covariance": {
        "title": "atlas.PoseCovariance", "type": "object",
        "properties": {**{name: {"type": "number"} for name in ("x", "y", "heading", "sigma_x", "sigma_y",
                                                                "sigma_heading")},
                       "covariance": {"type": "array", "items": {"type": "number"}, "minItems": 9, "maxItems": 9},
                       "localised": {"type": "boolean"}, "particles": {"type": "integer"}},
    },
}

FOXGLOVE_MISSING = ("recording for Foxglove needs the Foxglove SDK, which is not installed: "
                    "install atlas-rap[foxglove] (pip install 'atlas-rap[foxglove]')")


def require_foxglove() -> Any:
    """The ``foxglove`` module (the SDK, ``foxglove-sdk`` on PyPI); a one-line
    :class:`RunError` saying how to install it when it is missing."""
    try:
        import foxglove
        import foxglove.channels  # noqa: F401
        import foxglove.messages  # noqa: F401
    except ImportError:
        raise RunError(FOXGLOVE_MISSING) from None
    return foxglove


class _Output:
    """One place messages go: a Foxglove context with a channel per topic, and its sink
    (an MCAP writer or a WebSocket server). A live one keeps the latest latched messages."""

    def __init__(self, fox: Any, live: bool, topics: Iterable[str] = TOPICS) -> None:
        self.context = fox.Context()
        self.channels: dict[str, Any] = {}
        for topic in topics:
            kind = TOPICS[topic][1]
            if kind:
                self.channels[topic] = getattr(fox.channels, kind)(topic, context=self.context)
            else:
                self.channels[topic] = fox.Channel(topic, schema=_JSON_SCHEMAS[topic], context=self.context)
        self.latched: dict[str, dict[str, Any]] | None = None
        if live:
            self.forget()
        self.pending: set[str] = set()  # topics a viewer subscribed to since the last sample
        self.writer: Any = None
        self.file: AtomicFile | None = None  # the writer's file, renamed into place at close
        self.server: Any = None

    def forget(self) -> None:
        """A live one forgets the latched messages (a skill host's new session: a new world)."""
        self.latched = {topic: {} for topic in _LATCHED if topic in self.channels}

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

    def close(self, keep: bool = True) -> None:
        """Finish the MCAP file and rename it into place (an :class:`OutputError` when it cannot be
        finished: the old file stays; ``keep=False``: drop it), and stop the live server."""
        try:
            if self.writer is not None:
                writer, file, self.writer = self.writer, self.file, None
                try:
                    writer.close()
                except Exception as exc:  # the SDK's own error: the disk is full
                    file.discard()  # type: ignore[union-attr]
                    if keep:
                        raise OutputError(f"{file.what} {file.path}: cannot write it ({exc})") from None
                if keep:
                    file.commit()  # type: ignore[union-attr]
                else:
                    file.discard()  # type: ignore[union-attr]
        finally:
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


def _open_file(fox: Any, path: str | Path, topics: Iterable[str], flag: str = "--record") -> _Output:
    """An MCAP file's output, written beside ``path`` and renamed into place when closed
    (``atlas_rap.outputs``; a :class:`RunError` when it cannot be written)."""
    output = _Output(fox, live=False, topics=topics)
    file = AtomicFile(path, flag, stream=None)
    try:
        output.writer = fox.open_mcap(file.writing, allow_overwrite=True, context=output.context)
    except BaseException as exc:  # the SDK's own errors: a folder, no permission
        file.discard()
        if not isinstance(exc, Exception):
            raise
        raise RunError(f"{flag} {path}: cannot write it ({exc})") from None
    output.file = file
    return output


def _open_live(fox: Any, host: str, port: int, topics: Iterable[str]) -> _Output:
    """A live WebSocket server's output (:class:`RunError` when the port cannot be had)."""
    output = _Output(fox, live=True, topics=topics)
    try:
        output.server = fox.start_server(name="atlas-rap", host=host, port=port, context=output.context,
                                         capabilities=[fox.websocket.Capability.Time],
                                         server_listener=_subscriptions(fox, output))
    except Exception as exc:  # the port is taken, the host is not this machine's
        raise RunError(f"--live: cannot serve on {host}:{port} ({exc})") from None
    return output


def _live_url(host: str, live: _Output | None) -> str | None:
    if live is None or live.server is None:
        return None
    return f"ws://{host}:{live.server.port}"


class WorldSampler:
    """Samples a run's world into the world channels (:data:`WORLD_TOPICS`): the one implementation,
    for a run in one process (:class:`RunRecorder`) and for a skill host (:class:`HostRecorder`).

    ``source`` holds the world and is read at each sample (it may be built after the sampler is
    made): ``simulation`` (None: no world here, nothing is sampled), ``manager`` (the skill
    manager: its beliefs give the sonar, grid, topology and route), ``world`` (the simulated
    world), ``stack`` (the layer stack or None: the believed world, the grid's version) and
    ``now()`` (simulated seconds). A :class:`~atlas_rap.layers.engine.MissionEngine` is one, a
    skill host's session another. ``outputs``: where every message goes; ``live``: the one
    of them that is a WebSocket server (its time is broadcast and late viewers served at each
    sample). ``start``: when the world starts (the walls, places and prior topology are stamped then).
    """

    def __init__(self, source: Any, outputs: list[_Output], *, live: _Output | None = None,
                 pose_rate: float = POSE_RATE, grid_period: float = GRID_PERIOD, start: float = 0.0) -> None:
        from atlas_rap.views import foxglove_messages

        self.m = foxglove_messages
        self.source = source
        self.outputs = outputs
        self.live = live
        self.pose_rate = pose_rate
        self.grid_period = grid_period
        self.start = start
        self._sample_index = math.floor(start * pose_rate + 1e-9)
        self._last_sample: float | None = None
        self._started = False
        self._path = _GrowingPath("/robot/path", foxglove_messages.pose)
        self._believed = _GrowingPath("/robot/estimated_path", foxglove_messages.pose)
        self._track_seen = 0  # how many poses of the localiser's track were read
        self._estimate: Any = None
        self._particles_due = 0.0
        self._sonar: Any = None
        self._grid_key: tuple[int, int] | None = None
        self._grid_sent: tuple[int, int] | None = None
        self._grid_due = 0.0
        self._topology: Any = None
        self._route_key: tuple[int, int] | None = None
        self._doors: dict[str, bool] | None = None
        self._obstacles: list | None = None
        self.counts: dict[str, int] = {topic: 0 for topic in TOPICS}

    def send(self, topic: str, message: Any, t: float, key: str = "") -> None:
        """Write ``message`` on ``topic`` at simulated time ``t`` to every output."""
        ns = self.m.nanoseconds(t)
        for output in self.outputs:
            output.send(topic, message, ns, key)
        self.counts[topic] += 1

    def pace(self, t: float) -> None:
        """A ``pace`` hook (the executive's, at every sequencer tick): samples the world when a
        pose sample is due at simulated time ``t``."""
        index = math.floor(t * self.pose_rate + 1e-9)
        if index <= self._sample_index:
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
        source = self.source
        sim = source.simulation
        if sim is None:
            return
        if not self._started:
            self._start()
        self._last_sample = t
        m = self.m
        x, y, heading = sim.pose
        where = m.pose(x, y, heading)
        self.send("/robot/pose", m.pose_in_frame(t, where), t)
        self.send("/tf", m.robot_transform(t, x, y, heading), t)
        self._path.add(x, y, heading, where)
        if self._path.due(t):
            self._send_path(t, self._path)
        beliefs = source.manager.context.beliefs
        sonar = beliefs.get(SONAR)
        if sonar is not None and sonar is not self._sonar:
            self._sonar = sonar
            config = source.world.sonar
            self.send("/robot/sonar", m.sonar_scan(t, where, sonar[0], sonar[1], sim.radius, config.max_range), t)
        grid = beliefs.get(GRID)
        if grid is not None:
            self._grid_key = (id(grid), source.stack.grid_version if source.stack is not None else 0)
            if self._grid_key != self._grid_sent and t >= self._grid_due:
                self._send_grid(t, grid)
        topology = beliefs.get(TOPOLOGY)
        if topology is not None and topology is not self._topology:
            self._topology = topology
            self.send("/map/topology", m.scene(m.topology_entity(t, topology)), t)
        route = beliefs.get(ROUTE)
        route_key = (id(route), route.index) if route is not None else None
        if route_key != self._route_key:
            self._route_key = route_key
            update = m.scene(m.route_entity(t, route)) if route is not None else m.scene(deleted=[(t, "route")])
            self.send("/robot/route", update, t)
        doors = sim.doors_open
        if doors != self._doors:
            self._doors = doors
            self.send("/world/scene", m.scene(m.doors_entity(t, source.world, doors)), t, "doors")
        obstacles = sim.obstacles()
        if obstacles != self._obstacles:
            self._obstacles = obstacles
            self.send("/world/scene", m.scene(m.obstacles_entity(t, obstacles)), t, "obstacles")
        self._sample_belief(t, beliefs)

    def _sample_belief(self, t: float, beliefs: Any) -> None:
        """The localiser's latest estimate, if it is new (stamped when it was made), and the believed
        path (nothing when the pose is not estimated)."""
        estimate = beliefs.get(POSE_ESTIMATE)
        if estimate is not None and estimate is not self._estimate:
            self._estimate = estimate
            m, at = self.m, estimate.time
            self.send("/robot/estimate", m.pose_in_frame(at, m.pose(*estimate.pose)), at)
            self.send("/robot/estimate/covariance", m.covariance_record(estimate), at)
            self.send("/robot/estimate/ellipse", m.scene(m.estimate_entity(at, estimate)), at, "estimate")
            if estimate.particles is not None and at >= self._particles_due:
                self._particles_due = at + PARTICLES_PERIOD
                self.send("/robot/particles", m.particles(at, estimate.particles, MAX_PARTICLES), at)
        track = beliefs.get(POSE_TRACK)
        if track:
            believed = self._believed
            for _, x, y, heading in track[self._track_seen:]:
                believed.add(x, y, heading)
            self._track_seen = len(track)
            if believed.due(t):
                self._send_path(t, believed)

    def _start(self) -> None:
        """The world as it starts: walls, places, and the prior map's graph."""
        self._started = True
        m, source, t = self.m, self.source, self.start
        self.send("/world/scene", m.scene(m.walls_entity(t, source.world)), t, "walls")
        self.send("/world/scene", m.scene(m.places_entity(t, source.world)), t, "places")
        believed = source.stack.world if source.stack is not None else source.world
        self.send("/map/topology", m.scene(m.prior_topology_entity(t, believed)), t)

    def _send_path(self, t: float, path: _GrowingPath) -> None:
        path.sent = len(path.poses)
        path.next = t + max(PATH_PERIOD, len(path.poses) / 1000.0)
        self.send(path.topic, self.m.path(t, path.poses), t)

    def _send_grid(self, t: float, grid: Any) -> None:
        self._grid_sent = self._grid_key
        self._grid_due = t + self.grid_period
        self.send("/map/grid", self.m.occupancy_grid(t, grid), t)

    def finish(self) -> None:
        """The end of the world's run: a last pose sample if it ended after the last one, the
        last path and grid (the outputs stay open)."""
        source = self.source
        if source.simulation is None:
            return
        end = source.now()
        if self._last_sample is None or end > self._last_sample + 1e-9:
            self.sample(end)
            end = self._last_sample
        for path in (self._path, self._believed):
            if len(path.poses) != path.sent:
                self._send_path(end, path)
        grid = source.manager.context.beliefs.get(GRID)
        if grid is not None and self._grid_key != self._grid_sent:
            self._send_grid(end, grid)


class _GrowingPath:
    """A path a topic sends whole (``/robot/path``, ``/robot/estimated_path``): a pose joins it when
    the robot moved :data:`PATH_STEP` or turned :data:`PATH_TURN` since the last one kept; it is
    due once :data:`PATH_PERIOD` after it was last sent, if it grew (less often once long)."""

    def __init__(self, topic: str, pose_of: Any) -> None:
        self.topic = topic
        self.pose_of = pose_of  # (x, y, heading) -> a Foxglove pose
        self.poses: list[Any] = []
        self.last: tuple[float, float, float] | None = None
        self.sent = 0  # poses in the last message sent
        self.next = 0.0  # when the next message may be sent

    def add(self, x: float, y: float, heading: float, where: Any = None) -> None:
        """The robot is at (x, y, heading) (``where``: the same as a Foxglove pose, when made already)."""
        last = self.last
        if last is None or math.hypot(x - last[0], y - last[1]) >= PATH_STEP or \
                abs(math.remainder(heading - last[2], math.tau)) >= PATH_TURN:
            self.last = (x, y, heading)
            self.poses.append(where if where is not None else self.pose_of(x, y, heading))

    def due(self, t: float) -> bool:
        return t >= self.next and len(self.poses) != self.sent


class RunRecorder:
    """Records one run to an MCAP file (``path``) and/or serves it live (``live``) for Foxglove.

    ``host``/``port``: where the live WebSocket server listens (port 0: any
    free port; :attr:`url` says which). ``pose_rate``, ``grid_period``: see
    :data:`POSE_RATE`, :data:`GRID_PERIOD`. Raises :class:`RunError` when
    the SDK is missing, the file cannot be made or the port cannot be had.
    With ``atlas run --connect`` the engine has no world of its own (the skill
    host records it: :class:`HostRecorder`), so only the trace and the primary
    layer are recorded here.
    """

    def __init__(self, engine: MissionEngine, *, path: str | Path | None = None, live: bool = False,
                 host: str = "127.0.0.1", port: int = 8765, pose_rate: float = POSE_RATE,
                 grid_period: float = GRID_PERIOD) -> None:
        fox = require_foxglove()
        self.engine = engine
        self.outputs: list[_Output] = []
        self.live: _Output | None = None
        self.closed = False
        self._host = host
        if path is not None:
            self.outputs.append(_open_file(fox, path, TOPICS))
        if live:
            try:
                self.live = _open_live(fox, host, port, TOPICS)
            except AtlasError:
                self._close_outputs(keep=False)
                raise
            self.outputs.append(self.live)
        self.world = WorldSampler(engine, self.outputs, live=self.live, pose_rate=pose_rate,
                                  grid_period=grid_period)
        self.counts = self.world.counts
        engine.trace.add_sink(self)

    @property
    def url(self) -> str | None:
        """The live view's ``ws://host:port`` (None without ``live``)."""
        return _live_url(self._host, self.live)

    def __call__(self, record: dict) -> None:
        """The trace sink: a log line per record; a primary-layer message per switch."""
        if self.closed:
            return
        t = record["t"]
        send = self.world.send
        send("/atlas/trace", self.world.m.log_line(record), t)
        if record["event"] == Event.LAYER_SWITCHED:
            send("/atlas/primary_layer", {"layer": record.get("layer"), "previous": record.get("previous"),
                                          "reason": record.get("reason", "")}, t)

    def pace(self, t: float) -> None:
        """The engine's ``pace`` hook (``run_mission(until, pace=recorder.pace)``): samples the
        world when a pose sample is due at simulated time ``t``."""
        if not self.closed:
            self.world.pace(t)

    def sample(self, t: float) -> None:
        """Everything that is sampled, at simulated time ``t`` (:meth:`WorldSampler.sample`)."""
        self.world.sample(t)

    def close(self) -> None:
        """Finish the recording (safe to call twice, and after a failed or interrupted run): a last
        pose sample if the run ended after the last one, the last path and grid, then the MCAP
        file is closed (renamed into place) and the live server stopped."""
        if self.closed:
            return
        try:
            self.world.finish()
        finally:
            self.closed = True
            self._close_outputs()

    def discard(self) -> None:
        """Stop without a recording (a run that never started): the file at ``path``, if any, stays
        as it was; the live server stops."""
        if not self.closed:
            self.closed = True
            self._close_outputs(keep=False)

    def _close_outputs(self, keep: bool = True) -> None:
        """Close every output, also when one fails; then raise the first failure."""
        errors = write_all({f"output {i}": lambda output=output: output.close(keep)
                            for i, output in enumerate(self.outputs)})
        if errors:
            raise next(iter(errors.values()))


class HostRecorder:
    """A skill host's recording (``atlas skills serve --record HOST.mcap --live``): the world
    channels (:data:`WORLD_TOPICS`) of each sequencer's session, sampled by a :class:`WorldSampler`
    at the host's sequencer ticks, in the same simulated time as the sequencer's own recording.

    Each session is a file of its own, closed when the session ends (however it ends):
    the first is ``path``, the next ``HOST-2.mcap``, ``HOST-3.mcap``, ... (:func:`session_file`).
    The live server (``live``) serves from the host's start to its end, one session after
    another (a viewer stays connected; time starts again with each session's world).
    """

    def __init__(self, *, path: str | Path | None = None, live: bool = False, host: str = "127.0.0.1",
                 port: int = 8765, pose_rate: float = POSE_RATE, grid_period: float = GRID_PERIOD) -> None:
        self.fox = require_foxglove()
        self.path = Path(path) if path is not None else None
        self.pose_rate = pose_rate
        self.grid_period = grid_period
        self._host = host
        self.live = _open_live(self.fox, host, port, WORLD_TOPICS) if live else None
        self.sampler: WorldSampler | None = None
        self.file: _Output | None = None
        self.file_path: Path | None = None
        self.written: list[Path] = []
        self.closed = False

    @property
    def url(self) -> str | None:
        """The live view's ``ws://host:port`` (None without ``live``)."""
        return _live_url(self._host, self.live)

    def begin(self, source: Any, number: int, start: float) -> WorldSampler:
        """Session ``number`` starts at simulated time ``start`` with the world of ``source``
        (see :class:`WorldSampler`); its sampler, whose :meth:`~WorldSampler.pace` is the
        host's executive's hook."""
        self.end()
        outputs: list[_Output] = []
        if self.path is not None:
            self.file_path = session_file(self.path, number)
            self.file = _open_file(self.fox, self.file_path, WORLD_TOPICS)
            outputs.append(self.file)
        if self.live is not None:
            self.live.forget()
            outputs.append(self.live)
        self.sampler = WorldSampler(source, outputs, live=self.live, pose_rate=self.pose_rate,
                                    grid_period=self.grid_period, start=start)
        return self.sampler

    def end(self) -> Path | None:
        """The session ends: its last samples, and its file closed; the file written (or None)."""
        sampler, self.sampler = self.sampler, None
        file, self.file = self.file, None
        written, self.file_path = self.file_path, None
        try:
            if sampler is not None:
                sampler.finish()
        finally:
            if file is not None:
                file.close()
                self.written.append(written)  # type: ignore[arg-type]
        return written if file is not None else None

    def close(self) -> Path | None:
        """The host ends: the session's file closed (:meth:`end`, its path), the live server stopped."""
        if self.closed:
            return None
        self.closed = True
        try:
            return self.end()
        finally:
            if self.live is not None:
                self.live.close()


def session_file(path: str | Path, number: int) -> Path:
    """The file of a skill host's session ``number``: ``path`` for the first, ``NAME-2.mcap``, ... after;
    a device (``/dev/null``, a pipe) is every session's."""
    path = Path(path)
    device = (path.exists() and not path.is_file()) or path.is_relative_to("/dev")
    return path if number <= 1 or device else path.with_name(f"{path.stem}-{number}{path.suffix}")
