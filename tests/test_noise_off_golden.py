"""With its odometry noise off, a world runs exactly as it did before odometry noise and localisation
(issue 27): `atlas run` of deliver.rap on lab-corridor-office with `odometry_drift: 0.0` writes, byte
for byte, the traces tests/golden/ kept from then, with the prior map and without it. (Written again
when the shipped rules stopped capping the speed while Layer IV maps, issue 28: without the prior map
the robot drives at top speed, and the first trace no longer asserts the cap; and again when the
rules named the survey's spacing and the map quality became the survey's: both traces assert the
two settings, and without the prior map Layer IV maps the whole errand, its survey short of 0.9.)"""

from __future__ import annotations

import difflib

import pytest
from cli_process import REPO, assert_no_traceback, atlas

GOLDEN = REPO / "tests" / "golden"
DELIVER = REPO / "rap_library" / "missions" / "deliver.rap"
WORLD = GOLDEN / "lab-corridor-office-noiseless.yaml"


def first_difference(got: str, want: str) -> str:
    """The first differing lines of two traces, for the failure message."""
    diff = difflib.unified_diff(want.splitlines(), got.splitlines(), "golden", "this run", n=1, lineterm="")
    return "\n".join(list(diff)[:12])


@pytest.mark.parametrize("flags, golden", [((), "deliver-noiseless.jsonl"),
                                           (("--no-prior-map",), "deliver-noiseless-no-prior-map.jsonl")],
                         ids=["prior-map", "no-prior-map"])
def test_deliver_with_the_noise_off_writes_the_golden_trace_byte_for_byte(tmp_path, flags, golden):
    trace = tmp_path / "trace.jsonl"
    done = atlas("run", str(DELIVER), "--world", str(WORLD), "--quiet", *flags, "--trace", str(trace), cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stdout + done.stderr
    got, want = trace.read_bytes(), (GOLDEN / golden).read_bytes()
    assert got == want, first_difference(got.decode("utf-8"), want.decode("utf-8"))


def test_the_golden_world_says_odometry_drift_0_which_means_noise_off():
    from atlas_rap.sim.world import load_world

    assert "odometry_drift: 0.0" in WORLD.read_text(encoding="utf-8")
    assert load_world(WORLD).robot.odometry_noise.off
