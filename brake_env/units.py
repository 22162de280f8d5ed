"""The unit store: finished units' results in ``<out>/units``, so that an interrupted run
resumes from what finished (README "Running on a cluster"). One implementation for every
command that has units (:func:`open_store`).

Opening a store, before any long work:

- takes the run's lock (``.lock``, held with ``flock`` until the run ends; the kernel drops
  it when the process dies), so that a second run into the same ``--out`` refuses, naming
  the first (pid, host, start time). A lock left by a run that is no longer running is
  taken over, saying so;
- compares the run's settings with those the store was written with, naming what differs;
- checks every unit file (whole JSON, its own key, its arrays' SHA-256): a damaged one is
  moved to ``damaged/`` and its unit redone, naming the file and the unit on stderr;
- says how many of the run's units are done already ("resuming: K of N ...", stderr).
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import json
import os
import re
import shutil
import socket
import sys
import time
import weakref
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from brake_env.output import json_safe, read_arrays, sha256_file, write_arrays, write_json

if sys.platform != "win32":  # Windows has no flock: there the lock names the run, unenforced
    import fcntl

_SAFE = re.compile(r"[^A-Za-z0-9_.=-]+")
_ARRAY, _TUPLE, _FLOAT = "$array", "$tuple", "$float"
SETTINGS = "settings.json"
LOCK = ".lock"
DAMAGED = "damaged"


class StoreLocked(ValueError):
    """Another run, still running, holds the store's lock; the message names it."""


def open_store(
    directory: str | os.PathLike[str],
    settings: Mapping[str, Any],
    keys: Sequence[str],
    command: str,
    noun: str = "units",
) -> UnitStore:
    """The store of a run whose units are ``keys`` (locked, checked; damaged units set
    aside), saying on stderr how many of them are done already.

    Args:
        directory: ``<out>/units``.
        settings: What the units' results depend on (JSON).
        keys: The run's units (to name a damaged file's unit and count what is done).
        command: The command's name, starting each message.
        noun: What a unit is called in the messages ("units", "cases").

    Raises:
        StoreLocked: Another running process holds the store.
        ValueError: ``directory`` holds units of a run with other settings.
    """
    store = UnitStore(directory, settings, keys=keys, command=command)
    done = sum(k in store for k in keys)
    if done:
        print(
            f"{command}: resuming: {done} of {len(keys)} {noun} already done ({store.directory})",
            file=sys.stderr,
        )
    return store


class UnitStore:
    """Finished units' results in ``directory``: per unit a JSON file and, for its arrays,
    an ``.npz`` (read back without pickle, its SHA-256 in the JSON, written first: a unit
    counts as done once its JSON is there, whole). ``settings.json`` records what the run
    was asked for, and the digest of the code that ran (:func:`code_digest`); a rerun asked
    for anything else, or by other code, is refused rather than mixed.

    A result is a tree of dicts (string keys), lists, tuples, numpy arrays, strings,
    numbers, booleans and None. The store holds the directory's lock while it is open
    (:meth:`close`, or when it is garbage-collected, or when the process ends).

    Args:
        directory: Where the units' files go.
        settings: What the results depend on (JSON): seed, budget, atlas hash...
        keys: The run's unit keys, to name the unit of a damaged file that names none.
        command: Starts the messages on stderr (``""``: ``units``).

    Raises:
        StoreLocked: Another running process holds the store.
        ValueError: ``directory`` holds units of a run with other settings.
    """

    def __init__(
        self,
        directory: str | os.PathLike[str],
        settings: Mapping[str, Any],
        keys: Sequence[str] = (),
        command: str = "",
    ):
        self.directory = Path(directory)
        self.command = command or "units"
        self.directory.mkdir(parents=True, exist_ok=True)
        self._lock = _acquire(self.directory / LOCK, self.command)
        self._release = weakref.finalize(self, _release, self._lock)
        try:
            self.settings = self._check_settings(settings)
            self._set_aside_damaged(keys)
        except BaseException:
            self.close()
            raise

    def close(self) -> None:
        """Release the directory's lock (another run may then open it)."""
        self._release()

    def __enter__(self) -> UnitStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _check_settings(self, settings: Mapping[str, Any]) -> dict[str, Any]:
        settings = {**settings, "code": code_digest()}
        want: dict[str, Any] = json.loads(json.dumps(json_safe(settings), allow_nan=False))
        path = self.directory / SETTINGS
        if not path.is_file():
            write_json(want, path)
            return want
        try:
            have = json.loads(path.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError) as e:
            raise ValueError(
                f"{path} is damaged ({e}); delete {self.directory} to start the run afresh"
            ) from None
        diff = sorted(k for k in {*have, *want} if have.get(k) != want.get(k))
        if diff:
            shown = ", ".join(f"{k}: {have.get(k)!r} -> {want.get(k)!r}" for k in diff)
            raise ValueError(
                f"{self.directory} holds finished units of a run with other settings"
                f" ({shown}); resume with the same settings or write to another --out"
            )
        return want

    def _set_aside_damaged(self, keys: Sequence[str]) -> None:
        """Move every damaged unit file (and its arrays) to ``damaged/``, naming it: its
        unit is then not done, so the run redoes it."""
        by_stem = {self._stem(k).name: k for k in keys}
        for path in self._unit_files():
            key, problem = _unit_problem(path, self._stem)
            if problem is None:
                continue
            key = key or by_stem.get(path.stem) or _key_in_text(path) or "(unknown)"
            aside = self.directory / DAMAGED
            aside.mkdir(exist_ok=True)
            for part in (path, path.with_suffix(".npz")):
                if part.exists():
                    shutil.move(part, aside / part.name)
            print(
                f"{self.command}: unit {key}: {path} is damaged ({problem}); moved it to"
                f" {aside}/ and will redo the unit",
                file=sys.stderr,
            )

    def _unit_files(self) -> list[Path]:
        return sorted(
            p
            for p in self.directory.glob("*.json")
            if p.name != SETTINGS and not p.name.startswith(".")  # not a killed write's temp
        )

    def _stem(self, key: str) -> Path:
        digest = hashlib.sha256(key.encode()).hexdigest()[:10]
        return self.directory / f"{_SAFE.sub('_', key)[:60]}-{digest}"

    def __contains__(self, key: str) -> bool:
        return self._stem(key).with_suffix(".json").is_file()

    def keys(self) -> list[str]:
        """Keys of the units saved here."""
        return sorted(json.loads(p.read_text())["key"] for p in self._unit_files())

    def save(self, key: str, value: Any) -> None:
        """Save a unit's result (arrays first, the JSON that vouches for them last)."""
        arrays: dict[str, np.ndarray] = {}
        tree = _encode(value, arrays)
        stem = self._stem(key)
        sha = write_arrays(arrays, stem.with_suffix(".npz")) if arrays else None
        write_json({"key": key, "arrays_sha256": sha, "result": tree}, stem.with_suffix(".json"))

    def load(self, key: str) -> Any:
        """A saved unit's result.

        Raises:
            ValueError: The files are not this key's, or its arrays were changed.
        """
        stem = self._stem(key)
        doc = json.loads(stem.with_suffix(".json").read_text())
        if doc.get("key") != key:
            raise ValueError(f"{stem}.json holds unit {doc.get('key')!r}, not {key!r}")
        sha = doc.get("arrays_sha256")
        arrays = read_arrays(stem.with_suffix(".npz"), sha, f"unit {key}") if sha else {}
        return _decode(doc["result"], arrays)


def _unit_problem(path: Path, stem_of: Any) -> tuple[str | None, str | None]:
    """(the unit key the file names, what is wrong with it or None): cheap checks only,
    whole JSON of the right shape under its own name, arrays of the SHA-256 it gives."""
    try:
        doc = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError, OSError) as e:
        return None, f"not whole JSON: {e}"
    key = doc.get("key") if isinstance(doc, dict) else None
    if not isinstance(key, str) or "result" not in doc:
        return None, "not a unit file (no key and result)"
    if stem_of(key).name != path.stem:
        return key, f"holds unit {key!r} under another unit's name"
    sha = doc.get("arrays_sha256")
    npz = path.with_suffix(".npz")
    if sha is not None and not npz.is_file():
        return key, f"its arrays {npz.name} are missing"
    if sha is not None and sha256_file(npz) != sha:
        return key, f"its arrays {npz.name} are not the file it was written with"
    return key, None


def _key_in_text(path: Path) -> str | None:
    """The key written at the start of a cut unit file, if it got that far."""
    found = re.search(r'"key":\s*"([^"]*)"', path.read_text(errors="replace"))
    return found.group(1) if found else None


# ---------------------------------------------------------------------- lock
# This process's locks by path, with how many open stores share each (a command may open
# its store again, e.g. to read it back; flock would refuse a second open file).
_HELD: dict[Path, list[Any]] = {}


def _acquire(path: Path, command: str) -> Path:
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


def _release(path: Path) -> None:
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


# ---------------------------------------------------------------------- encoding
def code_digest() -> str:
    """SHA-256 (first 16 hex digits) of the project's Python sources as imported here: a
    store written by other code (an edited checkout, another version) is not resumed."""
    h = hashlib.sha256()
    for pkg in ("brake_env", "twin", "baselines", "agents", "sim2real"):
        spec = importlib.util.find_spec(pkg)
        if spec is None or not spec.submodule_search_locations:
            continue
        root = Path(next(iter(spec.submodule_search_locations)))
        for path in sorted(root.rglob("*.py")):
            h.update(str(path.relative_to(root.parent)).encode())
            h.update(path.read_bytes())
    return h.hexdigest()[:16]


def _encode(x: Any, arrays: dict[str, np.ndarray]) -> Any:
    if isinstance(x, np.ndarray):
        name = f"a{len(arrays)}"
        arrays[name] = x
        return {_ARRAY: name}
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and not np.isfinite(x):
        return {_FLOAT: repr(x)}
    if x is None or isinstance(x, str | int | float | bool):
        return x
    if isinstance(x, Mapping):
        bad = [k for k in x if not isinstance(k, str) or k.startswith("$")]
        if bad:
            raise TypeError(f"unit results need string keys (not starting with $), got {bad}")
        return {k: _encode(v, arrays) for k, v in x.items()}
    if isinstance(x, tuple):
        return {_TUPLE: [_encode(v, arrays) for v in x]}
    if isinstance(x, list):
        return [_encode(v, arrays) for v in x]
    raise TypeError(f"a unit result cannot hold a {type(x).__name__}")


def _decode(x: Any, arrays: Mapping[str, np.ndarray]) -> Any:
    if isinstance(x, list):
        return [_decode(v, arrays) for v in x]
    if not isinstance(x, dict):
        return x
    if _ARRAY in x:
        return arrays[x[_ARRAY]]
    if _FLOAT in x:
        return float(x[_FLOAT])
    if _TUPLE in x:
        return tuple(_decode(v, arrays) for v in x[_TUPLE])
    return {k: _decode(v, arrays) for k, v in x.items()}
