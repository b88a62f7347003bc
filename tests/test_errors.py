"""The AtlasError family's helpers: one "did you mean" for every suggestion atlas-rap makes."""

from pathlib import Path

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
