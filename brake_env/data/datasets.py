"""Run-to-failure datasets as the paper builds them (paper 2.1.6), as event logs.

Training and in-distribution (ID) test pads draw K ~ N(mu_K, sigma_K^2); the
out-of-distribution (OOD) pads come from means shifted by -6 sigma (slow wear) and +6 sigma
(fast wear). Each run is simulated to failure through the atlas, sensor noise is added, and
the runs are written as event logs (docs/schema.md) with ground-truth columns.
A dataset directory gets a manifest, written last, that :func:`find_logs` checks.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from brake_env.data.schema import SENSOR_CHANNELS, write_event_log
from brake_env.model.atlas import Atlas
from brake_env.model.regime import Label, WearRegime
from brake_env.model.simulator import (
    F64,
    AlternatingRoutes,
    SensorNoise,
    Trajectory,
    simulate_runs,
)
from brake_env.output import Manifest

SPLITS = ("train", "id", "ood")


@dataclass(frozen=True)
class PlannedRun:
    """A run of a dataset before it is simulated.

    Attributes:
        split: ``train``, ``id`` or ``ood``.
        run_id: Its name in the logs (``train-00``, ``ood-slow-03``...).
        wear_coeff: Its Archard coefficient K [-].
    """

    split: str
    run_id: str
    wear_coeff: float


@dataclass(frozen=True, eq=False)
class SimulatedRun:
    """A run of a dataset simulated to failure.

    Attributes:
        split: ``train``, ``id`` or ``ood``.
        run_id: Its name in the logs.
        trajectory: Its ground truth, event by event.
    """

    split: str
    run_id: str
    trajectory: Trajectory


@dataclass(frozen=True)
class DatasetSpec:
    """How many runs of which wear coefficient (paper 2.1.6).

    Attributes:
        n_train: Training runs, in-distribution K.
        n_id: In-distribution test runs.
        n_ood_slow: OOD runs of slow wear (mean K shifted down).
        n_ood_fast: OOD runs of fast wear (mean K shifted up).
        wear: Distribution of K (:class:`~brake_env.model.regime.WearRegime`).
        noise: Sensor noise added to the logged channels.
        interpolate_layers: Blend adjacent atlas layers by volume (paper footnote 1).
        route_block_events: 0 draws each event's conditions independently (the paper);
            N > 0 alternates haul-road and pit blocks of N events (``AlternatingRoutes``).
    """

    n_train: int = 10
    n_id: int = 10
    n_ood_slow: int = 5
    n_ood_fast: int = 5
    wear: WearRegime = field(default_factory=WearRegime)
    noise: SensorNoise = field(default_factory=SensorNoise)
    interpolate_layers: bool = False
    route_block_events: int = 0

    def __post_init__(self) -> None:
        for name in ("n_train", "n_id", "n_ood_slow", "n_ood_fast"):
            n = getattr(self, name)
            if not isinstance(n, int) or n < 0:
                raise ValueError(f"DatasetSpec.{name} must be an int >= 0, got {n!r}")
        if self.n_train + self.n_id + self.n_ood_slow + self.n_ood_fast == 0:
            raise ValueError("DatasetSpec: no runs to simulate (all run counts are 0)")
        if not isinstance(self.route_block_events, int) or self.route_block_events < 0:
            raise ValueError(
                "DatasetSpec.route_block_events must be an int >= 0, got"
                f" {self.route_block_events!r}"
            )
        if self.n_ood_slow:
            self.wear.check_ood()

    @property
    def duty(self) -> AlternatingRoutes | None:
        """The duty cycle of the runs (None: independent conditions)."""
        n = self.route_block_events
        return AlternatingRoutes(n) if n else None

    def plan(self, rng: np.random.Generator) -> list[PlannedRun]:
        """Every run with its K drawn from ``rng``, in the order train, ID, slow and fast OOD."""
        draws: list[tuple[str, str, Label, int]] = [
            ("train", "train", "id", self.n_train),
            ("id", "id", "id", self.n_id),
            ("ood", "ood-slow", "ood-slow", self.n_ood_slow),
            ("ood", "ood-fast", "ood-fast", self.n_ood_fast),
        ]
        runs = []
        for split, prefix, label, n in draws:
            for i, k in enumerate(self.wear.draw(rng, label, n)):
                runs.append(PlannedRun(split, f"{prefix}-{i:02d}", float(k)))
        return runs


@dataclass(frozen=True, eq=False)
class Dataset:
    """Simulated runs, ground truth and logs.

    Attributes:
        runs: Every run simulated, in plan order.
        logs: Split name -> event log (noisy channels plus ground truth).
        simulate_seconds: Wall time of the coupled simulation.
        interpolate_layers: Whether adjacent layers were blended.
        route_block_events: The alternating-route block length (0: independent draws).
        seed: The seed it was simulated with, when known (for the manifest).
        spec: Its specification, when known (for the manifest).
    """

    runs: list[SimulatedRun]
    logs: dict[str, pd.DataFrame]
    simulate_seconds: float
    interpolate_layers: bool = False
    route_block_events: int = 0
    seed: int | None = None
    spec: DatasetSpec | None = None


def measure(
    t: Trajectory,
    noise: SensorNoise,
    rng: np.random.Generator,
    out: dict[str, F64] | None = None,
) -> dict[str, F64]:
    """What the sensors log for each event of ``t``: the true values plus Gaussian noise.

    Channels in schema order (``SENSOR_CHANNELS``), each drawn from ``rng`` in that order
    only when its noise is > 0. Energy and distance are never negative, so noise around a
    small true value is floored at 0. Writes into ``out``'s arrays when given.
    """
    truth = {
        "speed_kmh": (t.speed_mps * 3.6, noise.speed_kmh),
        "mass_kg": (t.mass_kg, noise.mass_kg),
        "slope_rad": (t.slope_rad, noise.slope_rad),
        "energy_j": (t.energy_j, noise.energy_j),
        "temp_c": (t.temp_mean_c, noise.temp_c),
        "stop_dist_m": (t.stop_dist_m, noise.stop_dist_m),
    }
    out = out if out is not None else {k: np.empty(t.n_events) for k in SENSOR_CHANNELS}
    for k, (x, sigma) in truth.items():
        out[k][:] = x
        if sigma > 0:
            out[k] += rng.normal(0.0, sigma, t.n_events)
    np.maximum(out["energy_j"], 0.0, out=out["energy_j"])
    np.maximum(out["stop_dist_m"], 0.0, out=out["stop_dist_m"])
    return out


def event_logs(
    runs: list[tuple[str, Trajectory]], noise: SensorNoise, rngs: list[np.random.Generator]
) -> pd.DataFrame:
    """One event log for several runs: measured channels with noise, and ground truth.

    Columns are filled in place, run after run, and handed to pandas without a copy: the
    logs of a full dataset are several hundred MB.
    """
    sizes = np.array([t.n_events for _, t in runs], dtype=np.int64)
    ends = np.cumsum(sizes)
    total = int(ends[-1]) if sizes.size else 0
    names = (*SENSOR_CHANNELS, "volume_frac", "wear_coeff")  # the float columns
    cols = {k: np.empty(total) for k in names}
    event, rul = np.empty(total, dtype=np.int64), np.empty(total, dtype=np.int64)
    failed = np.zeros(total, dtype=bool)
    for (_, t), rng, end, n in zip(runs, rngs, ends, sizes, strict=True):
        sl = slice(int(end - n), int(end))
        measure(t, noise, rng, out={k: cols[k][sl] for k in SENSOR_CHANNELS})
        cols["volume_frac"][sl] = t.volume_frac
        cols["wear_coeff"][sl] = t.wear_coeff
        event[sl] = np.arange(n)
        rul[sl] = t.rul_events
        failed[int(end) - 1] = True
    run_id = pd.Categorical.from_codes(
        np.repeat(np.arange(len(runs), dtype=np.int32), sizes), pd.Index([rid for rid, _ in runs])
    )
    data = {"run_id": run_id, "event": event}
    data.update((k, cols[k]) for k in SENSOR_CHANNELS)
    data.update(
        volume_frac=cols["volume_frac"],
        wear_coeff=cols["wear_coeff"],
        rul_events=rul,
        failed=failed,
    )
    return pd.DataFrame(data, copy=False)


def seeded_plan(
    spec: DatasetSpec, seed: int
) -> tuple[list[PlannedRun], list[list[np.random.SeedSequence]]]:
    """The runs of ``spec`` with their K, and per run its (conditions, noise) seeds.

    ``SeedSequence(seed)`` spawns one stream for the K draws and one child per run, which
    spawns the run's operating-condition and sensor-noise streams.
    """
    k_seq, runs_seq = np.random.SeedSequence(seed).spawn(2)
    plan = spec.plan(np.random.default_rng(k_seq))
    return plan, [s.spawn(2) for s in runs_seq.spawn(len(plan))]


def make_dataset(
    atlas: Atlas,
    spec: DatasetSpec | None = None,
    seed: int = 0,
    progress: Callable[[int], object] | None = None,
) -> Dataset:
    """Simulate every run of ``spec`` to failure and build its event logs.

    Randomness as :func:`seeded_plan` lays it out: the same seed gives the same data.
    """
    spec = spec or DatasetSpec()
    plan, per_run = seeded_plan(spec, seed)
    t0 = time.perf_counter()
    trajs = simulate_runs(
        atlas,
        [p.wear_coeff for p in plan],
        [c for c, _ in per_run],
        progress,
        spec.interpolate_layers,
        spec.duty,
    )
    sim_s = time.perf_counter() - t0
    runs = [SimulatedRun(p.split, p.run_id, t) for p, t in zip(plan, trajs, strict=True)]
    logs = {}
    for split in SPLITS:
        idx = [i for i, r in enumerate(runs) if r.split == split]
        logs[split] = event_logs(
            [(runs[i].run_id, runs[i].trajectory) for i in idx],
            spec.noise,
            [np.random.default_rng(per_run[i][1]) for i in idx],
        )
    return Dataset(runs, logs, sim_s, spec.interpolate_layers, spec.route_block_events, seed, spec)


# ---------------------------------------------------------------------- files
def write_dataset(
    ds: Dataset,
    out_dir: str | Path,
    formats: tuple[str, ...] = ("parquet", "csv"),
    progress: Callable[[str], object] | None = None,
    meta: dict[str, Any] | None = None,
) -> list[Path]:
    """Write each split as ``{split}.parquet`` / ``{split}.csv`` under ``out_dir``, then
    ``manifest.json`` (:class:`~brake_env.output.Manifest`): per file its split, rows,
    runs, size and SHA-256, with the seed, the spec and ``meta``.

    Every file is written atomically, and the manifest says "incomplete" from before the
    first old file is replaced until the last new one is in place, so a reader refuses a
    directory a killed writer left half old, half new. ``summary.json`` (written by the
    caller after this) is removed as it describes the logs being replaced.
    """
    bad = [f for f in formats if f not in ("parquet", "csv")]
    if bad or not formats:
        raise ValueError(f"unknown format(s) {bad or formats}; valid are ['csv', 'parquet']")
    spec = None if ds.spec is None else dataclasses.asdict(ds.spec)
    manifest = Manifest.begin(out_dir, {"seed": ds.seed, "spec": spec, **(meta or {})})
    (Path(out_dir) / "summary.json").unlink(missing_ok=True)
    paths = []
    for split, df in ds.logs.items():
        runs = int(df["run_id"].nunique()) if "run_id" in df else 0
        for fmt in formats:
            path = write_event_log(df, Path(out_dir) / f"{split}.{fmt}")
            manifest.add(path, split=split, rows=len(df), runs=runs)
            paths.append(path)
            if progress:
                progress(path.name)
    manifest.finish()
    return paths


def find_logs(data_dir: str | Path, splits: tuple[str, ...] = SPLITS) -> dict[str, Path]:
    """``{split}.parquet`` (else ``.csv``) of every split in ``data_dir`` (or of ``splits``;
    ``find_logs(d, ("train",))["train"]`` for the training log alone).

    A directory with a manifest (:func:`write_dataset`) must match it: only the files it
    lists are used, each with its size and checksum. A directory without one holds a
    user's own logs and is taken as it is (docs/schema.md).

    Raises:
        FileNotFoundError: No such directory, or a split without a log.
        ManifestError: A manifest that does not vouch for the files, naming the file.
    """
    d = Path(data_dir)
    if not d.is_dir():
        raise FileNotFoundError(f"data directory {d}: no such directory")
    manifest = Manifest.read(d)
    found, missing = {}, []
    for split in splits:
        names = [f"{split}.parquet", f"{split}.csv"]
        if manifest is not None:  # listed files only (missing ones are named by check)
            names = [n for n in names if n in manifest.files]
        path = next((d / n for n in names if manifest is not None or (d / n).is_file()), None)
        if path is None:
            missing.append(f"{split}.parquet")
        else:
            found[split] = path
    if missing:
        raise FileNotFoundError(
            f"data directory {d}: missing {', '.join(missing)} (or .csv);"
            " write them with brakewear simulate"
        )
    if manifest is not None:
        manifest.check(found.values())
    return found
