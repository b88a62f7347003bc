"""Read a recording (``atlas run --record``) back: its channels, and its messages as plain dicts.

Use it to check a recording or to draw one (``views.mcap_picture``) without
Foxglove and without the protobuf library. The ``mcap`` package
(``pip install 'atlas-rap[foxglove]'``) reads the file; a protobuf message
is decoded with the schema the file itself carries (a
``FileDescriptorSet``), by a small wire-format decoder, into a dict of
field name → value (lists for repeated fields, nested dicts for messages,
``bytes`` for bytes; a field left at its default is absent, as protobuf
leaves it out). JSON messages are parsed as JSON.

    recording = read_recording("run.mcap")
    recording.channels()               # {topic: (schema name, message count)}
    for t, msg in recording.messages("/robot/pose"): ...   # t in simulated seconds
"""

from __future__ import annotations

import json
import struct
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from atlas_rap.errors import RunError

# FieldDescriptorProto.type values, by how they are read off the wire
_VARINT = {3, 4, 5, 8, 13, 14}  # int64 uint64 int32 bool uint32 enum
_ZIGZAG = {17, 18}  # sint32 sint64
_FIXED64 = {1: "<d", 6: "<Q", 16: "<q"}  # double fixed64 sfixed64
_FIXED32 = {2: "<f", 7: "<I", 15: "<i"}  # float fixed32 sfixed32
_STRING, _MESSAGE, _BYTES, _BOOL = 9, 11, 12, 8
_REPEATED = 3


def _varint(data: bytes, at: int) -> tuple[int, int]:
    value = shift = 0
    while True:
        byte = data[at]
        at += 1
        value |= (byte & 0x7F) << shift
        if byte < 0x80:
            return value, at
        shift += 7


def _fields(data: bytes) -> Iterator[tuple[int, int, Any]]:
    """(field number, wire type, raw value) of each field of a protobuf message, in order."""
    at, end = 0, len(data)
    while at < end:
        key, at = _varint(data, at)
        number, wire = key >> 3, key & 7
        if wire == 0:
            value, at = _varint(data, at)
        elif wire == 1:
            value, at = data[at:at + 8], at + 8
        elif wire == 2:
            size, at = _varint(data, at)
            value, at = data[at:at + size], at + size
        elif wire == 5:
            value, at = data[at:at + 4], at + 4
        else:
            raise ValueError(f"protobuf wire type {wire} is not supported")
        yield number, wire, value


@dataclass(frozen=True, slots=True)
class _Field:
    name: str
    type: int
    repeated: bool
    type_name: str  # ".foxglove.Pose" for a message field


class ProtobufSchemas:
    """The message types of one ``FileDescriptorSet`` (a protobuf schema in an MCAP file), and their decoding."""

    def __init__(self, descriptor_set: bytes) -> None:
        self.types: dict[str, dict[int, _Field]] = {}
        for number, _, file_data in _fields(descriptor_set):
            if number == 1:
                self._file(file_data)

    def _file(self, data: bytes) -> None:
        package = ""
        messages = []
        for number, _, value in _fields(data):
            if number == 2:
                package = value.decode()
            elif number == 4:
                messages.append(value)
        for message in messages:
            self._message(message, f".{package}" if package else "")

    def _message(self, data: bytes, scope: str) -> None:
        name, fields, nested = "", {}, []
        for number, _, value in _fields(data):
            if number == 1:
                name = value.decode()
            elif number == 2:
                spec = dict((n, v) for n, _, v in _fields(value))
                fields[spec[3]] = _Field(spec[1].decode(), spec.get(5, 0), spec.get(4) == _REPEATED,
                                         spec.get(6, b"").decode())
            elif number == 3:
                nested.append(value)
        full = f"{scope}.{name}"
        self.types[full] = fields
        for inner in nested:
            self._message(inner, full)

    def decode(self, type_name: str, data: bytes) -> dict[str, Any]:
        """The message ``data`` of type ``type_name`` (``foxglove.Grid`` or ``.foxglove.Grid``) as a dict."""
        fields = self.types[type_name if type_name.startswith(".") else "." + type_name]
        out: dict[str, Any] = {}
        for number, wire, raw in _fields(data):
            spec = fields.get(number)
            if spec is None:
                continue
            if wire == 2 and spec.type not in (_STRING, _BYTES, _MESSAGE):  # packed repeated numbers
                values = list(self._packed(spec.type, raw))
            else:
                values = [self._value(spec, raw)]
            if spec.repeated:
                out.setdefault(spec.name, []).extend(values)
            else:
                out[spec.name] = values[-1]
        return out

    def _value(self, spec: _Field, raw: Any) -> Any:
        kind = spec.type
        if kind in _VARINT:
            if kind == _BOOL:
                return bool(raw)
            return raw - (1 << 64) if kind in (3, 5) and raw >= 1 << 63 else raw
        if kind in _ZIGZAG:
            return (raw >> 1) ^ -(raw & 1)
        if kind in _FIXED64:
            return struct.unpack(_FIXED64[kind], raw)[0]
        if kind in _FIXED32:
            return struct.unpack(_FIXED32[kind], raw)[0]
        if kind == _STRING:
            return raw.decode("utf-8")
        if kind == _MESSAGE:
            return self.decode(spec.type_name, raw)
        return bytes(raw)

    def _packed(self, kind: int, raw: bytes) -> Iterator[Any]:
        if kind in _FIXED64:
            yield from struct.unpack(f"<{len(raw) // 8}{_FIXED64[kind][1]}", raw)
        elif kind in _FIXED32:
            yield from struct.unpack(f"<{len(raw) // 4}{_FIXED32[kind][1]}", raw)
        else:
            spec = _Field("", kind, False, "")
            at = 0
            while at < len(raw):
                value, at = _varint(raw, at)
                yield self._value(spec, value)


@dataclass
class Recording:
    """A recording read into memory: per topic, its schema name and its raw messages (time-ordered)."""

    path: Path
    schemas: dict[str, tuple[str, str, bytes]] = field(default_factory=dict)  # topic → (name, encoding, data)
    raw: dict[str, list[tuple[int, bytes]]] = field(default_factory=dict)  # topic → [(log time ns, data)]
    _decoders: dict[bytes, ProtobufSchemas] = field(default_factory=dict)

    def channels(self) -> dict[str, tuple[str, int]]:
        """Topic → (schema name, how many messages), for every channel with a message."""
        return {topic: (self.schemas[topic][0], len(messages)) for topic, messages in sorted(self.raw.items())}

    def times(self, topic: str) -> list[float]:
        """The log times of a topic's messages, in simulated seconds, in file order."""
        return [ns / 1e9 for ns, _ in self.raw.get(topic, [])]

    def messages(self, topic: str) -> Iterator[tuple[float, dict[str, Any]]]:
        """(simulated seconds, message as a dict) of each message on ``topic``, in time order."""
        for ns, data in self.raw.get(topic, []):
            yield ns / 1e9, self.decode(topic, data)

    def last(self, topic: str) -> dict[str, Any] | None:
        """The last message on ``topic`` as a dict, or None when it has none."""
        messages = self.raw.get(topic)
        return self.decode(topic, messages[-1][1]) if messages else None

    def decode(self, topic: str, data: bytes) -> dict[str, Any]:
        """One message of ``topic`` as a dict (protobuf by the file's schema, or JSON)."""
        name, encoding, schema = self.schemas[topic]
        if encoding == "protobuf":
            decoder = self._decoders.get(schema)
            if decoder is None:
                decoder = self._decoders[schema] = ProtobufSchemas(schema)
            return decoder.decode(name, data)
        return json.loads(data)


def read_recording(path: str | Path) -> Recording:
    """Read an MCAP file: every channel's schema and every message, sorted by log time per topic.

    Raises :class:`RunError` (one line) when the ``mcap`` package is missing
    or the file is not an MCAP file.
    """
    try:
        from mcap.reader import make_reader
    except ImportError:
        raise RunError("reading a recording needs the mcap package: pip install 'atlas-rap[foxglove]'") from None
    recording = Recording(Path(path))
    try:
        with open(path, "rb") as stream:
            for schema, channel, message in make_reader(stream).iter_messages(log_time_order=True):
                if channel.topic not in recording.schemas:
                    recording.schemas[channel.topic] = (schema.name if schema else "", channel.message_encoding,
                                                        schema.data if schema else b"")
                recording.raw.setdefault(channel.topic, []).append((message.log_time, message.data))
    except OSError as exc:
        raise RunError(f"{path}: cannot read it ({exc.strerror or exc})") from None
    except Exception as exc:  # the mcap reader's own errors: not an MCAP file, a truncated one
        raise RunError(f"{path}: not a readable MCAP recording ({type(exc).__name__})") from None
    return recording
