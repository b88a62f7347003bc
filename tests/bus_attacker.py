"""A stranger on the skill bus, for the security tests: it uses only eclipse-zenoh and the
standard library, never atlas-rap, as someone on the same network would.

    python bus_attacker.py --connect tcp/127.0.0.1:PORT --listen tcp/127.0.0.1:MINE --robot robot MODE

Modes:

- ``flood``: record every frame it sees on ``atlas/ROBOT/**`` (payload and attachment);
  from then on, until it has sent ``--count`` frames and its standard input closes or
  says ``stop``, put on every key the bus uses: garbage bytes, oversized messages,
  deeply nested JSON, forged frames (an enable of ``navigate-to``), each frame it saw
  again as it was (a replay) and with a flipped bit, and Hellos with made-up tags.
- ``squat``: put a forged Hello (a made-up tag and nonce) for the robot and hold a
  sequencer's liveliness token, as if it had a session; on a line ``replay`` on its
  input, put again every frame it saw the sequencer send (Hello, ticks, enables, in
  order, with their tags): an earlier run replayed whole. It ends when its input
  closes or says ``stop``, and then writes what it saw to ``--save FILE`` if given.
- ``replay``: put again, at once, every frame toward a host that ``--load FILE`` holds
  (a ``squat``'s ``--save``), then wait until its input closes.

It prints ``ready`` once its subscriptions are made, ``replayed N`` after a replay, and
``sent N`` at the end.
"""

from __future__ import annotations

import argparse
import base64
import json
import os
import random
import sys
import threading

import zenoh


def open_session(connect: list[str], listen: list[str]) -> zenoh.Session:
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("connect/endpoints", json.dumps(connect))
    config.insert_json5("listen/endpoints", json.dumps(listen))
    return zenoh.open(config)


def keys(robot: str) -> list[str]:
    """Every key the skill bus uses for one robot (as its documentation lists them)."""
    root = f"atlas/{robot}"
    return [f"{root}/skill/navigate-to/enable", f"{root}/skill/navigate-to/disable", f"{root}/clock/tick",
            f"{root}/clock/ack", f"{root}/event/done", f"{root}/event/facts", f"{root}/event/note",
            f"{root}/sequencer/ack", f"{root}/sequencer/hello", f"{root}/sequencer/beat",
            f"{root}/session/welcome"]


def nested(depth: int) -> bytes:
    return b"[" * depth + b"]" * depth


def forged(robot: str, seen: list[tuple[str, bytes, bytes]]) -> bytes:
    """A frame as the sequencer would send it, enabling navigate-to, in a session seen on the bus."""
    session = ""
    for _, payload, _ in seen[-20:]:
        try:
            session = json.loads(payload).get("session", session)
        except (ValueError, AttributeError, RecursionError):  # its own garbage, seen too
            continue
    frame = {"v": 1, "type": "frame", "session": session, "seq": random.randrange(0, 2000), "tick": 0, "phase": 0,
             "messages": [{"v": 1, "type": "enable", "call": ["navigate-to", "office"]}]}
    return json.dumps(frame).encode()


def flipped(data: bytes) -> bytes:
    if not data:
        return b"\x01"
    index = random.randrange(len(data))
    return data[:index] + bytes([data[index] ^ (1 << random.randrange(8))]) + data[index + 1:]


def flood(session: zenoh.Session, robot: str, count: int, stop: threading.Event,
          seen: list[tuple[str, bytes, bytes]]) -> int:
    sent = 0
    targets = keys(robot)
    kinds = ["garbage", "nested", "forged", "replay", "flipped", "hello"]
    while sent < count or not stop.is_set():
        kind = kinds[sent % len(kinds)] if sent % 25 else "oversized"
        key = targets[(sent // len(kinds)) % len(targets)]
        attachment = os.urandom(32)
        if kind == "garbage":
            payload = os.urandom(random.randrange(1, 512))
        elif kind == "oversized":
            payload = b'{"v": 1, "type": "frame", "pad": "' + b"x" * (1 << 20) + b'"}'
        elif kind == "nested":
            payload = nested(5000)
        elif kind == "forged":
            payload = forged(robot, seen)
        elif kind == "hello":
            frame = {"v": 1, "type": "frame", "session": os.urandom(6).hex(), "seq": 0, "tick": 0, "phase": 0,
                     "messages": [{"v": 1, "type": "hello", "robot": robot, "tick": 0}]}
            payload, attachment = json.dumps(frame).encode(), os.urandom(48)
            key = f"atlas/{robot}/sequencer/hello"
        elif seen:
            key, payload, attachment = random.choice(seen[-50:])
            if kind == "flipped":
                if random.random() < 0.5:
                    payload = flipped(payload)
                else:
                    attachment = flipped(attachment)
        else:
            payload = b"{}"
        try:
            session.put(key, payload, attachment=attachment)
        except Exception as exc:  # a link Zenoh closed (an oversized message): keep going
            print(f"put failed: {exc}", file=sys.stderr, flush=True)
        sent += 1
    return sent


def replay_toward_host(session: zenoh.Session, frames: list[tuple[str, bytes, bytes]]) -> int:
    """Put again, in order, the frames a sequencer sent a host (with their tags)."""
    toward_host = [item for item in frames
                   if "/sequencer/" in item[0] or "/skill/" in item[0] or item[0].endswith("/clock/tick")]
    for key, payload, attachment in toward_host:
        session.put(key, payload, attachment=attachment or None)
    return len(toward_host)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--connect", action="append", default=[])
    parser.add_argument("--listen", action="append", default=[])
    parser.add_argument("--robot", default="robot")
    parser.add_argument("--count", type=int, default=1000)
    parser.add_argument("--save")
    parser.add_argument("--load")
    parser.add_argument("mode", choices=["flood", "squat", "replay"])
    args = parser.parse_args()
    session = open_session(args.connect, args.listen)
    seen: list[tuple[str, bytes, bytes]] = []

    def record(sample: zenoh.Sample) -> None:
        if len(sample.payload) > 65536:  # its own oversized messages, seen too
            return
        attachment = sample.attachment
        seen.append((str(sample.key_expr), sample.payload.to_bytes(), attachment.to_bytes() if attachment else b""))

    subscriber = session.declare_subscriber(f"atlas/{args.robot}/**", zenoh.handlers.Callback(record, indirect=False))
    stop = threading.Event()
    replay = threading.Event()

    def watch_input() -> None:
        for line in sys.stdin:
            if line.strip() == "stop":
                break
            if line.strip() == "replay":
                replay.set()
        stop.set()

    threading.Thread(target=watch_input, daemon=True).start()
    sent = 0
    if args.mode == "flood":
        print("ready", flush=True)
        sent = flood(session, args.robot, args.count, stop, seen)
    elif args.mode == "replay":
        with open(args.load, encoding="utf-8") as saved:
            frames = [tuple(base64.b64decode(part) if i else part for i, part in enumerate(json.loads(line)))
                      for line in saved]
        print("ready", flush=True)
        sent = replay_toward_host(session, frames)
        print(f"replayed {sent}", flush=True)
        stop.wait()
    else:
        frame = {"v": 1, "type": "frame", "session": os.urandom(6).hex(), "seq": 0, "tick": 0, "phase": 0,
                 "messages": [{"v": 1, "type": "hello", "robot": args.robot, "tick": 0}]}
        token = session.liveliness().declare_token(f"atlas/{args.robot}/sequencer/{frame['session']}")
        session.put(f"atlas/{args.robot}/sequencer/hello", json.dumps(frame).encode(), attachment=os.urandom(48))
        sent = 1
        print("ready", flush=True)
        while not stop.is_set():
            if replay.wait(0.1):
                replay.clear()
                count = replay_toward_host(session, list(seen))
                sent += count
                print(f"replayed {count}", flush=True)
        token.undeclare()
        if args.save:
            with open(args.save, "w", encoding="utf-8") as out:
                for key, payload, attachment in seen:
                    out.write(json.dumps([key, base64.b64encode(payload).decode(),
                                          base64.b64encode(attachment).decode()]) + "\n")
    print(f"sent {sent}", flush=True)
    subscriber.undeclare()
    session.close()


if __name__ == "__main__":
    main()
