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
caller's thread. Frames that cannot be decoded are logged and dropped.
"""

from __future__ import annotations

import atexit
import json
import logging
import queue
import re
import threading
from typing import Any, Iterable, Sequence

from atlas_rap.errors import AtlasError
from atlas_rap.skillbus.messages import DecodeError, Frame, decode

log = logging.getLogger("atlas_rap.skillbus")

LEASE_MS = 1000
"""Zenoh link lease: a peer that says nothing for this long is gone (its tokens with it)."""


class BusError(AtlasError):
    """The bus cannot be used: Zenoh is not installed, an endpoint is bad or taken, nobody answers."""


def _zenoh() -> Any:
    try:
        import zenoh
    except ImportError:
        raise BusError("the Zenoh skill bus needs eclipse-zenoh: pip install 'atlas-rap[zenoh]'") from None
    return zenoh


def open_session(listen: Sequence[str] = (), connect: Sequence[str] = ()) -> Any:
    """A Zenoh peer session listening on / connecting to the given endpoints (``tcp/127.0.0.1:7447``)."""
    zenoh = _zenoh()
    for endpoint in (*listen, *connect):
        check_endpoint(endpoint)
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("listen/endpoints", json.dumps(list(listen)))
    config.insert_json5("connect/endpoints", json.dumps(list(connect)))
    config.insert_json5("transport/link/tx/lease", str(LEASE_MS))
    if listen:
        config.insert_json5("listen/exit_on_failure", "true")
    try:
        session = zenoh.open(config)
    except Exception as exc:  # zenoh raises ZError with the cause in its text
        where = ", ".join(listen) if listen else ", ".join(connect)
        raise BusError(f"cannot open the Zenoh session on {where}: {_first_line(exc)}") from None
    _open_sessions.add(session)
    return session


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


class Conversation:
    """One side of one robot's exchange over a Zenoh session.

    ``inbound``: the keys the other side puts on; ``peer_token``: the other
    side's liveliness token (a key expression), watched. Declare this side's
    own token with :meth:`declare_token` once the subscriptions are made.
    """

    def __init__(self, session: Any, inbound: Iterable[str], peer_token: str) -> None:
        zenoh = _zenoh()
        self.session = session
        self.inbox: queue.Queue[tuple[str, Any]] = queue.Queue()
        self.peer_alive = threading.Event()
        self._publishers: dict[str, Any] = {}
        self._zenoh = zenoh
        # direct callbacks (Zenoh's own threads, which only queue): indirect ones run on Python threads
        # that keep the interpreter from exiting until they are undeclared
        on_sample = zenoh.handlers.Callback(self._on_sample, indirect=False)
        on_token = zenoh.handlers.Callback(self._on_token, indirect=False)
        self._subscribers = [session.declare_subscriber(key, on_sample) for key in inbound]
        self._liveliness = session.liveliness().declare_subscriber(peer_token, on_token, history=True)
        self._token: Any = None
        self.dropped = 0
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
                self.inbox.get_nowait()
            except queue.Empty:
                return

    # Zenoh's threads: only queue what came.
    def _on_sample(self, sample: Any) -> None:
        self.inbox.put((FRAME, (str(sample.key_expr), sample.payload.to_bytes())))

    def _on_token(self, sample: Any) -> None:
        if sample.kind == self._zenoh.SampleKind.PUT:
            self.peer_alive.set()
            self.inbox.put((ALIVE, str(sample.key_expr)))
        else:
            self.peer_alive.clear()
            self.inbox.put((GONE, str(sample.key_expr)))

    def put(self, key: str, frame: Frame) -> None:
        """Put ``frame`` on ``key`` (reliable, sent at once, never dropped under congestion)."""
        self.put_bytes(key, frame.to_bytes())

    def put_bytes(self, key: str, data: bytes) -> None:
        publisher = self._publishers.get(key)
        if publisher is None:
            z = self._zenoh
            publisher = self._publishers[key] = self.session.declare_publisher(
                key, congestion_control=z.CongestionControl.BLOCK, express=True, reliability=z.Reliability.RELIABLE)
        publisher.put(data)

    def receive(self, timeout: float) -> tuple[str, Any] | None:
        """The next thing that came within ``timeout`` seconds: ``(FRAME, (key, Frame))``,
        ``(ALIVE, key)`` or ``(GONE, key)``; None when nothing did. Frames that cannot be
        decoded (or are not frames) are logged and dropped."""
        try:
            kind, item = self.inbox.get(timeout=timeout) if timeout > 0 else self.inbox.get_nowait()
        except queue.Empty:
            return None
        if kind != FRAME:
            return kind, item
        key, data = item
        try:
            frame = decode(data)
        except DecodeError as exc:
            self.dropped += 1
            log.warning("skill bus: dropped a message on %s that cannot be decoded: %s", key, exc)
            return self.receive(0)
        if type(frame) is not Frame:
            self.dropped += 1
            log.warning("skill bus: dropped a %s message on %s that came outside a frame", frame.TYPE, key)
            return self.receive(0)
        return FRAME, (key, frame)

    def close(self) -> None:
        """Undeclare everything this conversation declared (the session stays open)."""
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
