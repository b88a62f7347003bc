"""The robot's pose belief where people look at a run (issue 27, "Visible"): ``atlas run --render`` draws
the believed path beside the true one and the last estimate's 2-sigma ellipse; ``--record`` writes the
estimate, its covariance, the particle cloud and the believed path on channels of their own; a run
whose odometry is exact draws and records exactly what it did before beliefs existed.

The runs are ``deliver.rap`` in-process on ``lab-corridor-office``, once with its odometry drifting
5 % and once on the noiseless copy the golden traces use. The recordings are read back with
``views.mcap_reader`` and set against the true pose they recorded (``/robot/pose``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from matplotlib.image import imread
from scipy.ndimage import binary_dilation
from skimage.draw import line as draw_line

from cli_process import REPO
from localisation_runs import drifting_world
from atlas_rap.layers import MissionEngine, RunOptions
from atlas_rap.sequencer import Trace
from atlas_rap.skills.beliefs import POSE_ESTIMATE, POSE_TRACK
from atlas_rap.views.pose_error import covariance_ellipse
from atlas_rap.views.run_picture import RunPicture
from atlas_rap.views.world_render import render_run

pytest.importorskip("foxglove")
pytest.importorskip("mcap")

from atlas_rap.views import foxglove_messages  # noqa: E402
from atlas_rap.views.mcap_picture import render_recording  # noqa: E402
from atlas_rap.views.mcap_reader import read_recording  # noqa: E402
from atlas_rap.views.recording import (ESTIMATE_TOPICS, MAX_PARTICLES, PARTICLES_PERIOD, TOPICS,  # noqa: E402
                                       RunRecorder)

DELIVER = REPO / "rap_library" / "missions" / "deliver.rap"
NOISELESS = REPO / "tests" / "golden" / "lab-corridor-office-noiseless.yaml"
BELIEF_RGB = (0xD6 / 255, 0x12 / 255, 0x7A / 255)  # the believed path's magenta (views.world_render._BELIEF)


@dataclass
class Run:
    engine: MissionEngine
    picture: RunPicture
    png: Path
    mcap: Path


def run_deliver(world: Path, folder: Path) -> Run:
    """deliver.rap in ``world``, drawn (``run.png``) and recorded (``run.mcap``) as ``atlas run`` does."""
    engine = MissionEngine(RunOptions(world=str(world), seed=0), trace=Trace(keep=True))
    picture = RunPicture(engine)
    recorder = RunRecorder(engine, path=folder / "run.mcap")
    try:
        engine.load_file(DELIVER, require_post=True)
        result = engine.run_mission(300.0, pace=recorder.pace)
    finally:
        recorder.close()
    assert result.ok, f"ended by {result.ended_by} at {result.time}"
    picture.render(str(folder / "run.png"), "deliver.rap")
    return Run(engine, picture, folder / "run.png", folder / "run.mcap")


@pytest.fixture(scope="module")
def drifting(tmp_path_factory) -> Run:
    folder = tmp_path_factory.mktemp("drifting")
    return run_deliver(Path(drifting_world(folder, 0.05)), folder)


@pytest.fixture(scope="module")
def exact(tmp_path_factory) -> Run:
    return run_deliver(NOISELESS, tmp_path_factory.mktemp("exact"))


def belief_pixels(png: Path, tolerance: float = 0.12) -> np.ndarray:
    """Where a picture is the believed path's magenta."""
    rgb = imread(png)[..., :3]
    return (np.abs(rgb - np.asarray(BELIEF_RGB)) < tolerance).all(axis=2)


def true_pose_at(recording, t: float) -> tuple[float, float]:
    """The recorded true pose (``/robot/pose``) at ``t``, between the two samples round it."""
    times, xs, ys = [], [], []
    for when, message in recording.messages("/robot/pose"):
        times.append(when)
        xs.append(message["pose"]["position"].get("x", 0.0))
        ys.append(message["pose"]["position"].get("y", 0.0))
    return float(np.interp(t, times, xs)), float(np.interp(t, times, ys))


def position(pose: dict) -> tuple[float, float]:
    return pose["position"].get("x", 0.0), pose["position"].get("y", 0.0)


# -- the recording ----------------------------------------------------------------------------------


def test_a_drifting_run_records_its_belief_on_channels_of_their_own(drifting):
    recording = read_recording(drifting.mcap)
    channels = recording.channels()
    for topic in ESTIMATE_TOPICS:
        assert topic in channels, f"{topic} has no message: {sorted(channels)}"
        assert channels[topic][0] == TOPICS[topic][0]
        times = recording.times(topic)
        assert times == sorted(times), f"{topic} is not in time order"
    updates = channels["/robot/estimate"][1]
    assert updates > 100  # the filter updates as the robot moves
    assert channels["/robot/estimate/covariance"][1] == channels["/robot/estimate/ellipse"][1] == updates
    assert recording.times("/robot/estimate") == recording.times("/robot/estimate/covariance")
    # the estimate is stamped when the filter made it
    for t, message in recording.messages("/robot/estimate"):
        stamp = message["timestamp"]
        assert stamp.get("seconds", 0) + stamp.get("nanos", 0) / 1e9 == pytest.approx(t, abs=1e-9)
        assert message["frame_id"] == "map"


def test_the_recorded_estimates_are_near_the_recorded_true_pose(drifting):
    recording = read_recording(drifting.mcap)
    errors = [math.dist(position(message["pose"]), true_pose_at(recording, t))
              for t, message in recording.messages("/robot/estimate")]
    assert max(errors) < 0.5, f"worst {max(errors):.2f} m"
    assert math.sqrt(np.mean(np.square(errors))) < 0.2
    # the particle cloud: thin, not too often, and round the true pose
    times = recording.times("/robot/particles")
    assert len(times) > 20 and min(np.diff(times)) >= PARTICLES_PERIOD - 1e-9
    for t, cloud in recording.messages("/robot/particles"):
        poses = cloud["poses"]
        assert 0 < len(poses) <= MAX_PARTICLES
        centre = np.mean([position(p) for p in poses], axis=0)
        assert math.dist(centre, true_pose_at(recording, t)) < 0.6, t
    # the believed path ends where the localiser's track ends, and wanders from the true path
    believed = [position(p) for p in recording.last("/robot/estimated_path")["poses"]]
    track = drifting.engine.manager.context.beliefs[POSE_TRACK]
    assert len(believed) > 100
    assert math.dist(believed[-1], track[-1][1:3]) < 0.03
    true_path = [position(p) for p in recording.last("/robot/path")["poses"]]
    assert believed != true_path


def test_the_covariance_and_its_ellipse_say_the_same(drifting):
    recording = read_recording(drifting.mcap)
    numbers = recording.last("/robot/estimate/covariance")
    covariance = np.asarray(numbers["covariance"]).reshape(3, 3)
    assert np.allclose(covariance, covariance.T)
    assert numbers["sigma_x"] == pytest.approx(math.sqrt(covariance[0, 0]))
    assert numbers["localised"] is True and numbers["particles"] > 0
    final = drifting.engine.manager.context.beliefs[POSE_ESTIMATE]
    assert np.allclose(covariance, final.covariance)
    (disc,) = recording.last("/robot/estimate/ellipse")["entities"][0]["cylinders"]
    width, height, _ = covariance_ellipse(covariance, sigmas=2.0)
    assert (disc["size"]["x"], disc["size"]["y"]) == (pytest.approx(width), pytest.approx(height))
    assert position(disc["pose"]) == (pytest.approx(numbers["x"]), pytest.approx(numbers["y"]))


def test_a_run_with_exact_odometry_records_no_belief(exact):
    assert exact.engine.manager.context.beliefs.get(POSE_TRACK) is None
    channels = read_recording(exact.mcap).channels()
    assert "/robot/pose" in channels
    assert not set(ESTIMATE_TOPICS) & set(channels)


# -- the pictures -----------------------------------------------------------------------------------


def test_the_picture_of_a_drifting_run_differs_only_where_the_belief_is_drawn(drifting, tmp_path):
    beliefs = drifting.engine.manager.context.beliefs
    track, estimate = beliefs.pop(POSE_TRACK), beliefs.pop(POSE_ESTIMATE)
    try:
        drifting.picture.render(str(tmp_path / "no-belief.png"), "deliver.rap")
    finally:
        beliefs[POSE_TRACK], beliefs[POSE_ESTIMATE] = track, estimate
    with_belief, without = imread(drifting.png)[..., :3], imread(tmp_path / "no-belief.png")[..., :3]
    assert belief_pixels(drifting.png).sum() > 500, "the believed path is not drawn"
    assert not belief_pixels(tmp_path / "no-belief.png").any()

    # Metres to pixels, from the walls of the picture without the belief: the longest rows of wall are the
    # walls at y = 10, 6 and 4 m, the longest columns those at x = 0, 8 and 20 m.
    h, w = min(with_belief.shape[0], without.shape[0]), min(with_belief.shape[1], without.shape[1])
    wall = (np.abs(without[:h, :w] - 0x2B / 255) < 0.03).all(axis=2)  # views.world_render's wall colour
    rows = np.nonzero(wall.sum(axis=1) > 0.5 * wall.sum(axis=1).max())[0]
    cols = np.nonzero(wall.sum(axis=0) > 0.5 * wall.sum(axis=0).max())[0]
    px_per_m = (cols.max() - cols.min()) / 20.0
    assert abs((rows.max() - rows.min()) / px_per_m - 6.0) < 0.1  # equal aspect: y = 10 m down to 4 m

    def pixel(x: float, y: float) -> tuple[int, int]:
        return round(rows.min() + (10.0 - y) * px_per_m), round(cols.min() + x * px_per_m)

    # where the belief is drawn: the believed path, and the last estimate's ellipse round its pose
    drawn = np.zeros((h, w), dtype=bool)
    for (_, xa, ya, _), (_, xb, yb, _) in zip(track, track[1:]):
        line_rows, line_cols = draw_line(*pixel(xa, ya), *pixel(xb, yb))
        drawn[line_rows, line_cols] = True
    row, col = pixel(*estimate.pose[:2])
    reach = math.ceil(max(covariance_ellipse(estimate.covariance)[:2]) / 2 * px_per_m) + 8  # and its legend cross
    drawn[row - reach:row + reach + 1, col - reach:col + reach + 1] = True
    drawn = binary_dilation(drawn, iterations=4)  # the line's width, dashes' caps and antialiasing

    changed = np.abs(with_belief[:h, :w] - without[:h, :w]).sum(axis=2) > 0.05
    inside = np.zeros_like(changed)  # the world's bounds, 0..20 x 0..10 m (the legend beside it gains rows)
    (top, left), (bottom, right) = pixel(0.0, 10.0), pixel(20.0, 0.0)
    inside[top:bottom + 1, left:right + 1] = True
    stray = changed & inside & ~drawn
    assert (changed & inside).sum() > 500
    assert stray.sum() == 0, f"{stray.sum()} pixels changed away from the believed path, e.g. (row, column) " \
                             f"{np.argwhere(stray)[:5].tolist()}"


def test_a_run_with_exact_odometry_draws_the_picture_it_always_did(exact, tmp_path):
    """No belief: the picture is render_run's with the arguments it took before beliefs existed."""
    engine, picture = exact.engine, exact.picture
    sim = engine.simulation
    before = render_run(engine.world, tmp_path / "before.png", path=sim.path, doors_open=sim.doors_open,
                        obstacles=sim.obstacles(), task_marks=picture.marks(), title=f"deliver.rap, seed {engine.seed}",
                        plan_events=picture.plan_events, objects=picture.objects())
    assert exact.png.read_bytes() == before.read_bytes()
    assert not belief_pixels(exact.png).any()


def test_the_picture_of_a_recording_draws_the_believed_path(drifting, exact, tmp_path):
    assert belief_pixels(render_recording(drifting.mcap, tmp_path / "drifting.png")).sum() > 500
    assert not belief_pixels(render_recording(exact.mcap, tmp_path / "exact.png")).any()


# -- the pieces -------------------------------------------------------------------------------------


def test_the_ellipse_of_a_covariance_lies_along_its_larger_axis():
    turn = math.radians(30.0)
    rotation = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
    block = rotation @ np.diag([0.09, 0.01]) @ rotation.T
    covariance = np.zeros((3, 3))
    covariance[:2, :2], covariance[2, 2] = block, 0.2
    width, height, angle = covariance_ellipse(covariance, sigmas=2.0)
    assert (width, height, angle) == (pytest.approx(1.2), pytest.approx(0.4), pytest.approx(30.0))
    assert covariance_ellipse(np.diag([0.01, 0.04, 1.0]), sigmas=1.0) == (pytest.approx(0.4), pytest.approx(0.2),
                                                                        pytest.approx(90.0))


def test_a_big_particle_cloud_is_thinned_to_every_kth_particle():
    from foxglove.messages import PosesInFrame

    from atlas_rap.views.mcap_reader import ProtobufSchemas

    schema = PosesInFrame.get_schema()

    def poses(message) -> list[dict]:
        return ProtobufSchemas(schema.data).decode(schema.name, message.encode())["poses"]

    cloud = np.column_stack([np.arange(1200.0), np.ones(1200), np.full(1200, math.pi / 2)])
    thinned = poses(foxglove_messages.particles(3.0, cloud, limit=500))
    assert len(thinned) == 400  # every 3rd
    assert [p["position"].get("x", 0.0) for p in thinned[:3]] == [0.0, 3.0, 6.0]
    assert thinned[1]["orientation"]["z"] == pytest.approx(math.sin(math.pi / 4))
    assert len(poses(foxglove_messages.particles(3.0, cloud[:120]))) == 120
