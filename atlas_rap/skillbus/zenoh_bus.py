"""The Eclipse Zenoh transport of the skill bus: sessions, one robot's conversation, liveliness.

Sessions are Zenoh **peers** with explicit endpoints (``listen`` on the
host, ``connect`` on the sequencer) and multicast scouting off, so runs on a
shared machine never find each other by accident. The link lease is one
second, so a host that dies without closing its connection (a lost
network) is seen gone within a second; a killed process closes its TCP
connection and is seen gone at once.

:class:`Conversation` is one side's end of one robot's exchange: it puts
:class:`~atlas_rap.skillbus.messages.Frame`\\ s on keys
(:mod:`atlas_rap.skillbus.keys`) and receives the other side's frames and
the other side's liveliness in one queue, in order. Zenoh's threads only
put bytes in that queue; decoding and everything after it happen on the
caller's thread. What the other side sent is handed on as bytes, with
the Zenoh attachment that carries its tag (:mod:`~atlas_rap.skillbus.auth`);
the turn-taking of :mod:`~atlas_rap.skillbus.protocol` checks and decodes it.

**Hostile input.** Whatever comes is refused at the door when it is larger
than the message cap (``max_message``, default 1 MiB; Zenoh's own
``transport/link/rx/max_message_size`` is set a little above it, so that
Zenoh drops far larger messages on the links it reads before Python sees
them), and the inbox holds at most :data:`INBOX_BYTES`; no exception
ever escapes a Zenoh callback. What is dropped is logged by a
:class:`DropLog`: the first few of each kind, then a count now and then, so
a flood of garbage does not become a flood of log lines.

**Configuration.** ``--zenoh-config FILE`` passes Zenoh's own JSON5
configuration (TLS, mutual TLS, user/password, ACL: Zenoh's documentation).
The bus's own settings (peer mode, no multicast scouting, the one-second
link lease, the message cap) are applied where the file leaves Zenoh's
default, and the command's endpoints are added to the file's. A ``tls/`` or
``quic/`` endpoint without certificates in the configuration is refused
before Zenoh is asked (Zenoh's own error is "Missing TLS private key").
"""

from __future__ import annotations

import atexit
import ipaddress
import json
import logging
import queue
import re
import threading
import time
from pathlib import Path
from typing import Any, Iterable, Sequence

from atlas_rap.errors import SkillBusError
from atlas_rap.skillbus.messages import MAX_MESSAGE

log = logging.getLogger("atlas_rap.skillbus")

LEASE_MS = 1000
"""Zenoh link lease: a peer that says nothing for this long is gone (its tokens with it)."""

INBOX_BYTES = 64 << 20
"""The most a conversation's inbox holds, in bytes, before what comes is dropped (a flood)."""

SECURE = ("tls", "quic")
"""Endpoint protocols that encrypt and authenticate the link itself."""


class BusError(SkillBusError):
    """The bus cannot be used: Zenoh is not installed, an endpoint is bad or taken, nobody answers."""


def _zenoh() -> Any:
    try:
        import zenoh
    except ImportError:
        raise BusError("the Zenoh skill bus needs eclipse-zenoh: pip install 'atlas-rap[zenoh]'") from None
    return zenoh


def open_session(listen: Sequence[str] = (), connect: Sequence[str] = (), *,
                 config_file: str | Path | None = None, max_message: int = MAX_MESSAGE) -> Any:
    """A Zenoh peer session listening on / connecting to the given endpoints (``tcp/127.0.0.1:7447``),
    with Zenoh's configuration from ``config_file`` if given (module docstring)."""
    zenoh = _zenoh()
    config, listen, connect = checked_config(listen, connect, config_file)
    default = zenoh.Config()
    for key, value in (("mode", '"peer"'), ("scouting/multicast/enabled", "false"),
                       ("transport/link/tx/lease", str(LEASE_MS)),
                       ("transport/link/rx/max_message_size", str(max_message + (64 << 10)))):
        if config.get_json(key) == default.get_json(key):
            config.insert_json5(key, value)
    config.insert_json5("listen/endpoints", json.dumps(list(listen)))
    config.insert_json5("connect/endpoints", json.dumps(list(connect)))
    if listen:
        config.insert_json5("listen/exit_on_failure", "true")
    try:
        session = zenoh.open(config)
    except Exception as exc:  # zenoh raises ZError with the cause in its text
        where = ", ".join(listen) if listen else ", ".join(connect)
        raise BusError(f"cannot open the Zenoh session on {where}: {_first_line(exc)}") from None
    _open_sessions.add(session)
    return session


def checked_config(listen: Sequence[str], connect: Sequence[str],
                   config_file: str | Path | None) -> tuple[Any, list[str], list[str]]:
    """Zenoh's configuration and the endpoints to listen on and connect to (the file's, then the
    command's), each checked: a :class:`BusError` says what is wrong before anything is opened."""
    config = load_config(config_file)
    listen = _endpoints(config, "listen", listen)
    connect = _endpoints(config, "connect", connect)
    for endpoint in (*listen, *connect):
        check_endpoint(endpoint)
    _check_tls(config, listen, connect, config_file)
    return config, listen, connect


def load_config(config_file: str | Path | None) -> Any:
    """Zenoh's configuration from a JSON5 file (Zenoh's own format), or Zenoh's default one."""
    zenoh = _zenoh()
    if config_file is None:
        return zenoh.Config()
    path = Path(config_file)
    if not path.is_file():
        raise BusError(f"--zenoh-config {path}: no such file")
    try:
        return zenoh.Config.from_file(str(path))
    except Exception as exc:
        raise BusError(f"--zenoh-config {path}: not a Zenoh configuration: {_first_line(exc)}") from None


def _endpoints(config: Any, which: str, given: Sequence[str]) -> list[str]:
    """The ``listen``/``connect`` endpoints a configuration file set (not Zenoh's defaults, which
    listen on every interface), then the command's (each once)."""
    key = f"{which}/endpoints"
    try:
        value = config.get_json(key)
        found = json.loads(value) if value != _zenoh().Config().get_json(key) else []
    except Exception:
        found = []
    if isinstance(found, dict):  # per mode: {"peer": [...], "router": [...]}
        found = found.get("peer", [])
    return list(dict.fromkeys([*(e for e in found if isinstance(e, str)), *given]))


def configured_endpoints(config_file: str | Path | None, which: str) -> list[str]:
    """The ``listen`` or ``connect`` endpoints a Zenoh configuration file names."""
    return _endpoints(load_config(config_file), which, ())


DEFAULT_HOST_ENDPOINT = "tcp/127.0.0.1:7447"
"""Where a skill host listens when told nothing: this machine only."""


def host_endpoints(listen: Sequence[str], connect: Sequence[str], config_file: str | Path | None) -> tuple[str, ...]:
    """The endpoints a skill host listens on: ``listen``, else none when it connects somewhere or its
    configuration file names some to listen on, else :data:`DEFAULT_HOST_ENDPOINT`."""
    if listen:
        return tuple(listen)
    if connect or (config_file is not None and configured_endpoints(config_file, "listen")):
        return ()
    return (DEFAULT_HOST_ENDPOINT,)


def _check_tls(config: Any, listen: Sequence[str], connect: Sequence[str], config_file: str | Path | None) -> None:
    """A ``tls/`` or ``quic/`` endpoint needs certificates in the configuration: say so plainly."""
    def tls(name: str) -> Any:
        try:
            return json.loads(config.get_json(f"transport/link/tls/{name}"))
        except Exception:
            return None

    where = f"the --zenoh-config file {config_file}" if config_file is not None else "a --zenoh-config FILE"
    secure_listen = [e for e in listen if e.partition("/")[0] in SECURE]
    secure_connect = [e for e in connect if e.partition("/")[0] in SECURE]
    if secure_listen and not (tls("listen_certificate") and tls("listen_private_key")):
        raise BusError(f"{secure_listen[0]}: listening on TLS needs the host's certificate and key: give "
                       f"transport/link/tls/listen_certificate and listen_private_key in {where} "
                       f"(docs/how-to/skill-bus.md, 'The skill bus across machines')")
    if secure_connect and not tls("root_ca_certificate"):
        raise BusError(f"{secure_connect[0]}: connecting over TLS needs the certificate authority that signed the "
                       f"host's certificate: give transport/link/tls/root_ca_certificate in {where} "
                       f"(docs/how-to/skill-bus.md, 'The skill bus across machines')")


def exposure_warning(listen: Sequence[str], config_file: str | Path | None = None) -> str | None:
    """A warning when the host listens beyond this machine without TLS (None when it does not);
    :class:`BusError` when the endpoints or the configuration are wrong (:func:`checked_config`)."""
    _, listen, _ = checked_config(listen, (), config_file)
    exposed = [e for e in listen if e.partition("/")[0] not in SECURE and e.partition("/")[0] != "unixsock-stream"
               and not _loopback(e.partition("/")[2].rpartition(":")[0])]
    if not exposed:
        return None
    return (f"warning: listening on {', '.join(exposed)} without TLS: anyone on that network can read every "
            f"frame and hold up the bus, and only the token keeps them from driving the robot. For a network you "
            f"do not trust, listen on tls/ with --zenoh-config "
            f"(docs/how-to/skill-bus.md, 'The skill bus across machines').")


def _loopback(host: str) -> bool:
    host = host.strip("[]")
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def close_session(session: Any) -> None:
    """Close a session opened by :func:`open_session` (a process with an open session hangs at exit)."""
    if session in _open_sessions:
        _open_sessions.discard(session)
        try:
            session.close()
        except Exception:  # closing twice, or while Zenoh shuts down
            pass


def _close_all() -> None:
    """At exit: undeclare what is left and close the sessions (else the interpreter hangs on Zenoh's threads)."""
    for conversation in list(_open_conversations):
        conversation.close()
    for session in list(_open_sessions):
        close_session(session)


_open_sessions: set[Any] = set()
_open_conversations: set[Any] = set()
atexit.register(_close_all)


def check_endpoint(endpoint: str) -> str:
    """``endpoint`` if it looks like a Zenoh locator (``tcp/HOST:PORT``); else BusError."""
    proto, _, rest = endpoint.partition("/")
    host, _, port = rest.rpartition(":")
    if proto not in ("tcp", "udp", "tls", "quic", "ws", "unixsock-stream") or not rest:
        raise BusError(f"{endpoint!r} is not a Zenoh endpoint: write it as tcp/HOST:PORT, e.g. tcp/127.0.0.1:7447")
    if proto in ("tcp", "udp", "tls", "quic", "ws") and (not host or not port.isdigit() or not 0 < int(port) < 65536):
        raise BusError(f"{endpoint!r} is not a Zenoh endpoint: write it as tcp/HOST:PORT, e.g. tcp/127.0.0.1:7447")
    return endpoint


FRAME, ALIVE, GONE = "frame", "alive", "gone"


class DropLog:
    """Logs what a side drops: the first :data:`FIRST` of each kind as they come, then how many
    more every :data:`EVERY` seconds, so a flood of garbage is a few lines, not a flood of them."""

    FIRST = 3
    EVERY = 10.0

    def __init__(self, robot: str = "") -> None:
        self.robot = robot
        self.counts: dict[str, int] = {}
        self.unsaid: dict[str, int] = {}
        self._said_at = time.monotonic()

    def __call__(self, kind: str, key: str, detail: str = "") -> None:
        """Drop one message of ``kind`` (a reason, said as "a frame that ...") that came on ``key``."""
        count = self.counts[kind] = self.counts.get(kind, 0) + 1
        if count <= self.FIRST:
            log.warning("skill bus: dropped %s on %s%s", kind, key, f": {detail}" if detail else "")
        else:
            self.unsaid[kind] = self.unsaid.get(kind, 0) + 1
        if self.unsaid and time.monotonic() - self._said_at >= self.EVERY:
            self.flush()

    def flush(self) -> None:
        """Say how many were dropped and not said yet."""
        self._said_at = time.monotonic()
        for kind, count in self.unsaid.items():
            log.warning("skill bus: dropped %d more: %s", count, kind)
        self.unsaid.clear()

    def close(self) -> None:
        """Say what is left to say, and how many were dropped in all (when more than a few were)."""
        self.flush()
        if self.total > self.FIRST:
            counts = "; ".join(f"{count} {kind}" for kind, count in sorted(self.counts.items(), key=lambda c: -c[1]))
            log.warning("skill bus:%s %d messages dropped in all: %s", f" robot {self.robot}:" if self.robot else "",
                        self.total, counts)

    @property
    def total(self) -> int:
        return sum(self.counts.values())


class Conversation:
    """One side of one robot's exchange over a Zenoh session.

    ``inbound``: the keys the other side puts on; ``peer_token``: the other
    side's liveliness token (a key expression), watched. Declare this side's
    own token with :meth:`declare_token` once the subscriptions are made.
    ``max_message``: the largest payload taken, in bytes.
    """

    def __init__(self, session: Any, inbound: Iterable[str], peer_token: str, *,
                 max_message: int = MAX_MESSAGE, robot: str = "") -> None:
        zenoh = _zenoh()
        self.session = session
        self.max_message = max_message
        self.inbox: queue.Queue[tuple[str, Any]] = queue.Queue()
        self.queued = 0  # bytes in the inbox
        self.peer_alive = threading.Event()
        self.drops = DropLog(robot)
        self._publishers: dict[str, Any] = {}
        self._lock = threading.Lock()
        self._zenoh = zenoh
        # direct callbacks (Zenoh's own threads, which only queue): indirect ones run on Python threads
        # that keep the interpreter from exiting until they are undeclared
        on_sample = zenoh.handlers.Callback(self._on_sample, indirect=False)
        on_token = zenoh.handlers.Callback(self._on_token, indirect=False)
        self._subscribers = [session.declare_subscriber(key, on_sample) for key in inbound]
        self._liveliness = session.liveliness().declare_subscriber(peer_token, on_token, history=True)
        self._token: Any = None
        _open_conversations.add(self)

    def declare_token(self, key: str | None) -> None:
        """Hold the liveliness token ``key`` (None: hold none); the one held before is undeclared."""
        if self._token is not None:
            try:
                self._token.undeclare()
            except Exception:
                pass
        self._token = self.session.liveliness().declare_token(key) if key else None

    def drain(self) -> None:
        """Forget whatever came and was not received yet."""
        while True:
            try:
                self._take(self.inbox.get_nowait())
            except queue.Empty:
                return

    # Zenoh's threads: only queue what came; never raise.
    def _on_sample(self, sample: Any) -> None:
        try:
            key = str(sample.key_expr)
            size = len(sample.payload)
            if size > self.max_message:
                self.drops(f"a message larger than the cap of {self.max_message} bytes", key, f"{size} bytes")
                return
            if self.queued + size > INBOX_BYTES:
                self.drops("a message that came while the inbox was full", key)
                return
            attachment = sample.attachment
            item = (key, sample.payload.to_bytes(), attachment.to_bytes() if attachment is not None else b"")
            with self._lock:
                self.queued += size
            self.inbox.put((FRAME, item))
        except Exception as exc:  # nothing may escape into Zenoh's thread
            log.warning("skill bus: dropped a message that could not be taken: %s", exc)

    def _on_token(self, sample: Any) -> None:
        try:
            if sample.kind == self._zenoh.SampleKind.PUT:
                self.peer_alive.set()
                self.inbox.put((ALIVE, str(sample.key_expr)))
            else:
                self.peer_alive.clear()
                self.inbox.put((GONE, str(sample.key_expr)))
        except Exception as exc:
            log.warning("skill bus: a liveliness change could not be taken: %s", exc)

    def put(self, key: str, payload: bytes, attachment: bytes = b"") -> None:
        """Put ``payload`` on ``key`` (reliable, sent at once, never dropped under congestion), with
        ``attachment`` (the tag) if any. Safe from several threads."""
        with self._lock:
            publisher = self._publishers.get(key)
            if publisher is None:
                z = self._zenoh
                publisher = self._publishers[key] = self.session.declare_publisher(
                    key, congestion_control=z.CongestionControl.BLOCK, express=True,
                    reliability=z.Reliability.RELIABLE)
        publisher.put(payload, attachment=attachment or None)

    def receive(self, timeout: float) -> tuple[str, Any] | None:
        """The next thing that came within ``timeout`` seconds: ``(FRAME, (key, payload,
        attachment))``, ``(ALIVE, key)`` or ``(GONE, key)``; None when nothing did."""
        try:
            item = self.inbox.get(timeout=timeout) if timeout > 0 else self.inbox.get_nowait()
        except queue.Empty:
            return None
        return self._take(item)

    def _take(self, item: tuple[str, Any]) -> tuple[str, Any]:
        if item[0] == FRAME:
            with self._lock:
                self.queued -= len(item[1][1])
        return item

    def close(self) -> None:
        """Undeclare everything this conversation declared (the session stays open)."""
        self.drops.close()
        for entity in [*self._subscribers, self._liveliness, *self._publishers.values(),
                       *([self._token] if self._token is not None else [])]:
            try:
                entity.undeclare()
            except Exception:
                pass
        self._subscribers, self._publishers, self._token = [], {}, None
        _open_conversations.discard(self)


def alive_robots(session: Any, timeout: float = 1.0) -> list[str]:
    """The robots whose skill hosts hold their liveliness token now (``atlas/*/host``)."""
    from atlas_rap.skillbus import keys

    found = []
    for reply in session.liveliness().get(f"{keys.ROOT}/*/host", timeout=timeout):
        try:
            found.append(str(reply.ok.key_expr).split("/")[1])
        except Exception:
            continue
    return sorted(set(found))


def _first_line(exc: BaseException) -> str:
    """Zenoh's error, first line, without the Rust source locations it carries."""
    text = (str(exc).strip() or type(exc).__name__).splitlines()[0]
    return re.sub(r"\s+at \S+\.rs:\d+\.?", "", text).strip()
