"""A stored unit's digests and the cheap checks of its file (:mod:`brake_env.units`):
``sha256`` over its content, and ``digest``, an HMAC-SHA256 keyed by the hash of the
store's settings over its content and the settings hash it names, so that a unit holds only
under the settings it was made under."""

from __future__ import annotations

import contextlib
import hashlib
import hmac
import json
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from brake_env.output import sha256_file

CHANGED = "its content is not what was written (it was changed since it was written, or damaged)"


def canonical(x: Any) -> bytes:
    return json.dumps(x, sort_keys=True, separators=(",", ":"), allow_nan=False).encode()


def canonical_sha256(x: Any) -> str:
    return hashlib.sha256(canonical(x)).hexdigest()


def content_digest(doc: Mapping[str, Any]) -> str:
    """SHA-256 of a unit file's content (key, arrays' digest, result) as canonical JSON."""
    return canonical_sha256({k: doc.get(k) for k in ("key", "arrays_sha256", "result")})


def keyed_digest(doc: Mapping[str, Any], settings_hash: str) -> str:
    """HMAC-SHA256, keyed by the store's settings hash, of a unit's content and the
    settings hash it names: it holds only under the settings the unit was made under."""
    body = {k: doc.get(k) for k in ("key", "arrays_sha256", "result", "settings_sha256")}
    return hmac.new(settings_hash.encode(), canonical(body), hashlib.sha256).hexdigest()


def digest_problem(doc: Mapping[str, Any], settings_hash: str) -> str | None:
    """What is wrong with a unit's digests under the store's settings hash, or None."""
    if doc.get("sha256") != content_digest(doc):
        return CHANGED
    if "digest" not in doc:
        return (
            "it carries no digest keyed to the settings it was made under (an older unit"
            " format, or a copy): it cannot be told from a unit of other settings"
        )
    if doc.get("settings_sha256") != settings_hash:
        made = str(doc.get("settings_sha256"))[:12]
        return (
            f"it was made under other settings (settings hash {made},"
            f" this store's {settings_hash[:12]}): copied from another run, or settings.json"
            " was edited"
        )
    if not hmac.compare_digest(str(doc["digest"]), keyed_digest(doc, settings_hash)):
        return CHANGED
    return None


def unit_problem(path: Path, stem_of: Any, settings_hash: str) -> tuple[str | None, str | None]:
    """(the unit key the file names, what is wrong with it or None): cheap checks only,
    whole JSON of the right shape under its own name, its digests under ``settings_hash``
    (:func:`digest_problem`), arrays of the SHA-256 it gives."""
    try:
        doc = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError, OSError) as e:
        return None, f"not whole JSON: {e}"
    key = doc.get("key") if isinstance(doc, dict) else None
    if not isinstance(key, str) or "result" not in doc:
        return None, "not a unit file (no key and result)"
    if stem_of(key).name != path.stem:
        return key, f"holds unit {key!r} under another unit's name"
    if problem := digest_problem(doc, settings_hash):
        return key, problem
    sha = doc.get("arrays_sha256")
    npz = path.with_suffix(".npz")
    if sha is not None and not npz.is_file():
        return key, f"its arrays {npz.name} are missing"
    if sha is not None and sha256_file(npz) != sha:
        return key, f"its arrays {npz.name} are not the file it was written with"
    return key, None


def held_key(path: Path) -> str | None:
    """The unit key a file starts with (as :meth:`UnitStore.save` writes it, whole or cut
    short after the key), None if it starts otherwise."""
    try:
        text = path.read_text(errors="replace")
    except OSError:
        return None
    found = re.match(r'\{\s*"key":\s*("(?:[^"\\]|\\.)*")', text)
    with contextlib.suppress(json.JSONDecodeError):
        return json.loads(found.group(1)) if found else None
    return None
