"""Bad input files for every command that reads one: a located error or one line, never a traceback, never 0.

The files a user gets wrong: empty, binary, not UTF-8, a folder, nested
without end, a device that never ends (/dev/zero); for each kind of input
(programs, worlds, grids, topological maps, recordings, typed REPL text).
"""

from __future__ import annotations

import json
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
from cli_process import ENV, REPO, assert_no_traceback, atlas, atlas_command

from atlas_rap.maps.topology import FORMAT

DELIVER = str(REPO / "rap_library" / "missions" / "deliver.rap")

BAD_PROGRAMS = {
    "empty": (b"", "bad.rap:1:1: error: file is empty"),
    "binary": (b"\x00\xad\x13PK\x03", "bad.rap:1:2: error: file is not UTF-8 text (byte 0xad at offset 1)"),
    "Latin-1": (b"(post (greet \"Ren\xe9\"))\n", "bad.rap:1:18: error: file is not UTF-8 text (byte 0xe9 at offset 17)"),
    "nested": (b"(" * 5000 + b")" * 5000, "bad.rap:1:201: error: lists nested more than 200 deep"),
}


def refused(done, code: int = 1) -> str:
    assert_no_traceback(done)
    assert done.returncode == code, (done.returncode, done.stdout, done.stderr)
    return done.stderr


@pytest.mark.parametrize("command", [("check",), ("run",), ("plan",), ("repl",)], ids=lambda c: c[0])
@pytest.mark.parametrize("kind", list(BAD_PROGRAMS))
def test_a_bad_program_file_is_a_located_error_in_every_command_that_reads_one(tmp_path, command, kind):
    data, first_line = BAD_PROGRAMS[kind]
    (tmp_path / "bad.rap").write_bytes(data)
    stderr = refused(subprocess.run(atlas_command(*command, "bad.rap"), cwd=tmp_path, capture_output=True,
                                    text=True, env=ENV, input="", timeout=60))
    assert stderr.startswith(first_line), stderr


@pytest.mark.parametrize("command", ["check", "run", "plan"])
def test_a_device_that_never_ends_is_read_no_further_than_the_size_limit(tmp_path, command):
    stderr = refused(atlas(command, "/dev/zero", cwd=tmp_path))
    assert stderr.startswith("/dev/zero:1:1: error: file is too large")


@pytest.mark.parametrize("command", ["check", "run", "plan", "repl"])
def test_a_folder_where_a_program_file_goes_is_a_usage_error(tmp_path, command):
    (tmp_path / "missions.rap").mkdir()
    stderr = refused(atlas(command, "missions.rap", cwd=tmp_path), code=2)
    assert "'missions.rap' is a directory" in stderr


def test_an_include_of_a_folder_says_it_is_a_folder(tmp_path):
    (tmp_path / "lib").mkdir()
    (tmp_path / "m.rap").write_text('(include "lib")\n', encoding="utf-8")
    stderr = refused(atlas("check", "m.rap", cwd=tmp_path))
    assert stderr.startswith("m.rap:1:1: error: included path is a directory, not a file: lib")


def test_typed_text_that_is_not_utf8_is_located_in_the_repl_and_the_session_goes_on(tmp_path):
    done = subprocess.run(atlas_command("repl"), input=b"(post (x \xff))\n:agenda\n", cwd=tmp_path,
                          capture_output=True, env=ENV, timeout=60)
    assert b"Traceback" not in done.stderr
    assert done.returncode == 1
    assert done.stderr.decode().startswith("<input 1>:1:10: error: not UTF-8 text (byte 0xff)")
    assert b"the agenda is empty" in done.stdout


# ----------------------------------------------------------------- worlds


@pytest.mark.parametrize("data, first_line", [
    (b"", "w.yaml:1:1: error: file is empty"),
    (b"\x00\xad\x13", "w.yaml:1:2: error: file is not UTF-8 text (byte 0xad at offset 1)"),
    (b"name: caf\xe9\n", "w.yaml:1:10: error: file is not UTF-8 text (byte 0xe9 at offset 9)"),
    (b"walls: " + b"[" * 3000 + b"]" * 3000 + b"\n", "w.yaml:1:3007: error: lists or mappings nested too deeply"),
], ids=["empty", "binary", "Latin-1", "nested"])
def test_a_bad_world_file_is_a_located_error(tmp_path, data, first_line):
    (tmp_path / "w.yaml").write_bytes(data)
    stderr = refused(atlas("run", DELIVER, "--world", "w.yaml", cwd=tmp_path))
    assert stderr.startswith(first_line), stderr


@pytest.mark.parametrize("world", ["/dev/zero", "folder"])
def test_a_world_that_is_a_device_or_a_folder_is_one_line(tmp_path, world):
    (tmp_path / "folder").mkdir()
    stderr = refused(atlas("run", DELIVER, "--world", world, cwd=tmp_path))
    assert stderr.startswith(f"{world}:")
    assert "file is too large for a world file" in stderr or "is a directory, not a world file" in stderr


# ----------------------------------------------------------------- grids and topological maps


def _zip_with(path: Path, **members: bytes) -> None:
    with zipfile.ZipFile(path, "w") as archive:
        for name, data in members.items():
            archive.writestr(name, data)


def bad_grids(tmp_path: Path) -> dict[str, tuple[Path, str]]:
    (tmp_path / "empty.npz").write_bytes(b"")
    _zip_with(tmp_path / "cut.npz", **{"p_occ.npy": b"x" * 100})
    (tmp_path / "cut.npz").write_bytes((tmp_path / "cut.npz").read_bytes()[:40])
    np.save(tmp_path / "one.npy", np.zeros(3))
    (tmp_path / "one.npy").rename(tmp_path / "one.npz")
    np.savez(tmp_path / "shape.npz", p_occ=np.zeros((3, 3)), frame=np.array([4, 3, 0.05, 0, 0, 0]))
    np.savez(tmp_path / "frame.npz", p_occ=np.zeros((3, 3)), frame=np.array([1e300, 3, 0.05, 0, 0, 0]))
    return {"empty": (tmp_path / "empty.npz", "the file is empty or not an .npz archive"),
            "truncated": (tmp_path / "cut.npz", "the file is empty or not an .npz archive"),
            "one array": (tmp_path / "one.npz", "it holds one array (.npy), not an .npz archive of a grid"),
            "wrong shape": (tmp_path / "shape.npz", "p_occ has shape (3, 3), not the frame's (4, 3)"),
            "bad frame": (tmp_path / "frame.npz", "frame 1e+300 x 3 cells of 0.05 m is not a grid's")}


@pytest.mark.parametrize("kind", ["empty", "truncated", "one array", "wrong shape", "bad frame"])
def test_a_bad_grid_file_is_one_line_in_map_render_and_in_map_in(tmp_path, kind):
    path, why = bad_grids(tmp_path)[kind]
    render = refused(atlas("map", "render", str(path), "--out", "g.png", cwd=tmp_path))
    assert render.strip() == f"{path}: not a grid written by atlas map or atlas run --map-out ({why})"
    assert "interrupted" not in render  # an empty file once made `map render` say interrupted, exit 130
    map_in = refused(atlas("run", DELIVER, "--no-prior-map", "--map-in", str(path), cwd=tmp_path))
    assert f"{path}: not an occupancy grid" in map_in and why in map_in


@pytest.mark.parametrize("content, why", [
    ("", "Expecting value"),
    ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
    ("1e400", "it holds float, not an object"),
    (json.dumps({"format": FORMAT, "version": 1,
                 "frame": {"height": 10 ** 400, "width": 3, "resolution": 0.05, "origin": [0, 0, 0]},
                 "nodes": [], "edges": []}), "frame must be six finite numbers"),
], ids=["empty", "nested", "a number", "a 400-digit frame"])
def test_a_bad_topological_map_is_one_line(tmp_path, content, why):
    (tmp_path / "topology.json").write_text(content, encoding="utf-8")
    stderr = refused(atlas("run", DELIVER, "--map", "topology.json", cwd=tmp_path))
    assert stderr.startswith("topology.json: not a topological map written by atlas map (")
    assert why in stderr and len(stderr.splitlines()) == 1


def test_a_recording_that_is_not_one_is_one_line(tmp_path):
    (tmp_path / "run.mcap").write_bytes(b"\x00" * 64)
    stderr = refused(atlas("record", "show", "run.mcap", "--out", "r.png", cwd=tmp_path))
    assert stderr.strip().startswith("run.mcap: not a readable MCAP recording")


def test_check_raps_of_a_folder_that_does_not_exist_is_refused_before_planning(tmp_path):
    done = atlas("plan", str(REPO / "operators" / "office-goals.ap"), "--check-raps", "no-such", cwd=tmp_path)
    stderr = refused(done, code=2)
    assert "Invalid value for '--check-raps'" in stderr
    assert done.stdout == ""  # no plan was made first
