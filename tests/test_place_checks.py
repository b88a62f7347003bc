"""A mission that names a place its world lacks is stopped before the run, with the caret under the
name and the world's places as the hint (atlas_rap.sequencer.place_checks): before, deliver.rap on
small-office-map drove and retried for 12 s, then failed with "there is no place named office"."""

from __future__ import annotations

from cli_process import REPO, assert_no_traceback, atlas

from atlas_rap.lang import load
from atlas_rap.sequencer.place_checks import place_positions, place_problems
from atlas_rap.skills.catalog import catalog, param_types

DELIVER = REPO / "rap_library" / "missions" / "deliver.rap"
TYPES = param_types(catalog())


def test_a_rap_parameter_is_a_place_when_it_reaches_navigate_to_s_place_through_the_task_nets():
    positions = place_positions(load(DELIVER), TYPES)
    assert positions[("navigate-to", 1)] == {0}
    assert positions[("go-to", 1)] == {0}  # navigation.rap: (navigate-to ?place)
    assert positions[("deliver", 3)] == {1, 2}  # (deliver ?thing ?to ?from): the thing is no place


def test_atlas_run_refuses_a_post_naming_places_the_world_lacks_with_a_caret_under_each(tmp_path):
    done = atlas("run", str(DELIVER), "--world", "small-office-map", "--quiet", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 1, done.stdout + done.stderr
    lines = done.stderr.splitlines()
    first = next(i for i, line in enumerate(lines) if "no place named office in world small-office-map" in line)
    assert lines[first].split(":")[1:3] == ["25", "21"], lines[first]  # (post (deliver mail office lab))
    assert lines[first + 1].strip() == "(post (deliver mail office lab))"
    assert lines[first + 2].index("^") == lines[first + 1].index("office")
    assert "hint: the places of small-office-map: hall-east, hall-west, meeting-room, room-a" in done.stderr
    assert "no place named lab in world small-office-map" in done.stderr
    assert "succeeded" not in done.stdout and "failed at" not in done.stdout  # nothing ran


def test_atlas_check_finds_a_misspelt_place_in_a_step_of_a_file_that_names_its_world(tmp_path):
    mission = tmp_path / "tour.rap"
    mission.write_text(f'(include "{(REPO / "rap_library" / "navigation.rap").as_posix()}")\n'
                       '(world "small-office-map")\n'
                       "(define-rap (tour ?first)\n"
                       "  (method (task-net (sequence (t1 (go-to ?first)) (t2 (go-to room-d))))))\n"
                       "(post (tour meeting-room))\n", encoding="utf-8")
    done = atlas("check", str(mission), cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 1, done.stderr
    assert "tour.rap:4:" in done.stderr and "there is no place named room-d in world small-office-map" in done.stderr
    assert "hint: did you mean 'room-" in done.stderr.split("room-d in world")[1]  # a near place, as the hint
    assert "meeting-room in world" not in done.stderr  # a place the world has: no problem


def test_places_reached_through_variables_or_other_worlds_are_not_checked():
    program = load(DELIVER)
    assert place_problems(program, "lab-corridor-office", {"lab", "corridor", "office"}, TYPES) == []
    assert [p.message for p in place_problems(program, "elsewhere", {"lab"}, TYPES)] == [
        "there is no place named office in world elsewhere"]
