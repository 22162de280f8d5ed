"""Fitted predictors on disk without pickle (docs/results/prognostics.md).

A saved predictor is a directory of two files:

- ``arrays.npz``: the named numpy arrays of :meth:`Predictor.get_state`, read back with
  ``allow_pickle=False`` (numbers and fixed-width strings only, never Python objects);
- ``predictor.json``: the header, written last: format version, the predictor's registry
  name and seed, the content hash and spec of the atlas it was fitted with, the package
  version, the JSON settings of ``get_state`` and the SHA-256 of ``arrays.npz``.

Each file goes to a temporary name in the directory and is renamed into place
(:func:`brake_env.output.atomic_path`), and the
header names the bytes of the arrays it belongs to, so a model directory whose writing was
cut off, or that mixes the files of two fits, is refused instead of read. Loading checks the
format version and that the atlas given is the one the predictor was fitted with, then
rebuilds the predictor from the registry (:func:`~brake_env.prognostics.registry.make_predictor`)
and restores its state.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import numpy as np

from brake_env.model.atlas import Atlas, AtlasSpec, cached_atlas
from brake_env.output import PLAIN_KINDS, read_arrays, write_arrays, write_text
from brake_env.prognostics.protocol import Predictor
from brake_env.prognostics.registry import make_predictor
from brake_env.saved import SavedFormat, read_saved_header

FORMAT = "brakewear-predictor"
FORMAT_VERSION = 1
HEADER = "predictor.json"
ARRAYS = "arrays.npz"
SAVED = SavedFormat(
    "model",
    "predictor",
    HEADER,
    FORMAT,
    FORMAT_VERSION,
    ("predictor", "atlas_hash", "arrays_sha256", "meta"),
)


def package_version() -> str:
    """The installed brakewear version, or ``unknown`` when run from a bare checkout."""
    try:
        return version("brakewear")
    except PackageNotFoundError:
        return "unknown"


def save_predictor(
    predictor: Predictor,
    path: str | os.PathLike[str],
    atlas: Atlas,
    *,
    seed: int = 0,
    info: Mapping[str, Any] | None = None,
) -> Path:
    """Save a fitted predictor under directory ``path`` (created if needed).

    Args:
        predictor: A fitted predictor whose class implements ``get_state``.
        path: The model directory.
        atlas: The atlas the predictor was made and fitted with.
        seed: The seed it was made with (``make_predictor``'s).
        info: Anything JSON-able to keep beside, e.g. what it was fitted on.

    Returns:
        ``path``.

    Raises:
        NotImplementedError: The predictor cannot be saved.
        ValueError: Its state is not JSON settings and plain numeric arrays.
    """
    path = Path(path)
    meta, arrays = predictor.get_state()
    for k, a in arrays.items():
        if not isinstance(a, np.ndarray) or a.dtype.kind not in PLAIN_KINDS:
            what = a.dtype if isinstance(a, np.ndarray) else type(a).__name__
            raise ValueError(
                f"{predictor.name}: state array {k!r} is {what}; only numeric or text numpy"
                " arrays are saved (no pickled objects)"
            )
    header = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "predictor": predictor.name,
        "seed": int(seed),
        "atlas_hash": atlas.content_hash,
        "atlas_spec": atlas.spec.to_dict(),
        "package_version": package_version(),
        "arrays_sha256": "",
        "meta": _encode(dict(meta)),
        "info": _encode(dict(info or {})),
    }
    try:
        json.dumps(header, allow_nan=False)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{predictor.name}: state settings are not JSON ({e})") from None
    if path.exists() and not path.is_dir():
        raise ValueError(f"{path}: exists and is not a directory; a model is a directory")
    path.mkdir(parents=True, exist_ok=True)
    header["arrays_sha256"] = write_arrays(dict(arrays), path / ARRAYS, compress=True)
    text = json.dumps(header, indent=2, allow_nan=False) + "\n"
    write_text(text, path / HEADER)  # last: it vouches for the arrays
    return path


def read_header(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The checked header of a saved predictor: cheap, reads no arrays.

    Raises:
        FileNotFoundError: No model directory or header at ``path``.
        ValueError: Not a brakewear predictor, or a format this version does not read.
    """
    path = Path(path)
    if not path.is_dir():
        raise FileNotFoundError(f"model {path}: no such directory (write one with brakewear fit)")
    return read_saved_header(path, SAVED, " (not a model, or its fit was cut off)")


def check_atlas(header: Mapping[str, Any], atlas_hash: str, path: str | os.PathLike[str]) -> None:
    """Raise ValueError naming both hashes unless the model was fitted with this atlas."""
    if header["atlas_hash"] != atlas_hash:
        raise ValueError(
            f"model {path} was fitted with atlas {header['atlas_hash'][:16]}, the atlas given"
            f" is {atlas_hash[:16]}: predict with the fit's atlas (its --atlas file or preset)"
        )


def model_atlas(
    header: Mapping[str, Any], cache_dir: str | os.PathLike[str] | None = None
) -> Atlas:
    """The atlas a saved model was fitted on, rebuilt from the spec its header records (its
    effects included) through the cache, and checked against the recorded hash."""
    spec = AtlasSpec.from_dict(header.get("atlas_spec") or {})
    check_atlas(header, spec.content_hash(), "with that header")
    return cached_atlas(spec, cache_dir)


def load_predictor(path: str | os.PathLike[str], atlas: Atlas | None = None) -> Predictor:
    """A predictor saved by :func:`save_predictor`, ready to ``reset`` and ``update``; on its
    own atlas (:func:`model_atlas`) unless ``atlas`` is given, which must be that one.

    Raises:
        FileNotFoundError: No model at ``path``.
        ValueError: Another format version, another atlas, arrays that are not the ones
            the header was written with, or an unknown predictor name.
    """
    path = Path(path)
    header = read_header(path)
    atlas = atlas if atlas is not None else model_atlas(header)
    check_atlas(header, atlas.content_hash, path)
    arrays = read_arrays(path / ARRAYS, str(header["arrays_sha256"]), f"model {path}")
    name = str(header["predictor"])
    predictor = make_predictor(name, atlas, int(header.get("seed", 0)))
    try:
        predictor.set_state(_decode(header["meta"]), arrays)
    except (ValueError, KeyError, TypeError, AttributeError, IndexError) as e:
        # Each predictor checks its own schema; the others' lookups are the safety net.
        raise ValueError(
            f"model {path}: {HEADER} names predictor {name!r}, and the saved state does not"
            f" fit it: {e if isinstance(e, ValueError) else repr(e)}"
        ) from None
    return predictor


# Standard JSON has no inf or NaN; settings may hold them (a Gaussian prior has dof inf).
_NONFINITE = "$float"


def _encode(x: Any) -> Any:
    if isinstance(x, float) and not math.isfinite(x):
        return {_NONFINITE: repr(x)}
    if isinstance(x, dict):
        return {str(k): _encode(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_encode(v) for v in x]
    if isinstance(x, np.generic):
        return _encode(x.item())
    return x


def _decode(x: Any) -> Any:
    if isinstance(x, dict):
        if set(x) == {_NONFINITE}:
            return float(x[_NONFINITE])
        return {k: _decode(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_decode(v) for v in x]
    return x
