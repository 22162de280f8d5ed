"""The unit store: finished units' results in ``<out>/units``, so that an interrupted run
resumes from what finished (docs/cluster.md). One implementation for every
command that has units (:func:`open_store`).

Opening a store, before any long work:

- takes the run's lock (``.lock``, :mod:`brake_env.run_lock`), so that a second run into
  the same ``--out`` refuses, naming the first (pid, host, start time). A lock left by a
  run that is no longer running is taken over, saying so;
- refuses a non-empty directory without the store's ``settings.json``, naming it: files the
  project did not write are never adopted, moved or deleted;
- compares the run's settings with those the store was written with, naming what differs;
- checks every unit file (whole JSON, its own key, its arrays' SHA-256, and its digest: an
  HMAC-SHA256 of its content keyed by the hash of the settings it was made under, so a unit
  copied from a run with other settings, or kept under a hand-edited ``settings.json``, or
  of the older unkeyed format, is not used): a damaged, edited or foreign one is moved to
  ``damaged/`` as ``<name>.<n>.json`` (a number no copy there has: never overwritten, and no
  command deletes ``damaged/``) and its unit redone, naming the file and the unit on
  stderr. Only files named for a unit of the run, or for the key they hold, are the
  store's: a user's file named like a unit is left alone;
- says how many of the run's units are done already ("resuming: K of N ...", stderr).
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import json
import os
import re
import sys
import weakref
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from brake_env.output import (
    TEMP_MARK,
    json_safe,
    read_arrays,
    remove_stale_temps,
    write_arrays,
    write_json,
)
from brake_env.run_lock import StoreLocked as StoreLocked  # re-exported: raised by open_store
from brake_env.run_lock import acquire, release
from brake_env.unit_digest import (
    canonical_sha256,
    content_digest,
    digest_problem,
    held_key,
    keyed_digest,
    unit_problem,
)
from brake_env.unit_digest import content_digest as _content_digest  # noqa: F401  # read elsewhere

_SAFE = re.compile(r"[^A-Za-z0-9_.=-]+")
# Unit files as :meth:`UnitStore._stem` names them: other files are not units.
_UNIT_NAME = re.compile(r".*-[0-9a-f]{10}\.json")
_ARRAY, _TUPLE, _FLOAT = "$array", "$tuple", "$float"
SETTINGS = "settings.json"
LOCK = ".lock"
DAMAGED = "damaged"


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
    counts as done once its JSON is there, whole). The JSON carries ``sha256`` (of the
    canonical JSON of its key, result and arrays' digest), ``settings_sha256`` (the hash of
    the store's settings, :attr:`settings_hash`) and ``digest``, an HMAC-SHA256 of both keyed
    by that hash: a unit edited by hand, or made under other settings, is redone, not
    believed. ``settings.json`` records what the run was asked for, and the digest of the
    code that ran (:func:`code_digest`); a rerun asked for anything else, or by other code,
    is refused rather than mixed.

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
        ValueError: ``directory`` holds units of a run with other settings, or files but no
            ``settings.json`` (not a store).
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
        self._keys = list(keys)
        _refuse_foreign(self.directory)  # before the lock file is put there
        self.directory.mkdir(parents=True, exist_ok=True)
        self._lock = acquire(self.directory / LOCK, self.command)
        self._release = weakref.finalize(self, release, self._lock)
        try:
            self.settings = self._check_settings(settings)
            self.settings_hash = canonical_sha256(self.settings)
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
            _refuse_foreign(self.directory)
            write_json(want, path)
            return want
        try:
            have = json.loads(path.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError) as e:
            raise ValueError(
                f"{path} is damaged ({e}); delete {self.directory} to start the run afresh"
            ) from None
        if not isinstance(have, dict):
            raise ValueError(
                f"{path} is damaged (a {type(have).__name__}, not the run's settings); delete"
                f" {self.directory} to start the run afresh"
            )
        diff = sorted(k for k in {*have, *want} if have.get(k) != want.get(k))
        if diff:
            shown = ", ".join(f"{k}: {have.get(k)!r} -> {want.get(k)!r}" for k in diff)
            raise ValueError(
                f"{self.directory} holds finished units of a run with other settings"
                f" ({shown}); resume with the same settings or write to another --out"
            )
        return want

    def _set_aside_damaged(self, keys: Sequence[str]) -> None:
        """Move every damaged unit file (and its arrays) to ``damaged/`` under a number no
        copy there has, naming it: its unit is then not done, so the run redoes it."""
        by_stem = {self._stem(k).name: k for k in keys}
        for path in self._unit_files():
            key, problem = unit_problem(path, self._stem, self.settings_hash)
            if problem is None:
                continue
            key = key or by_stem.get(path.stem) or held_key(path) or "(unknown)"
            moved = self._move_aside(path)
            print(
                f"{self.command}: unit {key}: {path} is damaged ({problem}); moved it to"
                f" {moved} and will redo the unit",
                file=sys.stderr,
            )

    def _move_aside(self, path: Path) -> Path:
        """Move the unit file ``path`` and its arrays into ``damaged/`` as ``<stem>.<n>``,
        ``n`` the first number free for both: a copy set aside is never overwritten."""
        aside = self.directory / DAMAGED
        if aside.exists() and not aside.is_dir():
            raise ValueError(
                f"{aside} is a file: the store sets damaged units aside in a folder of that"
                " name; move the file away"
            )
        aside.mkdir(exist_ok=True)
        n = 1
        while any((aside / f"{path.stem}.{n}{s}").exists() for s in (".json", ".npz")):
            n += 1
        for part in (path, path.with_suffix(".npz")):
            if part.exists():
                os.rename(part, aside / f"{path.stem}.{n}{part.suffix}")  # the store's lock is held
        return aside / f"{path.stem}.{n}.json"

    def _unit_files(self) -> list[Path]:
        """This store's unit files: named as :meth:`_stem` names the unit of one of the
        run's keys, or of the key the file holds. Anything else (settings.json, a killed
        write's temp, a file someone put here, even one named like a unit) is not a unit:
        never moved or deleted."""
        stems = {self._stem(k).name for k in self._keys}
        names = (p for p in self.directory.glob("*.json") if not p.name.startswith("."))
        held = (p for p in names if _UNIT_NAME.fullmatch(p.name))
        return sorted(p for p in held if p.stem in stems or self._names_itself(p))

    def _names_itself(self, path: Path) -> bool:
        key = held_key(path)
        return key is not None and self._stem(key).name == path.stem

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
        doc = {"key": key, "arrays_sha256": sha, "result": tree}
        doc = {**doc, "sha256": content_digest(doc), "settings_sha256": self.settings_hash}
        write_json(
            {**doc, "digest": keyed_digest(doc, self.settings_hash)}, stem.with_suffix(".json")
        )

    def load(self, key: str) -> Any:
        """A saved unit's result.

        Raises:
            ValueError: The files are not this key's, its content or arrays were changed, or
                it was made under other settings.
        """
        stem = self._stem(key)
        doc = json.loads(stem.with_suffix(".json").read_text())
        if doc.get("key") != key:
            raise ValueError(f"{stem}.json holds unit {doc.get('key')!r}, not {key!r}")
        if problem := digest_problem(doc, self.settings_hash):
            raise ValueError(f"{stem}.json: unit {key}: {problem}")
        sha = doc.get("arrays_sha256")
        arrays = read_arrays(stem.with_suffix(".npz"), sha, f"unit {key}") if sha else {}
        return _decode(doc["result"], arrays)

    def discard(self) -> None:
        """Close the store and remove what it wrote: its settings, lock and the run's units;
        the directory too if that leaves it empty. The damaged files it set aside stay in
        ``damaged/`` (no command deletes them), and so do files it did not write; both
        named on stderr."""
        self.close()
        mine = [self.directory / SETTINGS, self.directory / LOCK]
        for key in self._keys:
            mine += [self._stem(key).with_suffix(".json"), self._stem(key).with_suffix(".npz")]
        for path in mine:
            path.unlink(missing_ok=True)
        remove_stale_temps(self.directory)
        with contextlib.suppress(OSError):  # not empty: set-aside or someone else's files
            self.directory.rmdir()
        aside = self.directory / DAMAGED
        if aside.is_dir():
            n = sum(1 for p in aside.iterdir() if p.suffix == ".json")
            print(
                f"{self.command}: kept {aside}/ ({n} damaged unit files set aside, by this run"
                " or earlier ones): no command deletes them; delete them when done with them",
                file=sys.stderr,
            )
        if left := sorted(p.name for p in self.directory.glob("*") if p != aside):
            print(
                f"{self.command}: left {self.directory} in place: it holds files this run did"
                f" not write ({', '.join(left[:5])}{', ...' if len(left) > 5 else ''})",
                file=sys.stderr,
            )


def _refuse_foreign(directory: Path) -> None:
    """Raise unless ``directory`` is new, empty, or a store (has ``settings.json``)."""
    if directory.exists() and not directory.is_dir():
        raise ValueError(f"{directory} is a file, not a unit store; write to another --out")
    if not directory.is_dir() or (directory / SETTINGS).is_file():
        return
    found = sorted(
        p.name
        for p in directory.iterdir()
        if p.name != LOCK and TEMP_MARK not in p.name and not (p.name == DAMAGED and p.is_dir())
    )
    if found:
        shown = ", ".join(found[:5]) + (", ..." if len(found) > 5 else "")
        raise ValueError(
            f"{directory} is not empty ({shown}) but has no {SETTINGS}: it is not a unit"
            " store this project wrote, and its files are left alone; move them away or"
            " write to another --out"
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
