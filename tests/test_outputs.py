"""Output files are checked before the work and written whole (atlas_rap.outputs): a write that fails
or is interrupted leaves the old file as it was and no temporary file behind."""

from __future__ import annotations

import os
import stat

import pytest

from atlas_rap.outputs import (
    AtomicFile,
    OutputError,
    OutputUsageError,
    atomic_path,
    atomic_write,
    check_apart,
    naming,
    output_file,
    output_folder,
    write_all,
    write_bytes,
    write_text,
)

OLD = b"the old content, which must survive\n"


def listing(folder) -> list[str]:
    return sorted(os.listdir(folder))


def test_a_complete_write_replaces_the_file_and_leaves_nothing_beside_it(tmp_path):
    target = tmp_path / "out.txt"
    target.write_bytes(OLD)
    write_text(target, "new\n")
    assert target.read_text() == "new\n"
    assert listing(tmp_path) == ["out.txt"]


def test_a_write_that_fails_halfway_leaves_the_old_file_and_no_temporary_file(tmp_path):
    target = tmp_path / "out.txt"
    target.write_bytes(OLD)
    with pytest.raises(RuntimeError):
        with atomic_write(target) as stream:
            stream.write(b"half of the new")
            raise RuntimeError("the writer broke")
    assert target.read_bytes() == OLD
    assert listing(tmp_path) == ["out.txt"]


def test_ctrl_c_in_the_middle_of_a_write_leaves_the_old_file(tmp_path):
    target = tmp_path / "out.txt"
    target.write_bytes(OLD)
    with pytest.raises(KeyboardInterrupt):
        with atomic_write(target, text=True) as stream:
            stream.write("half of the new")
            raise KeyboardInterrupt
    assert target.read_bytes() == OLD
    assert listing(tmp_path) == ["out.txt"]


def test_a_disk_error_while_writing_is_a_one_line_output_error_and_the_old_file_stays(tmp_path, monkeypatch):
    target = tmp_path / "out.txt"
    target.write_bytes(OLD)

    def full(*args):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", full)
    with pytest.raises(OutputError) as caught:
        with naming("--trace"):
            write_bytes(target, b"new")
    assert str(caught.value) == f"--trace {target}: cannot write it (No space left on device)"
    assert target.read_bytes() == OLD
    assert listing(tmp_path) == ["out.txt"]


def test_nothing_appears_at_the_path_until_the_file_is_complete(tmp_path):
    target = tmp_path / "trace.jsonl"
    target.write_bytes(OLD)
    file = AtomicFile(target, stream="t")
    file.stream.write("a line\n")
    file.stream.flush()
    assert target.read_bytes() == OLD  # a reader still sees the old file whole
    file.commit()
    assert target.read_text() == "a line\n"
    file.discard()  # after commit: nothing happens
    assert target.read_text() == "a line\n"
    assert listing(tmp_path) == ["trace.jsonl"]


def test_the_temporary_file_is_private_and_named_after_the_file_and_the_process(tmp_path):
    target = tmp_path / "plan.txt"
    file = AtomicFile(target, stream="t")
    assert file.writing.name.startswith(f".plan.txt.{os.getpid()}-") and file.writing.name.endswith(".part")
    assert stat.S_IMODE(file.writing.stat().st_mode) == 0o600
    file.discard()


def test_a_temporary_name_left_by_an_earlier_process_is_skipped_not_overwritten(tmp_path):
    first = AtomicFile(tmp_path / "plan.txt", stream="t")
    first.discard()
    number = int(first.writing.name.split("-")[-1].removesuffix(".part"))
    for ahead in range(1, 4):  # the next names the counter will give, left behind by someone
        (tmp_path / f".plan.txt.{os.getpid()}-{number + ahead}.part").write_bytes(b"someone else's")
    write_text(tmp_path / "plan.txt", "(go)\n")
    assert (tmp_path / "plan.txt").read_text() == "(go)\n"
    left = sorted(path.name for path in tmp_path.iterdir() if path.name.endswith(".part"))
    assert len(left) == 3 and all((tmp_path / name).read_bytes() == b"someone else's" for name in left)


def test_a_discarded_file_leaves_the_old_one(tmp_path):
    target = tmp_path / "run.mcap"
    target.write_bytes(OLD)
    file = AtomicFile(target, stream=None)
    file.writing.write_bytes(b"a recording that was never finished")
    file.discard()
    assert target.read_bytes() == OLD
    assert listing(tmp_path) == ["run.mcap"]


def test_a_writer_that_takes_a_path_writes_beside_and_the_file_moves_into_place(tmp_path):
    target = tmp_path / "run.mcap"
    with atomic_path(target) as writing:
        assert writing.parent == tmp_path and writing != target
        writing.write_bytes(b"recorded")
    assert target.read_bytes() == b"recorded"
    assert listing(tmp_path) == ["run.mcap"]


def test_the_new_file_keeps_the_old_ones_permissions_and_a_new_one_gets_the_usual(tmp_path):
    kept = tmp_path / "kept.txt"
    kept.write_bytes(OLD)
    kept.chmod(0o640)
    write_text(kept, "new\n")
    assert stat.S_IMODE(kept.stat().st_mode) == 0o640
    mask = os.umask(0o022)
    os.umask(mask)
    new = write_text(tmp_path / "new.txt", "new\n")
    assert stat.S_IMODE(new.stat().st_mode) == 0o666 & ~mask


def test_a_symbolic_link_keeps_pointing_at_the_file_it_named(tmp_path):
    real = tmp_path / "real.txt"
    real.write_bytes(OLD)
    link = tmp_path / "link.txt"
    link.symlink_to(real)
    write_text(link, "new\n")
    assert link.is_symlink() and real.read_text() == "new\n"


def test_devices_are_written_directly_never_replaced():
    write_text("/dev/null", "nothing\n")
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)
    with pytest.raises(OutputError, match="No space left on device"):
        write_text("/dev/full", "more than it takes\n")
    assert stat.S_ISCHR(os.stat("/dev/full").st_mode)


@pytest.mark.parametrize("path, reason", [
    ("/dev/full", "--trace /dev/full: cannot write it (No space left on device)"),
    ("/proc/atlas-trace.jsonl", "--trace /proc/atlas-trace.jsonl: cannot write it (no such file; files under "
                                "/dev and /proc are not made)"),
    ("/sys/atlas-trace.jsonl", "--trace /sys/atlas-trace.jsonl: cannot write in the folder /sys (Permission denied)"),
], ids=["a full device", "a process file", "a kernel folder"])
def test_an_output_that_cannot_be_written_is_found_before_the_work(path, reason):
    with pytest.raises(OutputError) as caught:
        output_file(path, "--trace")
    assert str(caught.value) == reason


def test_a_folder_is_not_an_output_file_nor_a_file_an_output_folder(tmp_path):
    (tmp_path / "a-file").write_bytes(OLD)
    with pytest.raises(OutputError, match="is a folder; give a file name"):
        output_file(tmp_path, "--trace")
    with pytest.raises(OutputError, match="is a file, not a folder"):
        output_folder(tmp_path / "a-file", "--out")
    assert (tmp_path / "a-file").read_bytes() == OLD
    assert output_folder(tmp_path / "new" / "levels") == tmp_path / "new" / "levels"
    assert listing(tmp_path / "new" / "levels") == []  # the try left nothing behind


def test_an_output_that_is_an_input_or_another_output_is_a_usage_error(tmp_path):
    mission = tmp_path / "m.rap"
    mission.write_bytes(OLD)
    with pytest.raises(OutputUsageError) as caught:
        check_apart({"--trace": str(mission)}, {"the mission": [str(mission)]})
    assert caught.value.exit_code == 2
    assert str(caught.value) == f"--trace {mission}: is the mission; give another file"
    with pytest.raises(OutputUsageError, match="the same file; give each its own"):
        check_apart({"--trace": tmp_path / "x", "--render": tmp_path / "x"}, {})
    (tmp_path / "out").mkdir()
    rules = tmp_path / "out" / "errand.rap"
    rules.write_bytes(OLD)
    with pytest.raises(OutputUsageError, match="writes errand.rap, which is --layer-rules"):
        check_apart({"--out": tmp_path / "out"}, {"--layer-rules": [rules]}, folders={"--out": ("errand.rap",)})
    check_apart({"--trace": tmp_path / "t.jsonl", "--out": tmp_path / "out"}, {"the mission": [mission]},
                folders={"--out": ("figures.json",)})  # apart: nothing to say


def test_every_writer_runs_when_one_fails_and_each_error_names_its_option(tmp_path):
    done = []
    failed = write_all({
        "--trace": lambda: write_text("/dev/full", "x"),
        "--render": lambda: done.append(write_text(tmp_path / "r.png", "x")),
        "--map-out": None,
    })
    assert list(failed) == ["--trace"] and str(failed["--trace"]).startswith("--trace /dev/full: cannot write it")
    assert done == [tmp_path / "r.png"]
