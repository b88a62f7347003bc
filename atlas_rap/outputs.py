"""Output paths: every file or folder a command writes is checked first and written whole.

**Before the work.** ``--trace``, ``--render``, ``--plan-file``, ``--out``,
``--map-out``, ``--record``, the REPL's ``:save`` and ``:map``: a missing
parent folder is made (as ``mkdir -p`` would), and the path is tried as
the work will use it: a file is made and removed in its folder, a device
is opened for writing. A path that cannot be written is a one-line
:class:`OutputError` naming the option and the reason, never a traceback
(:func:`output_file`, :func:`output_folder`). :func:`check_apart` then
refuses an output that is one of the command's own input files (the
mission, a file it includes, a world, a map) or another output. Prepare
every path before the work that fills it starts, so that a long run does
not end in a path error.

**Exit codes.** An output that is also an input, or two outputs that are
one file, contradict the command line itself: a usage error (exit 2,
:class:`OutputUsageError`). A path the file system will not take (a
read-only folder, ``/proc``, a folder where a file is wanted, a full
disk) is exit 1.

**Written whole.** A file is written to a temporary file beside it
(``.NAME.PID-N.part`` in the same folder) and renamed over the path
(``os.replace``) only when it is complete (:class:`AtomicFile`,
:func:`atomic_write`, :func:`atomic_path`, :func:`write_text`,
:func:`write_bytes`). A write that fails or is interrupted (Ctrl-C, a full
disk) removes the temporary file and leaves the old file as it was; a
reader never sees half a file. A symbolic link keeps pointing where it
did: the file it points at is replaced. The new file gets the old one's
permissions (a new one: 0666 less the umask, as ``open`` gives); hard
links to the old file keep the old content. Nothing is ``fsync``\\ ed:
this guards against interruptions and failed writes, not power loss.

**Devices and process files.** A path that exists and is not a regular
file (``/dev/null``, ``/dev/stdout``, a terminal, a named pipe), and any
path under ``/dev`` or ``/proc``, is written directly, appending, with no
temporary file and no rename: renaming a file over ``/dev/full`` would
replace the device itself, and ``/dev/stdout`` may be the very file the
command's output is going to. Before the work such a path is opened and
given an empty write, which a device that cannot take data refuses
(``/dev/full``: no space left on device). A block device is refused.
"""

from __future__ import annotations

import atexit
import itertools
import os
import stat
from contextvars import ContextVar
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any

from atlas_rap.errors import AtlasError

__all__ = [
    "AtomicFile", "OutputError", "OutputUsageError", "atomic_path", "atomic_write", "check_apart", "naming",
    "output_file", "output_folder", "write_all", "write_bytes", "write_text",
]

SPECIAL_FOLDERS = ("/dev", "/proc")
"""Paths under these are written directly (see the module docstring), never through a rename."""

TEMP_SUFFIX = ".part"
"""The ending of the temporary file written beside an output."""

_NAME: ContextVar[str] = ContextVar("output_name", default="output")
"""What an output written without a name of its own is called in its errors (:func:`naming`)."""


class OutputError(AtlasError):
    """An output file or folder that cannot be created or written."""


class OutputUsageError(OutputError):
    """An output path that the command line contradicts: one of its inputs, or another output."""

    exit_code = 2


# -- before the work ---------------------------------------------------------------


def output_file(path: str | os.PathLike, what: str = "output") -> Path:
    """``path`` as a file that can be written: its parent folder made if missing, and tried.

    ``what`` names the option or command in the error (``"--trace"``).
    """
    target = Path(path)
    if target.is_dir():
        raise OutputError(f"{what} {target}: is a folder; give a file name")
    _make_folder(target.parent, what, target)
    if _is_direct(target):
        _try_device(target, what)
        return target
    real = _real(target)
    if real.exists():  # opened for writing, not truncated: a read-only file or file system says so
        try:
            os.close(os.open(real, os.O_WRONLY | os.O_NONBLOCK))
        except OSError as exc:
            raise OutputError(f"{what} {target}: cannot write it ({_reason(exc)})") from None
    _try_folder(real.parent, what, target, target.parent)
    return target


def output_folder(path: str | os.PathLike, what: str = "--out") -> Path:
    """``path`` as a folder that exists (made, with its parents, if missing) and takes new files."""
    target = Path(path)
    if target.exists() and not target.is_dir():
        raise OutputError(f"{what} {target}: is a file, not a folder")
    _make_folder(target, what, target)
    _try_folder(target, what, target)
    return target


def check_apart(outputs: Mapping[str, str | os.PathLike | None], inputs: Mapping[str, Iterable[Any]], *,
                folders: Mapping[str, Iterable[str]] = {}) -> None:
    """Refuse an output that is one of the command's input files, or the same file as another output.

    ``outputs``: option name -> path (None: not given); ``inputs``: what an
    input is (``"the mission"``, ``"--map-in"``) -> its paths (missing ones
    are skipped). ``folders``: for an output that is a folder, the names of
    the files the command writes in it (``"map-run*.npz"`` patterns). Raises
    :class:`OutputUsageError` (exit 2) naming both.
    """
    given = [(what, Path(path)) for what, path in outputs.items() if path is not None]
    files = [(what, Path(path)) for what, paths in inputs.items() for path in paths
             if path is not None and Path(path).is_file()]
    for i, (what, out) in enumerate(given):
        if what in folders:
            for pattern in folders[what]:
                for found in sorted(out.glob(pattern)) if out.is_dir() else []:
                    for kind, path in files:
                        if _same(found, path):
                            raise OutputUsageError(f"{what} {out}: writes {found.name}, which is {kind} "
                                                   f"({path}); give another folder")
            continue
        for kind, path in files:
            if _same(out, path):
                same = "" if str(path) == str(out) else f" ({path})"
                raise OutputUsageError(f"{what} {out}: is {kind}{same}; give another file")
        for other, other_out in given[i + 1:]:
            if other not in folders and (_same(out, other_out) or _real(out) == _real(other_out)):
                raise OutputUsageError(f"{what} {out} and {other} {other_out}: the same file; "
                                       f"give each its own")


def write_all(writers: Mapping[str, Callable[[], object] | None]) -> dict[str, OutputError]:
    """Run every writer (option name -> writer; None: not asked for), also when one fails, each
    under its option's name (:func:`naming`); the :class:`OutputError` of each that failed.

    For the outputs written after a run: each is attempted, and the command
    reports the errors after the run's summary. Ctrl-C stops the writing (what
    was being written is dropped whole).
    """
    errors = {}
    for what, write in writers.items():
        if write is None:
            continue
        try:
            with naming(what):
                write()
        except OutputError as exc:
            errors[what] = exc
    return errors


@contextmanager
def naming(what: str) -> Iterator[None]:
    """Within the block, the errors of outputs written without a name of their own name ``what``
    (``with naming("--render"): render_run(...)``: "--render run.png: cannot write it (...)")."""
    token = _NAME.set(what)
    try:
        yield
    finally:
        _NAME.reset(token)


# -- written whole -----------------------------------------------------------------


class AtomicFile:
    """A file that appears at ``path`` only when complete (see the module docstring).

    ``stream`` (``"b"``: binary, ``"t"``: text, ``None``: none) is open on
    the temporary file; with ``None`` a writer that takes only a path (an
    MCAP writer) writes to :attr:`writing` itself. :meth:`commit`
    renames it into place, :meth:`discard` drops it; until one of them the
    old file is untouched. A device or process file is written directly
    (:attr:`writing` is then ``path``, opened to append).
    """

    def __init__(self, path: str | os.PathLike, what: str | None = None, *, stream: str | None = "b",
                 encoding: str = "utf-8", newline: str | None = None) -> None:
        self.path = Path(path)
        self.what = what or _NAME.get()
        self.direct = _is_direct(self.path)
        self.done = False
        self.stream: IO[Any] | None = None
        try:
            if self.direct:
                self.target = self.path
                self.writing = self.path
                if stream is not None:
                    self.stream = open(self.path, "a" if stream == "t" else "ab",
                                       **({"encoding": encoding, "newline": newline} if stream == "t" else {}))
                return
            self.target = _real(self.path)
            descriptor, name = _create_temporary(self.target.parent, self.target.name)
        except OSError as exc:
            raise self.error(exc) from None
        self.writing = Path(name)
        _UNFINISHED.add(self)
        if stream is None:
            os.close(descriptor)
        elif stream == "t":
            self.stream = os.fdopen(descriptor, "w", encoding=encoding, newline=newline)
        else:
            self.stream = os.fdopen(descriptor, "wb")

    def commit(self) -> Path:
        """Close the stream and rename the file into place; the path. On an error the old
        file stays and an :class:`OutputError` says why. Safe to call twice."""
        if self.done:
            return self.path
        try:
            if self.stream is not None:
                self.stream.close()
            if not self.direct:
                os.chmod(self.writing, _mode_for(self.target))
                os.replace(self.writing, self.target)
        except OSError as exc:
            self.discard()
            raise self.error(exc) from None
        self.done = True
        _UNFINISHED.discard(self)
        return self.path

    def discard(self) -> None:
        """Drop what was written (the old file, if any, stays as it was). Safe to call twice."""
        if self.done:
            return
        self.done = True
        _UNFINISHED.discard(self)
        if self.stream is not None:
            try:
                self.stream.close()
            except OSError:
                pass
        if not self.direct:
            try:
                os.unlink(self.writing)
            except FileNotFoundError:
                pass

    def error(self, exc: OSError) -> OutputError:
        """The one-line error for ``exc`` met while writing this file."""
        return OutputError(f"{self.what} {self.path}: cannot write it ({_reason(exc)})")

    def __enter__(self) -> AtomicFile:
        return self

    def __exit__(self, kind: type | None, exc: BaseException | None, tb: object) -> None:
        if exc is None:
            self.commit()
            return
        self.discard()
        if isinstance(exc, OSError):
            raise self.error(exc) from None


@contextmanager
def atomic_write(path: str | os.PathLike, what: str | None = None, *, text: bool = False,
                 encoding: str = "utf-8", newline: str | None = None) -> Iterator[IO[Any]]:
    """A stream (binary; ``text=True``: text) whose content becomes ``path`` when the block ends
    normally; an exception in the block leaves the old file (an ``OSError`` becomes an
    :class:`OutputError`)."""
    with AtomicFile(path, what, stream="t" if text else "b", encoding=encoding, newline=newline) as file:
        yield file.stream  # type: ignore[misc]


@contextmanager
def atomic_path(path: str | os.PathLike, what: str | None = None) -> Iterator[Path]:
    """A path beside ``path`` for a writer that takes only a file name (an MCAP writer);
    renamed into place when the block ends normally, removed when it does not."""
    with AtomicFile(path, what, stream=None) as file:
        yield file.writing


def write_text(path: str | os.PathLike, text: str, what: str | None = None, *, encoding: str = "utf-8",
               newline: str | None = None) -> Path:
    """``Path.write_text``, written whole (:func:`atomic_write`); the path."""
    with atomic_write(path, what, text=True, encoding=encoding, newline=newline) as stream:
        stream.write(text)
    return Path(path)


def write_bytes(path: str | os.PathLike, data: bytes, what: str | None = None) -> Path:
    """``Path.write_bytes``, written whole (:func:`atomic_write`); the path."""
    with atomic_write(path, what) as stream:
        stream.write(data)
    return Path(path)


# -- pieces ------------------------------------------------------------------------


def _make_folder(folder: Path, what: str, target: Path) -> None:
    if folder == Path("") or folder.is_dir():
        return
    blocking = next((part for part in (folder, *folder.parents) if part.exists() and not part.is_dir()), None)
    if blocking is not None:
        raise OutputError(f"{what} {target}: cannot create the folder {folder}: {blocking} is a file")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{what} {target}: cannot create the folder {folder} ({_reason(exc)})") from None


def _try_folder(folder: Path, what: str, target: Path, shown: Path | None = None) -> None:
    """Make and remove a file in ``folder``, as writing ``target`` will (``shown``: the folder
    as the user wrote it)."""
    try:
        descriptor, name = _create_temporary(folder, "atlas-try")
    except OSError as exc:
        raise OutputError(f"{what} {target}: cannot write in the folder {shown or folder} "
                          f"({_reason(exc)})") from None
    os.close(descriptor)
    os.unlink(name)


def _try_device(target: Path, what: str) -> None:
    """Open a device or process file for writing and write nothing (a full device refuses even that)."""
    try:
        mode = os.stat(target).st_mode
    except FileNotFoundError:
        raise OutputError(f"{what} {target}: cannot write it (no such file; files under "
                          f"{' and '.join(SPECIAL_FOLDERS)} are not made)") from None
    except OSError as exc:
        raise OutputError(f"{what} {target}: cannot write it ({_reason(exc)})") from None
    if stat.S_ISBLK(mode):
        raise OutputError(f"{what} {target}: is a block device; give a file")
    if stat.S_ISDIR(mode):
        raise OutputError(f"{what} {target}: is a folder; give a file name")
    if stat.S_ISFIFO(mode):
        return  # opening a pipe waits for its reader: it is opened when the work writes
    try:
        descriptor = os.open(target, os.O_WRONLY | os.O_APPEND | os.O_NONBLOCK)
        try:
            os.write(descriptor, b"")
        finally:
            os.close(descriptor)
    except OSError as exc:
        raise OutputError(f"{what} {target}: cannot write it ({_reason(exc)})") from None


def _is_direct(path: Path) -> bool:
    """Written directly, not through a rename: under /dev or /proc, or there and not a regular file."""
    absolute = os.path.abspath(path)
    if any(absolute == folder or absolute.startswith(folder + os.sep) for folder in SPECIAL_FOLDERS):
        return True
    try:
        return not stat.S_ISREG(os.stat(path).st_mode)
    except OSError:
        return False


_TEMPORARY_NUMBERS = itertools.count()


def _create_temporary(folder: Path, name: str) -> tuple[int, str]:
    """Create a new file ``.NAME.PID-N.part`` in ``folder`` for writing, as ``tempfile.mkstemp``
    would (exclusively, not through a symbolic link, mode 0600, not inherited by child
    processes): the descriptor and the path. The process number and a counter name it where
    mkstemp draws random letters; a name that exists is skipped. Every output goes through
    here, and mkstemp's random generator costs a third of a millisecond in a new process
    (more than writing a plan file)."""
    flags = os.O_RDWR | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
    for _ in range(1000):
        path = os.path.join(folder, f".{name}.{os.getpid()}-{next(_TEMPORARY_NUMBERS)}{TEMP_SUFFIX}")
        try:
            return os.open(path, flags, 0o600), path
        except FileExistsError:
            continue
    raise FileExistsError(f"no free temporary name for {name} in {folder}")


def _real(path: Path) -> Path:
    """The file a path names, its symbolic links followed (the one a rename must replace)."""
    return Path(os.path.realpath(path))


def _same(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


_UNFINISHED: set[AtomicFile] = set()
"""Files being written; those still open when the process ends are dropped (Ctrl-C in the middle)."""


@atexit.register
def _drop_unfinished() -> None:
    for file in list(_UNFINISHED):
        file.discard()


_UMASK: list[int] = []


def _mode_for(target: Path) -> int:
    """The permissions of the file replaced, or of a new file (0666 less the umask)."""
    try:
        return stat.S_IMODE(os.stat(target).st_mode)
    except OSError:
        pass
    if not _UMASK:
        mask = os.umask(0o022)
        os.umask(mask)
        _UMASK.append(mask)
    return 0o666 & ~_UMASK[0]


def _reason(exc: OSError) -> str:
    return exc.strerror or str(exc)
