"""The AtlasError family: one "did you mean" for every suggestion atlas-rap makes, and a class per area
(language, world, map, plan, run, skill bus) raised where that area raises, located ones with their caret."""

from pathlib import Path

import pytest

from atlas_rap import errors
from atlas_rap.errors import did_you_mean, nearest, suggestion

PACKAGE = Path(__file__).resolve().parents[1] / "atlas_rap"


def test_did_you_mean_names_the_closest_choice():
    assert did_you_mean("sucede", ["method", "succeed", "retries"]) == "did you mean 'succeed'?"


def test_did_you_mean_is_none_when_nothing_is_close():
    assert did_you_mean("xyzzy", ["method", "succeed"]) is None
    assert did_you_mean("anything", []) is None


def test_did_you_mean_quotes_and_ends_as_asked():
    assert did_you_mean(":agnda", (":agenda", ":memory"), quote="") == "did you mean :agenda?"
    assert did_you_mean("trinay", {"trinary": 1, "raw": 2}, end=" ") == "did you mean 'trinary'? "


def test_nearest_and_suggestion_are_the_parts_of_did_you_mean():
    assert nearest("offce", ["lab", "office"]) == "office"
    assert suggestion("(sequence ...)", quote="") == "did you mean (sequence ...)?"


def test_no_module_but_errors_writes_did_you_mean_itself():
    def writes_it(path: Path) -> bool:
        text = path.read_text(encoding="utf-8")
        return "did you mean" in text.lower() or "get_close_matches" in text

    assert sorted(str(path.relative_to(PACKAGE)) for path in PACKAGE.rglob("*.py") if writes_it(path)) == ["errors.py"]


# -- the error classes of each area --------------------------------------------------------------------------

AREAS = [(errors.WorldError, errors.WorldFileError), (errors.MapError, errors.MapFileError),
         (errors.PlanError, errors.PlanFileError), (errors.RunError, errors.RunFileError)]


@pytest.mark.parametrize("plain, located", AREAS)
def test_an_areas_located_error_is_a_source_error_of_the_area_and_its_plain_one_is_not(plain, located):
    assert issubclass(located, plain) and issubclass(located, errors.SourceError)
    assert issubclass(plain, errors.AtlasError) and not issubclass(plain, errors.SourceError)


@pytest.mark.parametrize("located", [errors.LanguageError] + [located for _, located in AREAS])
def test_an_areas_located_error_shows_its_line_with_a_caret_as_a_source_error_does(located):
    problem = errors.Problem("unknown key 'plces'", errors.SourceLocation("w.yaml", 2, 3), "  plces: {}",
                             "did you mean 'places'?")
    assert str(located(problem)) == str(errors.SourceError(problem)) == (
        "w.yaml:2:3: error: unknown key 'plces'\n      plces: {}\n      ^\n  hint: did you mean 'places'?")


def test_the_bus_errors_are_the_bus_areas():
    from atlas_rap.skillbus.auth import TokenError
    from atlas_rap.skillbus.messages import DecodeError, VersionError, decode
    from atlas_rap.skillbus.zenoh_bus import BusError

    assert all(issubclass(kind, errors.SkillBusError) for kind in (BusError, DecodeError, VersionError, TokenError))
    with pytest.raises(errors.SkillBusError):
        decode(b"not json")


def test_reading_a_rap_file_raises_the_language_area(tmp_path):
    from atlas_rap.lang import load, parse_text

    with pytest.raises(errors.LanguageError, match="no such file"):
        load(tmp_path / "missing.rap")
    with pytest.raises(errors.LanguageError, match="unknown clause 'sucede'"):
        parse_text("(define-rap (go) (sucede (at robot lab)))")


def test_a_world_raises_the_world_area_located_only_when_it_points_into_a_file(tmp_path):
    from atlas_rap.sim.world import load_world

    with pytest.raises(errors.WorldError, match="did you mean 'maze'") as unknown:
        load_world("maz")
    assert not isinstance(unknown.value, errors.SourceError)
    (tmp_path / "w.yaml").write_text("name: w\nplces: {}\n", encoding="utf-8")
    with pytest.raises(errors.WorldFileError, match="w.yaml:2:1"):
        load_world(tmp_path / "w.yaml")


def test_a_map_raises_the_map_area(tmp_path):
    from atlas_rap.maps.grid import load_grid_arrays
    from atlas_rap.maps.rosmap import load_ros_map

    (tmp_path / "m.yaml").write_text("image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nmode: trinay\n",
                                     encoding="utf-8")
    with pytest.raises(errors.MapFileError, match="did you mean 'trinary'"):
        load_ros_map(tmp_path / "m.yaml")
    (tmp_path / "grid.npz").write_bytes(b"not a grid")
    with pytest.raises(errors.MapError, match="not a grid written by atlas map"):
        load_grid_arrays(tmp_path / "grid.npz")


def test_a_plan_raises_the_plan_area(tmp_path):
    from atlas_rap.planner.plan_file import read_plan_file

    (tmp_path / "plan.txt").write_text("(move a b)\nmove c d\n", encoding="utf-8")
    with pytest.raises(errors.PlanFileError, match="not a plan action"):
        read_plan_file(tmp_path / "plan.txt")


def test_a_recording_that_cannot_be_read_raises_the_run_area(tmp_path):
    from atlas_rap.views.mcap_reader import read_recording

    with pytest.raises(errors.RunError):
        read_recording(tmp_path / "missing.mcap")
