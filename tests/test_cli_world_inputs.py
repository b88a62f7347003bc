"""Worlds and maps given where they do not belong, as a user meets them: located errors with a way out.

`atlas map abstract` / `render` given a world file point to its map (or say how
to build one); a world whose robot starts off the free space of its map is
refused at `robot.start`; an unknown world name or a missing world file is a
short error. Always exit 1, never a traceback.
"""

from __future__ import annotations

import re

from cli_process import REPO, assert_no_traceback, atlas

SMALL_OFFICE = REPO / "worlds" / "small-office-map.yaml"


def refused(done) -> str:
    """stderr of a run that must fail on bad input: exit 1, no traceback."""
    assert done.returncode == 1, (done.returncode, done.stdout, done.stderr)
    assert_no_traceback(done)
    return done.stderr


def test_abstract_of_a_map_world_points_to_its_map_and_that_map_abstracts(tmp_path):
    done = atlas("map", "abstract", "worlds/small-office-map.yaml", "--out", str(tmp_path / "levels"), cwd=REPO)
    stderr = refused(done)
    assert stderr.startswith("worlds/small-office-map.yaml:22:1: error: this is a world file, not a ROS map YAML; "
                             "the map it names is 'maps/small-office-map.yaml'")
    assert "    map: maps/small-office-map.yaml\n    ^\n" in stderr
    assert "hint: give that map instead: worlds/maps/small-office-map.yaml" in stderr
    assert "wrote" not in done.stdout
    map_yaml = re.search(r"give that map instead: (\S+)", stderr).group(1)
    done = atlas("map", "abstract", map_yaml, "--out", str(tmp_path / "levels"), cwd=REPO)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "levels" / "topology.json").is_file()


def test_render_of_a_world_without_a_map_image_says_how_to_build_one(tmp_path):
    done = atlas("map", "render", str(REPO / "worlds" / "maze.yaml"), "--out", "maze.png", cwd=tmp_path)
    stderr = refused(done)
    assert "maze.yaml:27:1: error: this is a world file, not a ROS map YAML, and it names no map image" in stderr
    assert f"`atlas map build --world {REPO / 'worlds' / 'maze.yaml'} --out maze-map`" in stderr
    assert "then give maze-map/occupancy.yaml" in stderr
    assert stderr.count("error:") == 1
    assert "wrote" not in done.stdout


def test_abstract_of_a_yaml_that_is_neither_says_which_keys_a_map_needs(tmp_path):
    (tmp_path / "plan.yaml").write_text("rooms: [lab, office]\nscale: 0.05\n", encoding="utf-8")
    stderr = refused(atlas("map", "abstract", "plan.yaml", "--out", "levels", cwd=tmp_path))
    assert stderr.startswith("plan.yaml:1:1: error: this is not a ROS map_server map YAML: "
                             "it has none of a map's keys (it has rooms, scale)")
    assert "hint: a map YAML has image:" in stderr and "origin: [x, y, yaw]" in stderr
    assert stderr.count("error:") == 1


def world_starting_at(tmp_path, start: str):
    """The shipped small-office-map world, copied with another robot.start (its map by absolute path)."""
    text = SMALL_OFFICE.read_text(encoding="utf-8")
    text = text.replace("  start: [1.5, 1.5, 0]\n", f"  start: {start}\n")
    text = text.replace("map: maps/small-office-map.yaml", f"map: {REPO / 'worlds' / 'maps' / 'small-office-map.yaml'}")
    path = tmp_path / "office.yaml"
    path.write_text(text, encoding="utf-8")
    line = next(i for i, row in enumerate(text.split("\n"), 1) if row.strip().startswith("start:"))
    return path, line


def test_run_in_a_world_whose_robot_starts_in_the_unknown_is_refused_at_robot_start(tmp_path):
    path, line = world_starting_at(tmp_path, "[-0.3, 4, 0]")
    go_to(tmp_path, "hall-west")
    stderr = refused(atlas("run", "go.rap", "--world", "office.yaml", "-q", cwd=tmp_path))
    assert stderr.startswith(f"office.yaml:{line}:10: error: robot.start (-0.3, 4) is on an unknown cell of the map")
    assert "      start: [-0.3, 4, 0]\n             ^\n" in stderr
    hint = re.search(r"hint: move robot.start into free space; the nearest free cell with room for the robot "
                     r"is at \((-?[\d.]+), (-?[\d.]+)\)", stderr)
    assert hint, stderr
    world_starting_at(tmp_path, f"[{hint.group(1)}, {hint.group(2)}, 0]")  # as the hint says
    done = atlas("run", "go.rap", "--world", "office.yaml", "-q", "--until", "60", cwd=tmp_path)
    assert done.returncode == 0, done.stderr  # the world loads, and the robot is in hall-west already


def go_to(tmp_path, place: str) -> None:
    """go.rap: a mission that sends the robot to ``place`` with the shipped navigation RAPs."""
    (tmp_path / "go.rap").write_text(f'(include "{REPO / "rap_library" / "navigation.rap"}")\n'
                                     f"(post (go-to {place}))\n", encoding="utf-8")


def test_an_unknown_world_name_or_a_missing_world_file_is_a_short_error(tmp_path):
    go_to(tmp_path, "lab")
    stderr = refused(atlas("run", "go.rap", "--world", "mazee", cwd=tmp_path))
    assert stderr.startswith("no shipped world named 'mazee'; did you mean 'maze'?\n")
    assert "small-office-map" in stderr and len(stderr.splitlines()) <= 4
    stderr = refused(atlas("run", "go.rap", "--world", "nowhere.yaml", cwd=tmp_path))
    assert stderr == "nowhere.yaml:1:1: error: no such file\n  hint: check the path\n"
