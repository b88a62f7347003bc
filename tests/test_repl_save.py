"""`:save FILE` writes a session that `atlas repl FILE` loads back: its world, definitions, memory and tasks.

A saved file was not loadable when the session ran in a world (the world was
not saved, so the stock skills its RAPs call were unknown). The round trip
here is the user's: save, start a new session on the file, save again, and
the two files say the same; and the loaded session runs the saved task in
the saved world.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

from cli_process import ENV, REPO, assert_no_traceback, atlas_command

DELIVER = str(REPO / "rap_library" / "missions" / "deliver.rap")


def repl(script: str, *files: str, cwd: Path) -> subprocess.CompletedProcess:
    done = subprocess.run(atlas_command("repl", *files), input=script, cwd=cwd, capture_output=True, text=True,
                          env=ENV, timeout=120)
    assert_no_traceback(done)
    return done


def forms(path: Path) -> list[str]:
    """The file without its comment lines (they say when it was saved)."""
    return [line for line in path.read_text(encoding="utf-8").splitlines() if not line.startswith(";;")]


def test_a_session_in_a_world_saves_the_world_and_loads_back_to_the_same_file(tmp_path):
    first = repl("(post (go-to storeroom) :priority 5 :deadline 300)\n"
                 "(at-time 100 (assert (door-closed office-door)))\n:run 5\n:save saved.rap\n", DELIVER, cwd=tmp_path)
    assert "saved the session (world lab-corridor-office" in first.stdout, first.stderr
    saved = forms(tmp_path / "saved.rap")
    assert saved[1] == '(world "lab-corridor-office")'
    assert "(post (go-to storeroom) :priority 5 :deadline 295.0)" in saved  # what was left of the deadline
    assert "(at-time 95.0 (assert (door-closed office-door)))" in saved  # 100 s, 5 s after the start
    assert "  (deliver ?item ?to ?home)" in saved  # the head of the mission's RAP, printed in full
    assert "  (carrying robot mail)" in saved  # the mission's own fact
    assert not any(line.strip().startswith(("(at robot", "(place ", "(door ")) for line in saved)  # the world's
    assert not any("one-primary-layer" in line for line in saved)  # the layers' rules come with the world

    again = repl(":save again.rap\n", "saved.rap", cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    assert forms(tmp_path / "again.rap") == saved

    run = repl(":run\n(? (at robot ?where))\n", "saved.rap", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert "✓ [2] (go-to storeroom) succeeded" in run.stdout  # the stock skills of the saved world drove it
    assert "✓ [1] (deliver mail office lab) succeeded" in run.stdout  # after the storeroom: they share the base
    assert "?where = lab" in run.stdout


def test_a_session_without_a_world_keeps_what_its_virtual_skills_asserted_and_its_plans(tmp_path):
    script = ("(define-virtual-skill (wave ?who) (after 1 (assert (greeted ?who)) (finish :succeed)))\n"
              "(define-rap (greet ?who) (succeed (greeted ?who)) (method (task-net (wave ?who))))\n"
              "(operator greet-op :purpose (greeted ?who) :effects ((greeted ?who)))\n"
              "(post (greet ann))\n:run\n(post (greet bea) :priority 3)\n"
              '(assert (note "a \\"quoted\\" word" 1.5e300 -7))\n'
              "(plan (greeted cy))\n:save saved.rap\n")
    first = repl(script, cwd=tmp_path)
    assert first.returncode == 0, first.stderr
    saved = forms(tmp_path / "saved.rap")
    assert saved[1] == '(world "none")'
    assert "  (greeted ann)" in saved and "  (done (wave ann) :succeed)" in saved  # a virtual skill is no world
    assert '  (note "a \\"quoted\\" word" 1.5e+300 -7)' in "\n".join(saved)
    assert "(post (greet bea) :priority 3)" in saved
    assert "(plan (greeted cy))" in saved  # the plan being made, as it was asked for
    assert not any("carry-out-plan" in line for line in saved)

    again = repl(":save again.rap\n", "saved.rap", cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    assert forms(tmp_path / "again.rap") == saved
    run = repl(":run\n(? (greeted ?who))\n", "saved.rap", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert "?who = bea" in run.stdout and "?who = cy" in run.stdout


def test_a_world_given_as_a_file_is_saved_by_its_full_path(tmp_path):
    world = tmp_path / "my-maze.yaml"
    world.write_text((REPO / "worlds" / "maze.yaml").read_text(encoding="utf-8"), encoding="utf-8")
    repl(":save saved.rap\n", "--world", str(world), cwd=tmp_path)
    # the printer wraps a form past its width, so a long tmp_path puts the path on a line of its own
    assert " ".join(" ".join(forms(tmp_path / "saved.rap")).split()).startswith(f'(world "{world}")')
    loaded = repl(":layers\n", str(tmp_path / "saved.rap"), cwd=tmp_path.parent)
    assert loaded.returncode == 0, loaded.stderr
