"""The lock of a run's output (:class:`~brake_env.units.UnitStore` holds one): a second run
into the same folder refuses while the first runs, naming it (pid, host, start time); a lock
left by a run that is no longer running is taken over, saying so. Held with ``flock``, which
the kernel drops when the process dies."""

from __future__ import annotations

import contextlib
import json
import os
import socket
import sys
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

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
    if path in _HELD:
        _HELD[path][1] += 1
        return path
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    if sys.platform != "win32":
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            held = _holder(fd)
            os.close(fd)
            raise StoreLocked(
                f"{path.parent} is in use by another run ({_describe(held)}); wait for it to"
                " finish or write to another --out"
            ) from None
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


def release(path: Path) -> None:
    """One store fewer holds ``path``; the last empties the lock file and lets it go."""
    held = _HELD.get(path)
    if held is None:
        return
    held[1] -= 1
    if held[1] > 0:
        return
    del _HELD[path]
    fd = held[0]
    # Empty: released on purpose (a dead holder leaves its name). The directory may be
    # gone with the finished run: nothing to say then.
    with contextlib.suppress(OSError):
        os.ftruncate(fd, 0)
    os.close(fd)  # closing drops the flock


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
