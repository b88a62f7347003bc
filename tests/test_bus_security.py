"""The skill bus admits only its own sequencer, as a user and a stranger meet it: `atlas skills
serve`, `atlas run --connect` and a stranger that uses only eclipse-zenoh (bus_attacker.py), all
real processes on loopback, each test on ports of its own.

Every wait is on a condition with a deadline (a line of output, a process ending)."""

from __future__ import annotations

import json
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest
from bus_processes import DELIVER, RUNTIME, Running, attacker, free_port, processes  # noqa: F401  (a fixture)
from cli_process import ENV, REPO, assert_no_traceback, atlas

zenoh = pytest.importorskip("zenoh")

TLS_EXAMPLE = REPO / "examples" / "bus-tls"


def host(processes, tmp_path: Path, port: int, *args: str, robot: str = "robot", listen: str = "tcp/127.0.0.1",
         env: dict | None = None) -> Running:
    running = Running("skills", "serve", "--listen", f"{listen}:{port}", "--robot", robot, *args, cwd=tmp_path,
                      env=env)
    processes.append(running)
    running.wait_for(f"skill host for robot {robot}")
    running.wait_for("token: ")
    return running


def deliver(processes, tmp_path: Path, port: int, trace: str, *args: str, env: dict | None = None) -> Running:
    running = Running("run", DELIVER, "--quiet", "--trace", trace, "--connect", f"tcp/127.0.0.1:{port}", *args,
                      cwd=tmp_path, env=env)
    processes.append(running)
    return running


def host_and_stranger(processes, tmp_path: Path, mode: str, *args: str) -> tuple[Running, Running, int, list[str]]:
    """A host, and a stranger on the bus beside it (connected to the host, listening for the
    sequencer): the host, the stranger, the host's port, and the options that connect a
    sequencer to both."""
    port, mine = free_port(), free_port()
    served = host(processes, tmp_path, port)
    stranger = attacker(processes, tmp_path, mode, *args, "--connect", f"tcp/127.0.0.1:{port}",
                        "--listen", f"tcp/127.0.0.1:{mine}")
    return served, stranger, port, ["--connect", f"tcp/127.0.0.1:{mine}"]


@pytest.fixture(scope="module")
def clean_trace(tmp_path_factory) -> bytes:
    """deliver.rap's trace in one process: what every run over the bus must give, byte for byte."""
    where = tmp_path_factory.mktemp("clean")
    done = atlas("run", DELIVER, "--quiet", "--trace", "clean.jsonl", cwd=where)
    assert done.returncode == 0, done.stderr
    return (where / "clean.jsonl").read_bytes()


def test_the_host_makes_a_token_file_only_its_user_can_read_and_keeps_it_across_restarts(processes, tmp_path):
    port = free_port()
    first = host(processes, tmp_path, port, robot="tokenbot")
    token = Path(RUNTIME) / "bus-tokenbot.token"
    assert f"token: {token}" in first.output
    assert stat.S_IMODE(token.stat().st_mode) == 0o600
    data = json.loads(token.read_text())
    assert data["robot"] == "tokenbot" and len(bytes.fromhex(data["key"])) == 32
    first.kill()
    host(processes, tmp_path, port, robot="tokenbot")
    assert json.loads(token.read_text()) == data  # a restarted host serves the same sequencers


def test_two_robots_hosts_on_one_machine_have_token_files_of_their_own(processes, tmp_path):
    host(processes, tmp_path, free_port(), robot="ada")
    host(processes, tmp_path, free_port(), robot="bea")
    ada = json.loads((Path(RUNTIME) / "bus-ada.token").read_text())
    bea = json.loads((Path(RUNTIME) / "bus-bea.token").read_text())
    assert (ada["robot"], bea["robot"]) == ("ada", "bea") and ada["key"] != bea["key"]


def test_a_sequencer_without_the_hosts_token_is_refused_with_a_clear_message(processes, tmp_path, clean_trace):
    port = free_port()
    served = host(processes, tmp_path, port)
    wrong = deliver(processes, tmp_path, port, "wrong.jsonl", env={"ATLAS_BUS_TOKEN": "not-the-hosts-secret-at-all"})
    assert wrong.finish() == 1
    assert "refused: this sequencer's token is not the skill host's" in wrong.output
    assert "Traceback" not in wrong.output
    served.wait_for("a Hello that fails authentication")
    assert "session 1 started" not in served.output  # the refused sequencer started nothing
    right = deliver(processes, tmp_path, port, "right.jsonl")
    assert right.finish() == 0, right.output
    assert (tmp_path / "right.jsonl").read_bytes() == clean_trace
    served.wait_for("session 1 started")


def test_a_token_file_given_by_hand_lets_a_sequencer_in(processes, tmp_path, clean_trace):
    port = free_port()
    host(processes, tmp_path, port, "--token-file", "keys/host.token")
    elsewhere = tmp_path / "elsewhere"  # a sequencer "on another machine": its own runtime folder
    elsewhere.mkdir()
    copied = shutil.copy(tmp_path / "keys" / "host.token", elsewhere / "copy.token")
    without = deliver(processes, tmp_path, port, "without.jsonl", env={"ATLAS_RUNTIME_DIR": str(elsewhere)})
    assert without.finish() == 1
    assert "no token for robot 'robot'" in without.output and "--token-file" in without.output
    run = deliver(processes, tmp_path, port, "with.jsonl", "--token-file", str(copied),
                  env={"ATLAS_RUNTIME_DIR": str(elsewhere)})
    assert run.finish() == 0, run.output
    assert (tmp_path / "with.jsonl").read_bytes() == clean_trace


def test_a_stranger_cannot_take_an_idle_host_nor_replay_an_earlier_run(processes, tmp_path, clean_trace):
    served, stranger, port, beside = host_and_stranger(processes, tmp_path, "squat")
    served.wait_for("a Hello that fails authentication")  # its forged Hello, refused
    first = deliver(processes, tmp_path, port, "first.jsonl", *beside)
    assert first.finish() == 0, first.output  # the squatter held nothing
    served.wait_for("session 1 the sequencer went away")
    stranger.say("replay")  # the whole first run again, as it was on the wire, tags and all
    stranger.wait_for("replayed")
    served.wait_for("a Hello seen before (a replay)")
    second = deliver(processes, tmp_path, port, "second.jsonl")
    assert second.finish() == 0, second.output
    served.wait_for("session 2 started")
    assert "session 3" not in served.output  # the replay started no session of its own
    assert (tmp_path / "first.jsonl").read_bytes() == clean_trace
    assert (tmp_path / "second.jsonl").read_bytes() == clean_trace
    stranger.close_input()
    assert stranger.finish() == 0
    assert served.proc.poll() is None


def test_a_replayed_hello_cannot_hold_a_host_that_has_restarted(processes, tmp_path, clean_trace):
    served, watcher, port, beside = host_and_stranger(processes, tmp_path, "squat", "--save", "wire.jsonl")
    first = deliver(processes, tmp_path, port, "first.jsonl", *beside)
    assert first.finish() == 0, first.output
    watcher.close_input()
    assert watcher.finish() == 0
    served.kill()
    again = host(processes, tmp_path, port)  # a new host process: it has seen no Hello yet
    replayer = attacker(processes, tmp_path, "replay", "--load", "wire.jsonl", "--connect", f"tcp/127.0.0.1:{port}")
    replayer.wait_for("replayed")
    again.wait_for("session 1 started")  # the replayed Hello holds (it is the real one) ...
    again.wait_for("fails authentication")  # ... but what followed it was tagged for another session
    second = deliver(processes, tmp_path, port, "second.jsonl")
    assert second.finish() == 0, second.output  # a real sequencer takes the host from the replay at once
    again.wait_for("took the host before this one's first frame")
    assert (tmp_path / "second.jsonl").read_bytes() == clean_trace


def test_garbage_replays_and_forgeries_during_a_run_change_nothing(processes, tmp_path, clean_trace):
    served, stranger, port, beside = host_and_stranger(processes, tmp_path, "flood", "--count", "1000")
    run = deliver(processes, tmp_path, port, "attacked.jsonl", *beside)
    assert run.finish(timeout=120) == 0, run.output
    stranger.close_input()
    assert stranger.finish(timeout=120) == 0
    sent = int(stranger.output.split("sent ")[-1].split()[0])
    assert sent >= 1000
    assert (tmp_path / "attacked.jsonl").read_bytes() == clean_trace
    assert "Traceback" not in run.output + served.output
    dropped = int(run.output.split(" messages dropped in all")[0].split()[-1])
    assert dropped >= 100  # the run was under attack while it ran: it dropped that much and still
    assert "fails authentication" in run.output and "fails authentication" in served.output
    assert served.proc.poll() is None  # the host lives on and serves the next run as before
    after = deliver(processes, tmp_path, port, "after.jsonl")
    assert after.finish() == 0, after.output
    assert (tmp_path / "after.jsonl").read_bytes() == clean_trace


SILENT = """
import sys, time
from atlas_rap.skillbus.protocol import END
from atlas_rap.skillbus.remote import BusSettings, RemoteSkills
fleet = RemoteSkills(BusSettings((sys.argv[1],)))
fleet._stop_beating.set()  # a sequencer that holds the secret, takes the host, then says nothing
fleet.links["robot"].tick_to((1, END))
print("in", flush=True)
time.sleep(600)
"""


def test_a_sequencer_that_falls_silent_loses_the_host_after_its_lease(processes, tmp_path, clean_trace):
    port = free_port()
    served = host(processes, tmp_path, port, "--lease", "2")
    silent = Running(cwd=tmp_path, command=[sys.executable, "-c", SILENT, f"tcp/127.0.0.1:{port}"])
    processes.append(silent)
    silent.wait_for("in")
    served.wait_for("session 1 started")
    served.wait_for("session 1 the sequencer sent nothing for 2 s (its lease ran out)", timeout=15)
    run = deliver(processes, tmp_path, port, "next.jsonl")
    assert run.finish() == 0, run.output
    assert (tmp_path / "next.jsonl").read_bytes() == clean_trace
    assert silent.proc.poll() is None  # it was alive all along: the lease, not liveliness, ended it


def test_mutual_tls_as_the_skill_bus_how_to_sets_it_up(processes, tmp_path, clean_trace):
    for name in ("make-certs.sh", "host.json5", "sequencer.json5"):
        shutil.copy(TLS_EXAMPLE / name, tmp_path / name)
    made = subprocess.run(["sh", "make-certs.sh"], cwd=tmp_path, capture_output=True, text=True, env=ENV)
    assert made.returncode == 0, made.stderr
    port = free_port()
    host(processes, tmp_path, port, "--zenoh-config", "host.json5", listen="tls/localhost")
    run = Running("run", DELIVER, "--quiet", "--trace", "tls.jsonl", "--connect", f"tls/localhost:{port}",
                  "--zenoh-config", "sequencer.json5", cwd=tmp_path)
    processes.append(run)
    assert run.finish() == 0, run.output
    assert (tmp_path / "tls.jsonl").read_bytes() == clean_trace
    # no client certificate: the host's TLS refuses the link, so no host is ever seen
    (tmp_path / "no-cert.json5").write_text('{transport: {link: {tls: {root_ca_certificate: "ca.pem"}}}}')
    refused = atlas("run", DELIVER, "--connect", f"tls/localhost:{port}", "--zenoh-config", "no-cert.json5",
                    cwd=tmp_path)
    assert refused.returncode == 1 and "no skill host for robot 'robot' answers" in refused.stderr
    # plain TCP to the TLS port: nothing either
    plain = atlas("run", DELIVER, "--connect", f"tcp/localhost:{port}", cwd=tmp_path)
    assert plain.returncode == 1 and "no skill host for robot 'robot' answers" in plain.stderr


@pytest.mark.parametrize("args, message", [
    (["--connect", "tls/localhost:7447"], "needs the certificate authority"),
    (["--connect", "tcp/127.0.0.1:1", "--zenoh-config", "missing.json5"], "does not exist"),
    (["--connect", "tcp/127.0.0.1:1", "--zenoh-config", "bad.json5"], "not a Zenoh configuration"),
    (["--zenoh-config", "bad.json5"], "--zenoh-config needs --connect"),
    (["--token-file", "bad.json5"], "--token-file needs --connect"),
    (["--connect", "tcp/127.0.0.1:1", "--token-file", "bad.json5"], "not a token file"),
    (["--connect", "tcp/127.0.0.1:1", "--max-message", "12"], "--max-message"),
    (["--host-grace", "5"], "--host-grace needs --connect"),
], ids=["tls without certificates", "missing config", "bad config", "config alone", "token alone",
        "not a token file", "tiny cap", "grace alone"])
def test_bad_bus_security_options_are_clear_errors(tmp_path, args, message):
    (tmp_path / "bad.json5").write_text("{ this is not: json5 ::: }")
    done = atlas("run", DELIVER, *args, cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode in (1, 2)
    assert message in done.stderr


def test_a_host_listening_beyond_this_machine_without_tls_warns(processes, tmp_path):
    exposed = host(processes, tmp_path, free_port(), listen="tcp/0.0.0.0")
    assert "without TLS: anyone on that network can read every frame" in exposed.output
    local = host(processes, tmp_path, free_port(), robot="quiet")
    assert "without TLS" not in local.output


@pytest.mark.parametrize("args, message", [
    (["--listen", "garbage"], "'garbage' is not a Zenoh endpoint"),
    (["--listen", "tls/127.0.0.1:1"], "listening on TLS needs the host's certificate and key"),
    (["--token-file", "/proc/x.token"], "token file /proc/x.token: cannot write it"),
    (["--token-file", "afile/x.token"], "afile is a file"),
    (["--lease", "0"], "--lease"),
], ids=["bad endpoint", "tls without certificates", "token in /proc", "token under a file", "no lease"])
def test_bad_host_options_are_clear_errors(tmp_path, args, message):
    (tmp_path / "afile").write_text("in the way")
    done = atlas("skills", "serve", *args, cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode in (1, 2)
    assert message in done.stderr
    assert "warning" not in done.stderr


def test_a_host_refuses_a_token_file_others_can_read(tmp_path):
    token = tmp_path / "open.token"
    token.write_text(json.dumps({"robot": "robot", "key": "ab" * 32, "signature_scheme": "hmac-sha256"}))
    token.chmod(0o644)
    done = atlas("skills", "serve", "--listen", f"tcp/127.0.0.1:{free_port()}", "--token-file", str(token),
                 cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 1
    assert "others can read it" in done.stderr and "chmod 600" in done.stderr
