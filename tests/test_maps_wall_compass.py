"""The wall compass (``atlas_rap.maps.wall_compass``): a building's wall directions learnt from the local
scans of the real simulated sonar, and the heading held to them. The corridor here runs at 25 degrees, so
nothing about the map's axes is assumed; the true pose is the simulator's, read by the test only."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from atlas_rap.maps.scan_matching import Echoes, MapMatcher
from atlas_rap.maps.wall_compass import CompassSettings, WallCompass, sharpness
from atlas_rap.sim.physics import Simulation
from atlas_rap.sim.world import load_world

SLANT = math.radians(25.0)


def _corridor(folder: Path) -> str:
    """A corridor 16 m long and 2 m wide along SLANT, its robot at the west end facing along it, with
    exact odometry: a world file's path."""
    c, s = math.cos(SLANT), math.sin(SLANT)

    def point(x: float, y: float) -> str:
        return f"[{c * x - s * y + 2:.4f}, {s * x + c * y + 2:.4f}]"

    corners = ", ".join(point(x, y) for x, y in [(0, -1), (16, -1), (16, 1), (0, 1)])
    start = point(1, 0)[1:-1]
    path = folder / "slanted.yaml"
    path.write_text(f"name: slanted\npolygons: [[{corners}]]\nplaces:\n  west: {{point: {point(1, 0)}}}\n"
                    f"robot: {{start: [{start}, 25], odometry_noise: off}}\n", encoding="utf-8")
    return str(path)


def _scans(world_file: str, metres: float, seed: int = 0) -> list[tuple[Echoes, float]]:
    """Drive ``metres`` along the corridor, weaving gently: each local scan the matcher would take, with the
    robot's true heading when it was taken."""
    world = load_world(world_file)
    sim = Simulation(world, seed=seed, dt=0.01)
    matcher = MapMatcher(np.asarray(sim.sonar_angles), world.robot.radius, world.sonar.max_range,
                         world.sonar.beam_width, world.sonar.rays_per_beam)
    scans, step = [], 0
    while math.dist(sim.pose[:2], world.robot.start[:2]) < metres:
        sim.command(0.4, 0.15 * math.sin(step * 0.01))
        sim.step()
        step += 1
        if step % 10 == 0:  # the sonar's 10 Hz
            matcher.add_ring(sim.odometry, sim.sonar())
            if matcher.due(sim.odometry):
                matcher.correct(sim.odometry, sim.odometry, step * 0.01)  # no grid kept: only the scan is taken
                if matcher.scan is not None and len(matcher.scan.ranges):
                    scans.append((matcher.scan, sim.pose[2]))
    return scans


@pytest.fixture(scope="module")
def corridor_scans(tmp_path_factory):
    return _scans(_corridor(tmp_path_factory.mktemp("compass")), metres=9.0)


def test_the_corridors_direction_is_learnt_from_the_scans_at_the_true_heading(corridor_scans):
    compass = WallCompass()
    for echoes, heading in corridor_scans[:15]:
        compass.correction(echoes, heading)
    learnt = compass.directions()
    assert learnt, compass.votes
    nearest = min(abs(math.remainder(d - SLANT, math.pi)) for d in learnt)
    assert nearest < math.radians(1.0), [math.degrees(d) for d in learnt]


def test_a_heading_that_is_off_is_turned_back_by_a_share_of_the_error_and_a_true_one_is_left_alone(corridor_scans):
    compass = WallCompass()
    for echoes, heading in corridor_scans[:15]:
        compass.correction(echoes, heading)
    gain = compass.settings.gain
    for error in (math.radians(3.0), math.radians(-4.0)):
        turns = [compass.correction(echoes, heading + error) for echoes, heading in corridor_scans[15:30]]
        made = [t for t in turns if t is not None]
        assert len(made) >= 10, turns
        assert float(np.median(made)) == pytest.approx(-gain * error, abs=math.radians(0.5)), \
            [round(math.degrees(t), 2) for t in made]
    exact = [compass.correction(echoes, heading) for echoes, heading in corridor_scans[15:30]]
    assert max(abs(t) for t in exact if t is not None) <= math.radians(1.0), exact


def test_a_heading_beyond_the_tolerance_is_not_turned(corridor_scans):
    compass = WallCompass()
    for echoes, heading in corridor_scans[:15]:
        compass.correction(echoes, heading)
    far = compass.settings.tolerance + math.radians(4.0)
    assert all(compass.correction(echoes, heading + far) is None for echoes, heading in corridor_scans[15:25])


def test_a_learnt_direction_stays_put_while_a_drifting_heading_votes(corridor_scans):
    compass = WallCompass()
    for echoes, heading in corridor_scans[:15]:
        compass.correction(echoes, heading)
    before = compass.directions()
    for i, (echoes, heading) in enumerate(corridor_scans[15:]):
        compass.correction(echoes, heading + math.radians(0.3) * i)  # a heading drifting away, scan by scan
    assert compass.directions()[: len(before)] == before


def test_a_wall_seen_at_a_slant_lines_up_along_its_own_direction_not_its_beams():
    # one sonar drawing near a wall along x at y = 1, its beam's axis 22.5 degrees off the wall's normal, so
    # the nearest echo in its 15-degree cone comes along the cone's edge, 15 degrees off the normal; placed
    # on the beam's axis instead (a cone of no width) the echoes would tilt the wall's line
    xs = np.linspace(0.0, 1.5, 16)
    distance = 1.0 - 0.5 * xs
    origins = np.stack([xs, 1.0 - distance], axis=1)
    bearings = np.full(len(xs), math.pi / 2 + math.radians(22.5))
    ranges = distance / math.cos(math.radians(15.0))
    directions = np.radians(np.arange(-10.0, 10.01, 0.25))
    cone = sharpness(Echoes(origins, bearings, ranges, math.radians(7.5)), directions, offset_bin=0.005)
    axis = sharpness(Echoes(origins, bearings, ranges, 0.0), directions, offset_bin=0.005)
    assert math.degrees(directions[int(np.argmax(cone[0]))]) == pytest.approx(0.0, abs=0.25)
    assert cone[1].max() == len(xs)
    assert abs(math.degrees(directions[int(np.argmax(axis[0]))])) >= 1.0


def test_too_few_echoes_neither_vote_nor_turn():
    compass = WallCompass(CompassSettings(min_support=12))
    few = Echoes(np.zeros((5, 2)), np.zeros(5), np.ones(5), math.radians(7.5))
    assert compass.correction(few, 0.0) is None
    assert compass.votes.sum() == 0
