"""The "truth" simulator: the nominal simulator with unmodelled effects attached.

"Real" logs for the sim-to-real diagnosis come from here:

- in-event effects change the physics of a braking event, so the truth runs through an
  atlas built with the modified physics (``truth_atlas``, cached in memory by the effects'
  parameters); the nominal model keeps the nominal atlas;
- a between-events effect makes each event's start temperature depend on the previous
  event's peak temperature and the time since it. The start temperature then varies from
  event to event, so the run goes through atlases at several start temperatures (linear in
  between) in a per-event recurrence vectorised across runs
  (:func:`sim2real.effects.carry_over.carry_over_runs`);
- sensor effects transform the logged temperature before the sensor noise is added.

Event times (``time_s``) are always logged: gaps between events are exponential with mean
``TruthSpec.mean_gap_s`` from their own random stream, so the other columns are those of
``brake_env.data.datasets.make_dataset`` for the same seed (bit for bit with no effect).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from brake_env.data.datasets import DatasetSpec, event_logs, seeded_plan
from brake_env.model.atlas import Atlas, AtlasSpec, cached_atlas
from brake_env.model.simulator import F64, Trajectory, simulate_runs
from brake_env.model.wear import WearModel
from sim2real.effects.carry_over import carry_over_runs
from sim2real.effects.interface import Effect, SensorContext, apply_sensor, split_kinds
from sim2real.effects.library import register, registry

_ATLAS_CACHE: dict[str, Atlas] = {}
_CACHE_MAX = 32
# Start temperatures above the nominal one at which carry-over runs read the physics [K].
START_TEMP_STEPS = (0.0, 40.0, 80.0, 160.0)


@dataclass(frozen=True)
class TruthSpec:
    """What the truth simulator produces, beside the effects.

    Attributes:
        dataset: Runs, their wear coefficients and the sensor noise (``brake_env`` spec).
        mean_gap_s: Mean time between the starts of two braking events [s].
    """

    dataset: DatasetSpec = field(default_factory=DatasetSpec)
    mean_gap_s: float = 60.0

    def __post_init__(self) -> None:
        if not self.mean_gap_s > 0:
            raise ValueError(f"TruthSpec.mean_gap_s must be > 0 s, got {self.mean_gap_s}")


def truth_atlas(spec: AtlasSpec, effects: Sequence[Effect]) -> Atlas:
    """The atlas of ``spec`` with the in-event effects' physics, recorded in its spec (and so
    its hash: ``spec.effects``); built once per process, cached on disk as any atlas."""
    inevent = [e for e in effects if e.kind == "in-event" and not e.is_neutral]
    if not inevent:
        return cached_atlas(spec)
    for e in inevent:  # the atlas resolves its effects by name: a user's own class too
        if registry().get(e.name) is not type(e):
            register(type(e))
    with_effects = dataclasses.replace(spec, effects=tuple(e.key for e in inevent))
    key = with_effects.content_hash()
    if key not in _ATLAS_CACHE:
        if len(_ATLAS_CACHE) >= _CACHE_MAX:
            _ATLAS_CACHE.pop(next(iter(_ATLAS_CACHE)))
        _ATLAS_CACHE[key] = cached_atlas(with_effects)
    return _ATLAS_CACHE[key]


def start_temp_atlases(spec: AtlasSpec, effects: Sequence[Effect]) -> list[Atlas]:
    """Atlases of the in-event physics at the start temperatures ``base + START_TEMP_STEPS``."""
    base = spec.model.brake.start_temp_c
    out = []
    for dt in START_TEMP_STEPS:
        brake = dataclasses.replace(spec.model.brake, start_temp_c=base + dt)
        s = dataclasses.replace(spec, model=dataclasses.replace(spec.model, brake=brake))
        out.append(truth_atlas(s, effects))
    return out


def event_times(n_events: int, mean_gap_s: float, rng: np.random.Generator) -> F64:
    """Start time of each event [s]: the first at 0, exponential gaps after it."""
    gaps = rng.exponential(mean_gap_s, max(n_events - 1, 0))
    return np.concatenate([[0.0], np.cumsum(gaps)])


def simulate_truth(
    atlas_spec: AtlasSpec,
    effects: Sequence[Effect],
    spec: TruthSpec | None = None,
    seed: int = 0,
    progress: Callable[[int], object] | None = None,
) -> dict[str, pd.DataFrame]:
    """Run-to-failure event logs (split -> log, as ``make_dataset``) with the effects attached.

    Args:
        atlas_spec: The nominal physics and grid.
        effects: Effects to attach (any mix of kinds; at most one between-events effect).
        spec: Runs, noise and event timing.
        seed: Same seed, same logs; with no effect the logs equal ``make_dataset``'s.
        progress: Called with 1 per atlas layer (with carry-over: with the events simulated).

    With a between-events effect the runs always hold the active layer
    (``spec.dataset.interpolate_layers`` applies to the other runs only).
    """
    spec = spec or TruthSpec()
    kinds = split_kinds(effects)
    plan, per_run = seeded_plan(spec.dataset, seed)
    time_rngs = [
        np.random.default_rng(s) for s in np.random.SeedSequence([seed, 6]).spawn(len(plan))
    ]
    trajs, times, ctxs = _trajectories(
        atlas_spec,
        kinds,
        spec,
        [p.wear_coeff for p in plan],
        [c for c, _ in per_run],
        time_rngs,
        progress=progress,
    )
    if kinds["sensor"]:
        trajs = [
            dataclasses.replace(t, temp_mean_c=apply_sensor(kinds["sensor"], t.temp_mean_c, c))
            for t, c in zip(trajs, ctxs, strict=True)
        ]
    runs = [
        _TruthRun(p.split, p.run_id, t, tm[: t.n_events], np.random.default_rng(noise_seed))
        for p, t, tm, (_, noise_seed) in zip(plan, trajs, times, per_run, strict=True)
    ]
    return {split: _split_log(runs, split, spec) for split in ("train", "id", "ood")}


def _trajectories(
    atlas_spec: AtlasSpec,
    kinds: dict[str, list[Effect]],
    spec: TruthSpec,
    ks: list[float],
    cond_seeds: list[np.random.SeedSequence],
    time_rngs: list[np.random.Generator],
    *,
    progress: Callable[[int], object] | None,
) -> tuple[list[Trajectory], list[F64], list[SensorContext]]:
    """True runs to failure (with carry-over if a between-events effect is not neutral),
    their event times and what a sensor effect needs of each event."""
    history = [e for e in kinds["between-events"] if not e.is_neutral]
    atlas = truth_atlas(atlas_spec, kinds["in-event"])
    k = np.array(ks)
    duty = spec.dataset.duty
    if history:
        times = [
            event_times(_capacity(atlas, kk), spec.mean_gap_s, r)
            for kk, r in zip(k, time_rngs, strict=True)
        ]
        atlases = start_temp_atlases(atlas_spec, kinds["in-event"])
        t_nodes = atlas_spec.model.brake.start_temp_c + np.asarray(START_TEMP_STEPS)
        trajs, ctxs = carry_over_runs(
            atlases, t_nodes, k, cond_seeds, times, history[0], progress=progress, duty=duty
        )
        return trajs, times, ctxs
    trajs = simulate_runs(atlas, k, cond_seeds, progress, spec.dataset.interpolate_layers, duty)
    times = [
        event_times(t.n_events, spec.mean_gap_s, r) for t, r in zip(trajs, time_rngs, strict=True)
    ]
    base_c = atlas_spec.model.brake.start_temp_c
    return trajs, times, [_context(atlas, t, base_c) for t in trajs]


@dataclass(frozen=True, eq=False)
class _TruthRun:
    """One simulated run: its split, name, trajectory, event times and sensor-noise stream."""

    split: str
    run_id: str
    trajectory: Trajectory
    times: F64
    noise_rng: np.random.Generator


def _split_log(runs: list[_TruthRun], split: str, spec: TruthSpec) -> pd.DataFrame:
    """The event log of one split's runs, with the event times as column ``time_s``."""
    mine = [r for r in runs if r.split == split]
    log = event_logs(
        [(r.run_id, r.trajectory) for r in mine], spec.dataset.noise, [r.noise_rng for r in mine]
    )
    log.insert(2, "time_s", np.concatenate([r.times for r in mine]) if mine else np.empty(0))
    return log


def _capacity(atlas: Atlas, k: float) -> int:
    return int(1.3 * float(WearModel.from_atlas(atlas).life(k))) + 1000


def _context(atlas: Atlas, t: Trajectory, base_c: float) -> SensorContext:
    r = atlas.query(
        t.speed_mps,
        t.mass_kg,
        t.slope_rad,
        layer=t.layer.astype(np.intp),
        fields=("temp_peak_c", "stop_time_s"),
    )
    return SensorContext(np.full(t.n_events, base_c), r["temp_peak_c"], r["stop_time_s"])
