"""A minimal Foxglove WebSocket client on the standard library, for testing ``atlas run --live``.

Enough of RFC 6455 and of Foxglove's WebSocket protocol to connect, read the
server's JSON ops (``serverInfo``, ``advertise``), subscribe to channels and
read the binary ``messageData`` frames that follow (no fragmentation, no
extensions, no TLS).
"""

from __future__ import annotations

import base64
import json
import os
import socket
import struct
from urllib.parse import urlparse

SUBPROTOCOLS = "foxglove.sdk.v1, foxglove.websocket.v1"
MESSAGE_DATA = 1  # the first byte of a binary messageData frame from the server


class FoxgloveClient:
    """One connection to a Foxglove WebSocket server at ``url`` (``ws://host:port``)."""

    def __init__(self, url: str, timeout: float = 10.0) -> None:
        where = urlparse(url)
        self.sock = socket.create_connection((where.hostname, where.port), timeout=timeout)
        key = base64.b64encode(os.urandom(16)).decode()
        self.sock.sendall((f"GET / HTTP/1.1\r\nHost: {where.hostname}:{where.port}\r\nUpgrade: websocket\r\n"
                           f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n"
                           f"Sec-WebSocket-Protocol: {SUBPROTOCOLS}\r\n\r\n").encode())
        self.buffer = b""
        while b"\r\n\r\n" not in self.buffer:
            self.buffer += self._recv()
        head, self.buffer = self.buffer.split(b"\r\n\r\n", 1)
        self.status = head.split(b"\r\n", 1)[0].decode()
        if " 101 " not in self.status:
            raise ConnectionError(f"no WebSocket upgrade: {self.status}")

    def _recv(self) -> bytes:
        data = self.sock.recv(65536)
        if not data:
            raise ConnectionError("the server closed the connection")
        return data

    def _take(self, n: int) -> bytes:
        while len(self.buffer) < n:
            self.buffer += self._recv()
        data, self.buffer = self.buffer[:n], self.buffer[n:]
        return data

    def frame(self) -> tuple[int, bytes]:
        """The next frame from the server: (opcode, payload); 1 text, 2 binary, 8 close."""
        first, second = self._take(2)
        size = second & 0x7F
        if size == 126:
            size = struct.unpack(">H", self._take(2))[0]
        elif size == 127:
            size = struct.unpack(">Q", self._take(8))[0]
        mask = self._take(4) if second & 0x80 else None
        payload = self._take(size)
        if mask:
            payload = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
        return first & 0x0F, payload

    def advertised(self) -> dict[str, dict]:
        """Wait for the server's ``advertise`` op; its channels by topic."""
        while True:
            opcode, payload = self.frame()
            if opcode == 1:
                op = json.loads(payload)
                if op["op"] == "advertise":
                    return {c["topic"]: c for c in op["channels"]}

    def send_json(self, op: dict) -> None:
        """Send a JSON op as a text frame."""
        self._send(1, json.dumps(op).encode())

    def _send(self, opcode: int, payload: bytes) -> None:
        """One final frame, masked as clients must."""
        mask = os.urandom(4)
        size = len(payload)
        head = bytes([0x80 | opcode]) + (bytes([0x80 | size]) if size < 126
                                         else bytes([0x80 | 126]) + struct.pack(">H", size))
        self.sock.sendall(head + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(payload)))

    def close(self) -> None:
        """Say goodbye (a close frame, status 1000), then close the socket."""
        try:
            self._send(8, struct.pack(">H", 1000))
        except OSError:
            pass
        self.sock.close()
