"""Benchmark the skill bus: the sequencer and the skills in one process, and over Eclipse Zenoh.

Prints one JSON object a line:

- ``bus-events``: facts a skill host posts to the sequencer, one batch each
  (memory, rules and the wait index take each, and the host waits for its
  turn back), per second: ``in_process`` (the skill link called directly),
  ``zenoh`` (two Zenoh peer sessions on loopback, the host on a thread
  of this process, the whole protocol of ``skillbus.protocol``, every frame
  authenticated) and ``zenoh_unauthenticated`` (the same with frames neither
  tagged nor checked, as the bus was before it admitted only its own sequencer).
- ``bus-latency``: enable → done round trip of a skill that finishes as soon
  as it is enabled, median and 99th percentile in microseconds, each way.
- ``bus-deliver``: ``rap_library/missions/deliver.rap`` in simulated time
  with the whole stack, simulated seconds per wall second, best of
  ``--runs``, the runs of the three ways interleaved: in one process; over
  Zenoh with ``atlas skills serve`` running in another process, frames
  authenticated; and the same without authentication (``SkillHostServer(secret=None)``
  and ``BusSettings(authenticate=False)``, which no command offers).
  ``ratio``: Zenoh over in process (target >= 0.5); ``auth_cost``: the
  authenticated run's wall time over the unauthenticated one's (target <= 1.1).
  ``same_trace`` says whether the three traces were equal, byte for byte.
- ``record``: what ``--record`` costs the same run in one process (best with
  over best without; target <= 1.3), measured by ``bench_record.py``, which
  also measures it on a run that maps.

Run: ``pip install '.[zenoh]' && python benchmarks/bench_bus.py`` (``--quick``
for fewer events and runs).
"""

from __future__ import annotations

import argparse
import json
import socket
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent)]  # the checkout, if not installed

MISSION = HERE.parent / "rap_library" / "missions" / "deliver.rap"


def emit(record: dict) -> None:
    print(json.dumps(record), flush=True)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Emitter:
    """A skill manager with two skills: ``(emit N)`` posts N facts, then finishes; ``(ping)`` finishes."""

    def __init__(self) -> None:
        self.host = None

    def connect(self, host) -> None:
        self.host = host

    def skills(self) -> dict[str, set[int]]:
        return {"emit": {1}, "ping": {0}}

    def produces(self) -> set[str]:
        return {"done", "event"}

    def instance(self, call):
        return call.functor

    def enable(self, call) -> None:
        from atlas_rap.logic import Compound

        for i in range(call.args[0] if call.functor == "emit" else 0):
            self.host.change([("assert", Compound("event", (i,)))], "skills")
        self.host.change([("assert", Compound("done", (call, ":succeed")))], f"skill ({call.functor})", skill=call)

    def disable(self, call) -> None:
        pass


def serve_emitter(endpoint: str, ready: threading.Event, stop: threading.Event, secret) -> None:
    """A skill host on this thread serving the :class:`Emitter`, one session (``secret`` None: no
    authentication)."""
    from atlas_rap.skillbus import keys
    from atlas_rap.skillbus.host import HostDoor, HostSession, SessionEnded, await_hello
    from atlas_rap.skillbus.messages import Welcome
    from atlas_rap.skillbus.zenoh_bus import Conversation, close_session, open_session

    session = open_session(listen=[endpoint])
    conversation = Conversation(session, keys.to_host("robot"), keys.sequencer_token("robot"))
    conversation.declare_token(keys.host_token("robot"))
    door = HostDoor(conversation, "robot", secret)
    ready.set()
    try:
        hello = await_hello(door, stop.is_set)
        if hello is None:
            return
        host = HostSession(door, hello, 0, lambda: 0)
        manager = Emitter()
        manager.connect(host)
        host.manager = manager
        host.welcome(Welcome("robot", "bench", {"emit": (1,), "ping": (0,)}, ("done", "event")))
        host.first_tick()
    except SessionEnded:
        pass
    finally:
        conversation.close()
        close_session(session)


def measure(link_for, events: int, pings: int) -> tuple[float, list[float]]:
    """(events per second, enable → done round trips in µs) through the link ``link_for()`` gives."""
    from atlas_rap.logic import Compound
    from atlas_rap.sequencer import Sequencer

    link = link_for()
    seq = Sequencer(skills=link)
    start = time.perf_counter()
    link.enable(Compound("emit", (events,)))
    rate = events / (time.perf_counter() - start)
    ping = Compound("ping", ())
    times = []
    for _ in range(pings):
        start = time.perf_counter()
        link.enable(ping)
        times.append((time.perf_counter() - start) * 1e6)
        assert Compound("done", (ping, ":succeed")) in seq.memory
        seq.change([("retract", Compound("done", (ping, ":succeed")))], "bench")
    return rate, times


def bus_protocol(events: int, pings: int, rounds: int) -> None:
    """The events and round trips of each way, ``rounds`` times interleaved; the best round of each kept."""
    import os

    from atlas_rap.skillbus.auth import TOKEN_ENV, secret_from_env
    from atlas_rap.skillbus.remote import BusSettings, RemoteSkills

    os.environ.setdefault(TOKEN_ENV, os.urandom(32).hex())  # this process is both host and sequencer
    rates: dict[str, float] = {}
    latencies: dict[str, list[float]] = {}

    def keep(name: str, rate: float, times: list[float]) -> None:
        if rate > rates.get(name, 0.0):
            rates[name], latencies[name] = rate, times

    for _ in range(rounds):
        keep("in_process", *measure(Emitter, events, pings))
        for name, secret in (("zenoh", secret_from_env()), ("zenoh_unauthenticated", None)):
            endpoint = f"tcp/127.0.0.1:{free_port()}"
            ready, stop = threading.Event(), threading.Event()
            thread = threading.Thread(target=serve_emitter, args=(endpoint, ready, stop, secret), daemon=True)
            thread.start()
            ready.wait(10)
            fleets = []

            def remote():
                fleets.append(RemoteSkills(BusSettings((endpoint,), authenticate=secret is not None)))
                return fleets[-1]

            try:
                keep(name, *measure(remote, events, pings))
            finally:
                stop.set()
                for fleet in fleets:
                    fleet.close()
                thread.join(10)
    emit({"bench": "bus-events", "events": events, "rounds": rounds,
          **{f"{name}_per_s": round(rate) for name, rate in rates.items()},
          "auth_cost": round(rates["zenoh_unauthenticated"] / rates["zenoh"], 3)})
    for name, times in latencies.items():
        times.sort()
        emit({"bench": "bus-latency", "transport": name, "round_trips": len(times),
              "median_us": round(statistics.median(times), 1), "p99_us": round(times[int(0.99 * (len(times) - 1))], 1)})


def run_deliver(bus, trace_path: Path) -> tuple[float, float, bool]:
    """deliver.rap once (``bus``: a BusSettings, or None in one process); (wall seconds, simulated seconds, ok)."""
    from atlas_rap.layers import MissionEngine, RunOptions
    from atlas_rap.sequencer import JsonlSink, Trace

    trace = Trace()
    sink = JsonlSink(trace_path)
    trace.add_sink(sink)
    engine = MissionEngine(RunOptions(bus=bus), trace=trace)
    engine.load_file(MISSION, require_post=True)
    start = time.perf_counter()
    result = engine.run_mission(600)
    wall = time.perf_counter() - start
    sink.close()
    if engine.remote is not None:
        engine.remote.close()
    return wall, result.time, result.ok


UNAUTHENTICATED_HOST = """
import sys
from atlas_rap.layers.skill_host import SkillHostServer
server = SkillHostServer("lab-corridor-office", secret=None, listen=[sys.argv[1]])
print("skill host without authentication", flush=True)
server.serve()
"""


def bus_deliver(runs: int, out: Path) -> None:
    from atlas_rap.skillbus.remote import BusSettings

    secure, plain = f"tcp/127.0.0.1:{free_port()}", f"tcp/127.0.0.1:{free_port()}"
    hosts = [subprocess.Popen([sys.executable, "-m", "atlas_rap", "skills", "serve", "--listen", secure],
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=HERE.parent),
             subprocess.Popen([sys.executable, "-c", UNAUTHENTICATED_HOST, plain],
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=HERE.parent)]
    try:
        for host in hosts:
            host.stdout.readline()  # "skill host ...": listening
        ways = {"in_process": None, "zenoh": BusSettings((secure,)),
                "zenoh_unauthenticated": BusSettings((plain,), authenticate=False)}
        speeds: dict[str, list[float]] = {name: [] for name in ways}
        for i in range(runs):  # interleaved, so that the machine's moods fall on every way alike
            for name, bus in ways.items():
                wall, sim, ok = run_deliver(bus, out / f"{name}.jsonl")
                assert ok, f"deliver.rap failed {name}"
                speeds[name].append(sim / wall)
        best = {name: max(values) for name, values in speeds.items()}
        traces = {(out / f"{name}.jsonl").read_bytes() for name in ways}
        emit({"bench": "bus-deliver", "mission": "deliver.rap", "runs": runs,
              **{f"{name}_sim_s_per_wall_s": round(speed, 1) for name, speed in best.items()},
              "ratio": round(best["zenoh"] / best["in_process"], 3), "target_ratio": 0.5,
              "auth_cost": round(best["zenoh_unauthenticated"] / best["zenoh"], 3), "target_auth_cost": 1.1,
              "same_trace": len(traces) == 1})
    finally:
        for host in hosts:
            host.kill()
            host.wait(10)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer events and runs, to try it out")
    parser.add_argument("--runs", type=int, default=5, help="runs of deliver.rap each way (best kept)")
    args = parser.parse_args()
    try:
        import zenoh  # noqa: F401
    except ImportError:
        emit({"bench": "bus", "skipped": "eclipse-zenoh is not installed: pip install 'atlas-rap[zenoh]'"})
        return
    import tempfile

    bus_protocol(2000 if args.quick else 20000, 200 if args.quick else 2000, 2 if args.quick else args.runs)
    with tempfile.TemporaryDirectory() as folder:
        bus_deliver(2 if args.quick else args.runs, Path(folder))
        try:
            import foxglove  # noqa: F401
        except ImportError:
            emit({"bench": "record", "skipped": "foxglove-sdk is not installed: pip install 'atlas-rap[foxglove]'"})
        else:
            from bench_record import bench as bench_record

            bench_record("record", 3 if args.quick else args.runs, True, Path(folder))


if __name__ == "__main__":
    main()
