"""Who holds a run's output, and while it runs.

- The lock of a unit store (:class:`~brake_env.units.UnitStore` holds one): a second run
  into the same folder refuses while the first runs, naming it (pid, host, start time); a
  lock left by a run that is no longer running is taken over, saying so. Held with
  ``flock``, which the kernel drops when the process dies.
- The mark of a command's ``--out`` (:data:`~brake_env.output.OUTPUT_MARK`,
  :func:`hold_output`): written when the command starts, naming the command, its arguments
  and its process, and kept after it ends or is killed, so another command refuses the
  folder and only the same command may resume it; while it runs its lock
  (``.brakewear.lock``, removed when it ends) refuses a second run of the same command. A
  mark that cannot be read is refused like another command's, naming the file.
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
import sys
import time
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from brake_env.output import OUTPUT_MARK, OUTPUT_MARK_FORMAT, atomic_path, write_json

if sys.platform != "win32":  # Windows has no flock: there the lock names the run, unenforced
    import fcntl


class StoreLocked(ValueError):
    """Another run, still running, holds the store's lock; the message names it."""


# This process's locks by path, with how many open stores share each (a command may open
# its store again, e.g. to read it back; flock would refuse a second open file).
_HELD: dict[Path, list[Any]] = {}


def acquire(path: Path, command: str) -> Path:
    """Hold ``path``'s lock for this process; refuse when another running process holds
    it, naming that process; take over a lock its dead holder left behind, saying so."""
    path = path.resolve()
    if path.is_dir() or (path.exists() and not path.is_file()):
        raise ValueError(
            f"{path} is a folder (or not a file): the run's lock is a file of that name; move"
            " it away"
        )
    if path in _HELD:
        _HELD[path][1] += 1
        return path
    fd = _locked_fd(path)
    left = _holder(fd)
    if left:  # released locks are emptied: this one's holder ended without releasing it
        print(
            f"{command}: taking over the lock of {path.parent} left by a run that is no"
            f" longer running ({_describe(left)})",
            file=sys.stderr,
        )
    me = {
        "pid": os.getpid(),
        "host": socket.gethostname(),
        "started": time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime()),
        "command": command,
    }
    os.ftruncate(fd, 0)
    os.lseek(fd, 0, os.SEEK_SET)
    os.write(fd, json.dumps(me).encode())
    os.fsync(fd)
    _HELD[path] = [fd, 1]
    return path


def _locked_fd(path: Path) -> int:
    """An open descriptor of ``path`` holding its ``flock``; retried while the file it
    locked was removed meanwhile by its last holder (:func:`release` with ``remove``)."""
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        if sys.platform == "win32":
            return fd
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            held = _holder(fd)
            os.close(fd)
            raise StoreLocked(
                f"{path.parent} is in use by another run ({_describe(held)}); wait for it to"
                " finish or write to another --out"
            ) from None
        with contextlib.suppress(FileNotFoundError):
            if os.path.samestat(os.fstat(fd), os.stat(path)):
                return fd
        os.close(fd)


def release(path: Path, remove: bool = False) -> None:
    """One store fewer holds ``path``; the last empties the lock file (or removes it, with
    ``remove``) and lets it go."""
    held = _HELD.get(path)
    if held is None:
        return
    held[1] -= 1
    if held[1] > 0:
        return
    del _HELD[path]
    fd = held[0]
    # Empty: released on purpose (a dead holder leaves its name). The directory may be
    # gone with the finished run: nothing to say then. Removed while still held, so no
    # other process locks the file on its way out (:func:`_locked_fd`).
    with contextlib.suppress(OSError):
        if remove:
            path.unlink()
        else:
            os.ftruncate(fd, 0)
    os.close(fd)  # closing drops the flock
    if remove:  # Windows removes no open file
        with contextlib.suppress(OSError):
            path.unlink(missing_ok=True)


def _holder(fd: int) -> dict[str, Any]:
    """What the lock file says of its holder ({} when empty or unreadable)."""
    os.lseek(fd, 0, os.SEEK_SET)
    text = os.read(fd, 4096).decode(errors="replace")
    try:
        held = json.loads(text) if text.strip() else {}
    except json.JSONDecodeError:
        return {"note": f"unreadable lock {text[:40]!r}"}
    return held if isinstance(held, dict) else {}


def _describe(held: Mapping[str, Any]) -> str:
    if "pid" not in held:
        return str(held.get("note", "holder unknown"))
    return (
        f"{held.get('command', '?')}, pid {held['pid']} on {held.get('host', '?')},"
        f" started {held.get('started', '?')}"
    )


# ---------------------------------------------------------------------- output folders
OUTPUT_LOCK = ".brakewear.lock"  # held in --out while a command runs; removed when it ends
_NOT_MINE = "move the folder's files away or write to another --out (nothing was changed)"


def read_mark(directory: str | os.PathLike[str]) -> dict[str, Any] | None:
    """The :data:`~brake_env.output.OUTPUT_MARK` in ``directory`` (None: it has none).

    Raises:
        ValueError: A mark that is not one this project writes (not JSON, not an object,
            another format, a command that is not a name...), naming the file.
    """
    d = Path(directory)
    path = d / OUTPUT_MARK
    if not os.path.lexists(path):
        return None
    try:
        mark = json.loads(path.read_bytes())
        problem = _mark_problem(mark)
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        mark, problem = None, f"unreadable: {type(e).__name__}: {e}"
    if problem is not None:
        raise ValueError(
            f"--out {d}: {path} is not a mark brakewear writes ({problem}), so which command"
            f" wrote {d} is unknown; {_NOT_MINE}"
        )
    return dict(mark)


def _mark_problem(mark: Any) -> str | None:
    """What is wrong with a mark read as JSON (None: nothing)."""
    if not isinstance(mark, dict):
        return f"a JSON {type(mark).__name__}, not an object"
    if mark.get("format") != OUTPUT_MARK_FORMAT:
        return f"format {mark.get('format')!r}, this brakewear writes {OUTPUT_MARK_FORMAT}"
    command = mark.get("command")
    if not isinstance(command, str) or not command.strip():
        return f"its command is {command!r}, not a command's name"
    args = mark.get("args", [])
    if not isinstance(args, list) or not all(isinstance(a, str) for a in args):
        return f"its args are {args!r}, not a list of strings"
    pid = mark.get("pid", 0)
    if not isinstance(pid, int) or isinstance(pid, bool):
        return f"its pid is {pid!r}, not a number"
    return None


def output_owner(directory: str | os.PathLike[str]) -> str | None:
    """The command whose mark is in ``directory`` (None: no mark).

    Raises:
        ValueError: The mark cannot be read (:func:`read_mark`).
    """
    mark = read_mark(directory)
    return None if mark is None else str(mark["command"])


def check_output(directory: str | os.PathLike[str], command: str) -> None:
    """Refuse ``directory`` as ``command``'s output when another command's mark is there,
    or a mark that cannot be read, or when it is not a directory.

    Raises:
        ValueError: Naming the folder and the command that wrote it (or the mark).
    """
    d = Path(directory)
    if d.exists() and not d.is_dir():
        raise ValueError(f"--out {d}: exists and is not a directory")
    mark = read_mark(d)
    if mark is not None and mark["command"] != command:
        by = f", by pid {mark['pid']} from {mark.get('started', '?')}" if "pid" in mark else ""
        raise ValueError(
            f"--out {d} holds the output of `brakewear {mark['command']}` ({d / OUTPUT_MARK}"
            f"{by}); write `brakewear {command}` to another --out (nothing was changed)"
        )


@contextlib.contextmanager
def hold_output(
    directory: str | os.PathLike[str], command: str, argv: Sequence[str]
) -> Iterator[Path]:
    """``directory`` as ``command``'s output while the block runs: refused if another
    command's (:func:`check_output`) or a running one's (:class:`StoreLocked`); else made,
    locked and marked (command, ``argv``, process) before the block. The mark stays when
    the block ends, or fails once it wrote to the folder; a block that fails having written
    nothing leaves the folder as it was (a folder made for it removed again).

    Raises:
        ValueError: The folder refused, or it cannot be made or written.
    """
    d = Path(directory)
    check_output(d, command)  # before anything is changed
    before = _entries(d)
    made = [p for p in (d, *d.parents) if not os.path.lexists(p)]  # innermost first
    try:
        with _cannot_write(d):
            d.mkdir(parents=True, exist_ok=True)
            lock = acquire(d / OUTPUT_LOCK, command)
    except BaseException:
        _unmake(made)
        raise
    previous: bytes | None = None
    try:
        check_output(d, command)  # again, holding the lock: it may have been marked since
        previous = (d / OUTPUT_MARK).read_bytes() if (d / OUTPUT_MARK).is_file() else b""
        with _cannot_write(d):
            write_json(_mark(command, argv), d / OUTPUT_MARK)
        yield d
    except BaseException:
        if previous is not None and _entries(d) == before:  # it wrote nothing: undo the mark
            _restore(d / OUTPUT_MARK, previous)
        raise
    finally:
        release(lock, remove=True)
        _unmake(made)


def _mark(command: str, argv: Sequence[str]) -> dict[str, Any]:
    return {
        "format": OUTPUT_MARK_FORMAT,
        "command": command,
        "args": [str(a) for a in argv],
        "pid": os.getpid(),
        "host": socket.gethostname(),
        "started": time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime()),
    }


def _entries(d: Path) -> set[str]:
    """The names in ``d`` but its mark and lock (none: no such folder)."""
    names = {p.name for p in d.iterdir()} if d.is_dir() else set()
    return names - {OUTPUT_MARK, OUTPUT_LOCK}


@contextlib.contextmanager
def _cannot_write(d: Path) -> Iterator[None]:
    """An OSError in the block (read-only, a dangling or looping link...) as one line."""
    try:
        yield
    except OSError as e:
        raise ValueError(f"--out {d}: cannot write there ({e.strerror or e})") from None


def _unmake(made: list[Path]) -> None:
    """Remove the folders made for the command that are still empty."""
    for p in made:
        with contextlib.suppress(OSError):
            p.rmdir()


def _restore(path: Path, previous: bytes) -> None:
    """Put back the mark ``path`` held before (none: ``b""``)."""
    with contextlib.suppress(OSError):
        if previous:
            with atomic_path(path) as tmp:
                tmp.write_bytes(previous)
        else:
            path.unlink(missing_ok=True)
