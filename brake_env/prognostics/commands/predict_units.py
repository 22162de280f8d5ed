"""``brakewear predict`` as independent units (docs/cluster.md, docs/results/prognostics.md).

The pads of a fleet log are cut, in order of first appearance, into chunks of
``pads_per_unit``; each chunk is one :class:`~brake_env.runner.Unit` that runs the saved
predictor's fleet over its pads' events (:func:`~brake_env.prognostics.fleet.predict_runs`)
and returns each pad's table row and its estimate after every event. A unit's result
depends on its pads and the model alone, so it is the same in this process and on Ray, and
a run that was cut off resumes from the chunks already saved. The chunking is part of the
results' identity: a fleet's estimates equal the single-pad predictor's to rounding only
(:mod:`~brake_env.prognostics.fleet`), so another chunking may move them by ~1e-13.

The model travels as its saved state (:class:`SavedModel`, no pickle on disk) and each
process rebuilds the predictor once (the twin builds its grid in ~1 s), not once per unit.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from brake_env.model.atlas import Atlas
from brake_env.output import sha256_file
from brake_env.prognostics.fleet import ESTIMATE_FIELDS, predict_runs
from brake_env.prognostics.persist import HEADER, package_version
from brake_env.prognostics.protocol import EventBatch, Predictor
from brake_env.prognostics.registry import make_predictor
from brake_env.runner import Runner, Unit
from brake_env.units import UnitStore

PADS_PER_UNIT = 8  # pads per unit: enough units to keep 2+ workers busy, few files
RESULT_FORMAT = 1  # layout of a unit's result; a store of another layout is refused


@dataclass(frozen=True, eq=False)
class SavedModel:
    """A fitted predictor as the units receive it.

    Attributes:
        name: Registry name (``make_predictor``'s).
        seed: The seed it was made with.
        meta: JSON settings of ``get_state``.
        arrays: Named arrays of ``get_state``.
        checksum: SHA-256 of the model's header (which names its arrays' SHA-256).
    """

    name: str
    seed: int
    meta: Mapping[str, Any]
    arrays: Mapping[str, NDArray[Any]]
    checksum: str

    @classmethod
    def of(
        cls, pred: Predictor, model_dir: str | Path, header: Mapping[str, Any], atlas: Atlas
    ) -> SavedModel:
        """The state of ``pred``, loaded from ``model_dir`` (its header ``header``) with
        ``atlas``; ``pred`` is remembered as this process's predictor of that model."""
        meta, arrays = pred.get_state()
        model = cls(pred.name, int(header.get("seed", 0)), meta, arrays, model_checksum(model_dir))
        _LOADED.clear()
        _LOADED[f"{model.checksum}:{atlas.content_hash}"] = pred
        return model

    def predictor(self, atlas: Atlas) -> Predictor:
        """The fitted predictor, rebuilt once per process (and per atlas)."""
        key = f"{self.checksum}:{atlas.content_hash}"
        if key not in _LOADED:
            pred = make_predictor(self.name, atlas, self.seed)
            pred.set_state(self.meta, self.arrays)
            _LOADED.clear()  # one model at a time: a worker may run many predicts
            _LOADED[key] = pred
        return _LOADED[key]


# This process's predictor of the model being run: units reuse it instead of rebuilding.
_LOADED: dict[str, Predictor] = {}


def forget() -> None:
    """Drop this process's remembered predictor (the command is done with it)."""
    _LOADED.clear()


def model_checksum(model_dir: str | Path) -> str:
    """SHA-256 of a model directory's header (it holds its arrays' SHA-256)."""
    return hashlib.sha256((Path(model_dir) / HEADER).read_bytes()).hexdigest()


def predict_pads(
    model: SavedModel, atlas: Atlas, runs: Sequence[tuple[str, EventBatch]]
) -> dict[str, Any]:
    """One unit: the pads ``runs`` through the model's fleet.

    Returns:
        ``pads``: per pad ``run_id``, ``events_logged``, ``first_event``,
        ``events_since_install`` and the estimate at its last event; ``traces``: ``event``
        and the estimate's columns at every event, pad after pad.
    """
    ests = predict_runs(model.predictor(atlas), [ev for _, ev in runs])
    sizes = np.array([len(ev) for _, ev in runs], dtype=np.int64)
    event = np.concatenate([ev.event for _, ev in runs])
    given = [f for f in ESTIMATE_FIELDS if all(getattr(e, f) is not None for e in ests)]
    cols = {f: np.concatenate([getattr(e, f) for e in ests]) for f in given}
    last = np.cumsum(sizes) - 1
    pads = {
        "run_id": [r for r, _ in runs],
        "events_logged": sizes,
        "first_event": event[last - sizes + 1],
        "events_since_install": event[last] + 1,
        **{f: c[last] for f, c in cols.items()},
    }
    return {"pads": pads, "traces": {"event": event, **cols}}


def pad_units(
    model: Any, atlas: Any, runs: Sequence[tuple[str, EventBatch]], pads_per_unit: int
) -> list[Unit]:
    """The units of a fleet: ``pads-0000``, ``pads-0001``... (:func:`unit_keys`) of
    ``pads_per_unit`` pads each, in order; ``model`` and ``atlas`` as :meth:`Runner.share`
    gave them."""
    keys = unit_keys(len(runs), pads_per_unit)
    starts = range(0, len(runs), pads_per_unit)
    return [
        Unit(key, predict_pads, (model, atlas, list(runs[a : a + pads_per_unit])))
        for key, a in zip(keys, starts, strict=True)
    ]


def unit_keys(n_pads: int, pads_per_unit: int) -> list[str]:
    """The keys of a fleet's units: ``pads-0000``, ``pads-0001``..., one per
    ``pads_per_unit`` pads."""
    if pads_per_unit < 1:
        raise ValueError(f"pads per unit must be >= 1, got {pads_per_unit}")
    n = len(range(0, n_pads, pads_per_unit))
    width = max(4, len(str(n - 1)))
    return [f"pads-{i:0{width}d}" for i in range(n)]


def store_settings(
    model_dir: str | Path, log_path: str | Path, atlas_hash: str, n_pads: int, pads_per_unit: int
) -> dict[str, Any]:
    """What a predict's units depend on: a store of other settings is refused."""
    log = Path(log_path)
    return {
        "command": "predict",
        "model_sha256": model_checksum(model_dir),
        "log_sha256": sha256_file(log),
        "log_bytes": log.stat().st_size,
        "atlas_hash": atlas_hash,
        "pads": n_pads,
        "pads_per_unit": pads_per_unit,
        "package_version": package_version(),
        "result_format": RESULT_FORMAT,
    }


def run_pads(
    runner: Runner,
    units: Sequence[Unit],
    store: UnitStore | None,
    progress: Callable[[int], object] | None = None,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Run (or read back) every unit; (traces, fleet table), the table not yet sorted and
    without ``missing_channels``."""

    def tick(_key: str, result: Any) -> None:
        if progress:
            progress(int(np.sum(result["pads"]["events_logged"])))

    results = list(runner.run(units, store, tick).values())
    return merge(results)


def merge(results: Sequence[Mapping[str, Any]]) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The units' results, in order, as one fleet: (traces, per-pad table)."""
    runs = [str(r) for res in results for r in res["pads"]["run_id"]]
    sizes = np.concatenate([res["pads"]["events_logged"] for res in results])
    given = [f for f in ESTIMATE_FIELDS if all(f in res["traces"] for res in results)]

    def cat(part: str, col: str) -> NDArray[Any]:
        return np.concatenate([res[part][col] for res in results])

    codes = np.repeat(np.arange(len(runs)), sizes)
    traces = pd.DataFrame(
        {
            "run_id": pd.Categorical.from_codes(codes, pd.Index(runs)),
            "event": cat("traces", "event"),
        }
    )
    for f in given:
        traces[f] = cat("traces", f)
    fleet = pd.DataFrame(
        {
            "run_id": pd.Index(runs).astype(str),
            "events_logged": sizes,
            "first_event": cat("pads", "first_event"),
            "events_since_install": cat("pads", "events_since_install"),
        }
    )
    for f in given:
        fleet[f] = cat("pads", f)
    return traces, fleet


def sort_table(rows: pd.DataFrame, missing: dict[str, list[str]]) -> pd.DataFrame:
    """Per-pad rows with their ``missing_channels``, sorted by RUL (most urgent first; ties
    in log order)."""
    rows = rows.copy()
    rows["missing_channels"] = [";".join(missing.get(r, [])) for r in rows["run_id"]]
    return rows.sort_values("rul_mean", kind="stable").reset_index(drop=True)
