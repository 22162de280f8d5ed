"""Results as people and programs read them: terminal or Markdown tables, JSON files; the
one way the project puts a file on disk (:func:`atomic_path`) and the manifest that vouches
for a directory of files (:class:`Manifest`).

Every file is written under a temporary name in its directory, flushed to disk and renamed
into place, so a reader sees the previous file or the whole new one, never half of one,
even when the writer is killed. A directory written as a whole (a dataset) gets a manifest
last, so a directory half old, half new is refused too.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import os
import secrets
import zipfile
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import pyarrow as pa

TEMP_MARK = ".tmp"  # temporary names: .{name}.{pid}-{random}.tmp{suffix}


def table(rows: list[list[str]], markdown: bool = False) -> str:
    """Rows (the first is the header) as right-aligned columns, or as a Markdown table."""
    if markdown:
        head = "| " + " | ".join(rows[0]) + " |"
        rule = "|" + "|".join("---" for _ in rows[0]) + "|"
        return "\n".join([head, rule, *("| " + " | ".join(r) + " |" for r in rows[1:])])
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)) for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def _fsync(path: Path, directory: bool = False) -> None:
    try:
        fd = os.open(path, os.O_RDONLY | (getattr(os, "O_DIRECTORY", 0) if directory else 0))
    except OSError:  # a directory cannot be opened on Windows; the rename is atomic anyway
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def temp_name(path: Path) -> Path:
    """A fresh temporary name beside ``path`` that keeps its suffix (writers such as
    matplotlib choose the format by it) and the writing process id (see
    :func:`remove_stale_temps`)."""
    tag = f"{os.getpid()}-{secrets.token_hex(4)}"
    return path.with_name(f".{path.name}.{tag}{TEMP_MARK}{path.suffix}")


@contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """A temporary path to write ``path``'s content to; renamed into place on success.

    On leaving the block without an error the temporary file is flushed to disk and renamed
    to ``path`` (``os.replace``: atomic on POSIX and Windows), and the directory entry is
    flushed. On an error it is removed and ``path`` keeps its previous content. A killed
    process leaves only a hidden temporary file behind, never a partial ``path``.

    Example:
        >>> with atomic_path(out / "figure.png") as tmp:  # doctest: +SKIP
        ...     fig.savefig(tmp)
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = temp_name(path)
    try:
        yield tmp
        if not tmp.is_file():
            raise FileNotFoundError(f"atomic write of {path}: nothing was written to {tmp}")
        _fsync(tmp)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    _fsync(path.parent, directory=True)


def remove_stale_temps(directory: str | os.PathLike[str]) -> list[Path]:
    """Remove temporary files of :func:`atomic_path` left in ``directory`` by processes
    that no longer run (a killed writer); returns the files removed."""
    removed = []
    for p in Path(directory).glob(f".*{TEMP_MARK}*"):
        tag = p.name.rsplit(TEMP_MARK, 1)[0].rsplit(".", 1)[-1]
        pid = tag.split("-", 1)[0]
        if pid.isdigit() and not _alive(int(pid)):
            p.unlink(missing_ok=True)
            removed.append(p)
    return removed


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True  # exists (another user's) or cannot tell: keep its file
    return True


def write_text(text: str, path: str | os.PathLike[str]) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically (:func:`atomic_path`)."""
    path = Path(path)
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return path


def json_safe(obj: Any) -> Any:
    """``obj`` with NaN and infinities as None (standard JSON has neither), numpy scalars
    and arrays as Python numbers and lists, tuples as lists and keys as strings."""
    if isinstance(obj, np.ndarray):
        obj = obj.tolist()
    elif isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [json_safe(v) for v in obj]
    return obj


def write_json(obj: Any, path: str | os.PathLike[str]) -> Path:
    """Write ``obj`` as standard JSON (NaN and infinities as null, :func:`json_safe`),
    atomically (:func:`atomic_path`).

    Raises:
        TypeError: ``obj`` holds something JSON cannot represent.
    """
    text = json.dumps(json_safe(obj), indent=2, sort_keys=False, allow_nan=False)
    return write_text(text + "\n", path)


# ---------------------------------------------------------------------- arrays
PLAIN_KINDS = frozenset("biufcUS")  # numbers, booleans and fixed-width strings: no objects


def write_arrays(
    arrays: dict[str, np.ndarray], path: str | os.PathLike[str], compress: bool = False
) -> str:
    """Write named arrays as ``.npz`` (atomically); returns its SHA-256, for the JSON
    header that vouches for it (:func:`read_arrays`).

    Raises:
        TypeError: An array holds Python objects (they would need pickle to read back).
    """
    bad = [k for k, a in arrays.items() if np.asarray(a).dtype.kind not in PLAIN_KINDS]
    if bad:
        raise TypeError(f"{path}: arrays {bad} hold Python objects, not numbers or strings")
    buf = io.BytesIO()
    save = np.savez_compressed if compress else np.savez
    save(buf, **arrays)  # type: ignore[arg-type]  # numpy's stub: allow_pickle
    blob = buf.getvalue()
    with atomic_path(path) as tmp:
        tmp.write_bytes(blob)
    return hashlib.sha256(blob).hexdigest()


def read_arrays(path: str | os.PathLike[str], sha256: str, what: str) -> dict[str, np.ndarray]:
    """The arrays :func:`write_arrays` wrote to ``path``, if its SHA-256 is ``sha256``;
    read with ``allow_pickle=False``, so no file can run code here.

    Raises:
        ValueError: Unreadable, another file than the header was written with, or arrays
            that are not plain numbers or strings; the message starts with ``what``.
    """
    name = Path(path).name
    try:
        blob = Path(path).read_bytes()
    except OSError as e:
        raise ValueError(f"{what}: cannot read {name} ({e})") from None
    if hashlib.sha256(blob).hexdigest() != sha256:
        raise ValueError(
            f"{what}: {name} is not the file its header was written with (an interrupted or"
            " mixed write); write it again"
        )
    try:
        with np.load(io.BytesIO(blob), allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except (ValueError, OSError, zipfile.BadZipFile) as e:
        raise ValueError(f"{what}: unreadable {name} ({e})") from None
    bad = [k for k, a in arrays.items() if a.dtype.kind not in PLAIN_KINDS]
    if bad:
        raise ValueError(f"{what}: {name} arrays {bad} are not numbers or strings")
    return arrays


# ---------------------------------------------------------------------- Parquet
_FOOTER_KEY = b"brakewear.footer_sha256"


def _type_name(t: pa.DataType) -> str:
    """A type as it reads back: dictionaries as their values, large strings as strings."""
    import pyarrow as pa

    t = t.value_type if pa.types.is_dictionary(t) else t
    return str(t).replace("large_string", "string").replace("large_binary", "binary")


def _footer_digest(schema: pa.Schema, num_rows: int) -> bytes:
    """Checksum of what a Parquet footer says of the table (Parquet checksums only pages)."""
    fields = [[f.name, _type_name(f.type), f.nullable] for f in schema]
    h = hashlib.sha256(json.dumps([fields, num_rows]).encode())
    h.update((schema.metadata or {}).get(b"pandas", b""))
    return h.hexdigest().encode()


def write_parquet(table: pa.Table, path: str | os.PathLike[str]) -> Path:
    """Write ``table`` as Parquet (zstd) atomically, with a CRC per page and a checksum of
    the footer, so a damaged file is refused on reading, not read as other numbers."""
    import pyarrow.parquet as pq  # not at import: the CLI starts without pyarrow

    meta = {**(table.schema.metadata or {})}
    meta[_FOOTER_KEY] = _footer_digest(table.schema, table.num_rows)
    with atomic_path(path) as tmp:
        pq.write_table(
            table.replace_schema_metadata(meta), tmp, compression="zstd", write_page_checksum=True
        )
    return Path(path)


def parquet_footer_ok(footer: dict[bytes, bytes] | None, table: pa.Table) -> bool:
    """Whether a table read from Parquet matches the checksum :func:`write_parquet` stored
    in the file's footer metadata (``footer``) and in the table's own schema metadata;
    True for files written elsewhere, which have neither. Read the pages with
    ``page_checksum_verification=True`` to check them too."""
    stored = {m[_FOOTER_KEY] for m in (footer, table.schema.metadata) if m and _FOOTER_KEY in m}
    return not stored or stored == {_footer_digest(table.schema, table.num_rows)}


# ---------------------------------------------------------------------- manifest
MANIFEST = "manifest.json"
MANIFEST_FORMAT = 1
_OWN_FILES = f"delete {MANIFEST} to use the files as your own (nothing is checked then)"


class ManifestError(ValueError):
    """A directory whose manifest does not vouch for its files; the message names the file."""


def sha256_file(path: str | os.PathLike[str]) -> str:
    """SHA-256 of a file's bytes, as hex."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while chunk := f.read(1 << 20):
            h.update(chunk)
    return h.hexdigest()


@dataclass(eq=False)
class Manifest:
    """``manifest.json`` of a directory written as a whole: each file's size and SHA-256.

    :meth:`begin` writes it as incomplete before the first file, :meth:`finish` as complete
    after the last, so at no moment does a complete manifest sit beside files it does not
    describe.

    Attributes:
        directory: Where it lives.
        meta: What the files are (seed, spec...), JSON-serialisable.
        files: File name -> ``bytes``, ``sha256`` and what :meth:`add` was given.
        complete: Every file is written.
    """

    directory: Path
    meta: dict[str, Any]
    files: dict[str, dict[str, Any]]
    complete: bool = False

    @classmethod
    def begin(cls, directory: str | os.PathLike[str], meta: dict[str, Any]) -> Manifest:
        """Mark ``directory`` as being written (and clear killed writers' temporary files)."""
        d = Path(directory)
        d.mkdir(parents=True, exist_ok=True)
        remove_stale_temps(d)
        m = cls(d, dict(meta), {})
        m._write()
        return m

    def add(self, path: Path, **info: Any) -> None:
        """Record a file written into the directory (its size and checksum from disk)."""
        self.files[path.name] = {**info, "bytes": path.stat().st_size, "sha256": sha256_file(path)}

    def finish(self) -> None:
        """Mark the directory complete: the last write."""
        self.complete = True
        self._write()

    def _write(self) -> None:
        body = {"format": MANIFEST_FORMAT, "complete": self.complete, "meta": self.meta}
        write_json({**body, "files": self.files}, self.directory / MANIFEST)

    @classmethod
    def read(cls, directory: str | os.PathLike[str]) -> Manifest | None:
        """The manifest of ``directory``, None when it has none.

        Raises:
            ManifestError: One that cannot be read, or of a write that never finished.
        """
        path = Path(directory) / MANIFEST
        if not path.is_file():
            return None
        try:
            m = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
            raise ManifestError(f"{path}: not a readable manifest ({e}); {_OWN_FILES}") from None
        if not isinstance(m, dict) or m.get("format") != MANIFEST_FORMAT:
            raise ManifestError(f"{path}: not a manifest of format {MANIFEST_FORMAT}; {_OWN_FILES}")
        if m.get("complete") is not True or not isinstance(m.get("files"), dict):
            raise ManifestError(
                f"{path}: the directory was being written and the write never finished (the"
                " writer was stopped?), so it may mix old and new files; write it again"
            )
        return cls(Path(directory), m.get("meta") or {}, m["files"], True)

    def check(self, read: Iterable[Path] = ()) -> None:
        """Every listed file present with its size; those in ``read`` with their checksum.

        Raises:
            ManifestError: The first file that differs, by name.
        """
        names = {Path(p).name for p in read}
        for name, info in self.files.items():
            path = self.directory / name
            if not path.is_file():
                raise ManifestError(f"{path}: listed in {MANIFEST} but missing")
            size = path.stat().st_size
            if size != info.get("bytes") or (
                name in names and sha256_file(path) != info.get("sha256")
            ):
                raise ManifestError(
                    f"{path}: does not match {MANIFEST} ({size} bytes, {info.get('bytes')}"
                    " written, or another checksum): cut off, changed, or from another run;"
                    f" write the directory again, or {_OWN_FILES}"
                )


# ---------------------------------------------------------------------- output folders
# In every --out a command wrote: {"format": 1, "command": ..., "args": [...], "pid": ...};
# written, read and held by brake_env.run_lock.hold_output.
OUTPUT_MARK = ".brakewear.json"
OUTPUT_MARK_FORMAT = 1
