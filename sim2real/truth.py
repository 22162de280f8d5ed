"""The "truth" simulator: the nominal simulator with unmodelled effects attached (issue 6).

- in-event effects change the physics of a braking event, so the truth runs through an
  atlas built with the modified physics (``truth_atlas``, cached in memory by the effects'
  parameters); the nominal model keeps the nominal atlas;
- a between-events effect makes each event's start temperature depend on the previous
  event's peak temperature and the time since it. The start temperature then varies from
  event to event, so the run goes through atlases at several start temperatures (linear in
  between) in a per-event recurrence vectorised across runs (``_carry_over_runs``), which
  follows ``brake_env.model.simulator.simulate_run_reference`` step for step;
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
from numpy.typing import NDArray

from brake_env.data.datasets import DatasetSpec, event_logs, seeded_plan
from brake_env.model.atlas import Atlas, AtlasSpec, cached_atlas
from brake_env.model.simulator import (
    F64,
    AlternatingRoutes,
    Trajectory,
    conditions_from_uniform,
    simulate_runs,
)
from brake_env.model.wear import WearModel
from sim2real.effects import (
    Effect,
    InEventPhysics,
    SensorContext,
    apply_sensor,
    effects_key,
    split_kinds,
)

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
    """The atlas of ``spec`` with the in-event effects' physics (nominal: ``cached_atlas``)."""
    inevent = [e for e in effects if e.kind == "in-event" and not e.is_neutral]
    if not inevent:
        return cached_atlas(spec)
    key = f"{spec.content_hash()}|{effects_key(inevent)}"
    if key not in _ATLAS_CACHE:
        if len(_ATLAS_CACHE) >= _CACHE_MAX:
            _ATLAS_CACHE.pop(next(iter(_ATLAS_CACHE)))
        _ATLAS_CACHE[key] = Atlas.build(spec, modifier=InEventPhysics(inevent, spec.model))
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
        progress: Called with 1 per atlas layer (or per 1000 events with carry-over).

    With a between-events effect the runs always hold the active layer
    (``spec.dataset.interpolate_layers`` applies to the other runs only).
    """
    spec = spec or TruthSpec()
    kinds = split_kinds(effects)
    plan, per_run = seeded_plan(spec.dataset, seed)
    ks = np.array([k for _, _, k in plan])
    cond_seeds = [c for c, _ in per_run]
    history = [e for e in kinds["between-events"] if not e.is_neutral]
    atlas = truth_atlas(atlas_spec, kinds["in-event"])
    time_rngs = [
        np.random.default_rng(s) for s in np.random.SeedSequence([seed, 6]).spawn(len(plan))
    ]
    if history:
        times = [
            event_times(_capacity(atlas, k), spec.mean_gap_s, r)
            for k, r in zip(ks, time_rngs, strict=True)
        ]
        atlases = start_temp_atlases(atlas_spec, kinds["in-event"])
        trajs, ctxs = _carry_over_runs(
            atlases, ks, cond_seeds, times, history[0], progress, spec.dataset.duty
        )
    else:
        trajs = simulate_runs(
            atlas, ks, cond_seeds, progress, spec.dataset.interpolate_layers, spec.dataset.duty
        )
        times = [
            event_times(t.n_events, spec.mean_gap_s, r)
            for t, r in zip(trajs, time_rngs, strict=True)
        ]
        ctxs = [_context(atlas, t, atlas_spec.model.brake.start_temp_c) for t in trajs]
    if kinds["sensor"]:
        trajs = [
            dataclasses.replace(t, temp_mean_c=apply_sensor(kinds["sensor"], t.temp_mean_c, c))
            for t, c in zip(trajs, ctxs, strict=True)
        ]
    runs = [(split, rid, t) for (split, rid, _), t in zip(plan, trajs, strict=True)]
    logs = {}
    for split in ("train", "id", "ood"):
        idx = [i for i, r in enumerate(runs) if r[0] == split]
        log = event_logs(
            [(runs[i][1], runs[i][2]) for i in idx],
            spec.dataset.noise,
            [np.random.default_rng(per_run[i][1]) for i in idx],
        )
        t_col = [times[i][: runs[i][2].n_events] for i in idx]
        log.insert(2, "time_s", np.concatenate(t_col) if t_col else np.empty(0))
        logs[split] = log
    return logs


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


_FIELDS = ("temp_mean_c", "stop_dist_m", "wear_per_k_m3", "temp_peak_c", "stop_time_s")


def _carry_over_runs(
    atlases: list[Atlas],
    ks: F64,
    seeds: Sequence[np.random.SeedSequence],
    times: list[F64],
    effect: Effect,
    progress: Callable[[int], object] | None,
    duty: AlternatingRoutes | None = None,
) -> tuple[list[Trajectory], list[SensorContext]]:
    """Runs to failure whose start temperatures carry over from event to event.

    A per-event recurrence, vectorised across runs: event k's start temperature needs event
    k-1's peak. Layer bookkeeping and wear summation follow ``simulate_run_reference``, so
    with a neutral effect the runs equal ``simulate_runs``'s bit for bit. Below an atlas's
    own end of life (hotter starts fail earlier) its last layer is held.
    """
    base_atlas = atlases[0]
    base = base_atlas.spec.model.brake.start_temp_c
    t_nodes = base + np.asarray(START_TEMP_STEPS)
    pad_v = base_atlas.spec.model.brake.pad_volume_m3
    lowers = base_atlas.lower_edges
    n = ks.size
    caps = np.array([len(t) for t in times])
    cap = int(caps.max())
    # The same uniform stream as simulate_runs draws (sequential triples per run).
    u = np.stack([np.random.default_rng(sd).random((cap, 3)) for sd in seeds])
    if duty is not None:
        u = np.stack([duty.apply(x, 0) for x in u])
    gaps = np.stack(
        [np.diff(np.pad(t, (0, cap - len(t)), mode="edge"), prepend=t[0]) for t in times]
    )
    s_all, m_all, th_all = conditions_from_uniform(base_atlas, u)
    # Every event's grid cell, located once (all atlases share the grid); the loop then only
    # gathers table rows. Uses the atlas's own cell tables and its interpolation order, so
    # a neutral effect reproduces simulate_runs bit for bit.
    cell, frac = base_atlas.lookup.locate(s_all, m_all, th_all, False)
    tables = [a.lookup.corner_table(_FIELDS) for a in atlases]
    n_cells = tables[0].shape[1]
    flat = [t.reshape(-1, *t.shape[2:]) for t in tables]
    cols = {f: np.full((n, cap), np.nan) for f in (*_FIELDS, "vol", "t0")}
    layer = np.zeros(n, dtype=np.intp)
    vol = np.ones(n)
    layer_start, acc = np.ones(n), np.zeros(n)
    prev_peak = np.full(n, base)
    alive = np.ones(n, dtype=bool)
    n_ev = np.zeros(n, dtype=np.int64)
    k = 0
    while alive.any():
        r = np.flatnonzero(alive)
        if np.any(k >= caps[r]):
            raise RuntimeError("carry-over run longer than its preallocated event stream")
        t0 = base if k == 0 else effect.start_temp(prev_peak[r], gaps[r, k], base)
        t0 = np.clip(
            np.broadcast_to(np.asarray(t0, dtype=np.float64), r.shape), t_nodes[0], t_nodes[-1]
        )
        hi = np.clip(np.searchsorted(t_nodes, t0, side="right"), 1, t_nodes.size - 1)
        w = (t0 - t_nodes[hi - 1]) / (t_nodes[hi] - t_nodes[hi - 1])
        fs, fm, ft = (x[r, k][:, None] for x in frac)
        c_k = cell[r, k]

        def lookup(
            a_idx: NDArray[np.intp],
            r: NDArray[np.intp] = r,
            c_k: NDArray[np.intp] = c_k,
            fs: F64 = fs,
            fm: F64 = fm,
            ft: F64 = ft,
        ) -> F64:
            out = np.empty((r.size, len(_FIELDS)))
            for a_i in np.unique(a_idx):
                sel = a_idx == a_i
                lay = np.minimum(layer[r[sel]], atlases[a_i].n_layers - 1)
                g = flat[a_i][lay * n_cells + c_k[sel]]
                gs = 1.0 - ft[sel]
                c = [gs * g[..., 2 * i] + ft[sel] * g[..., 2 * i + 1] for i in range(4)]
                gm = 1.0 - fm[sel]
                c0, c1 = gm * c[0] + fm[sel] * c[1], gm * c[2] + fm[sel] * c[3]
                out[sel] = (1.0 - fs[sel]) * c0 + fs[sel] * c1
            return out

        lo_v, hi_v = lookup(hi - 1), lookup(hi)
        resp_arr = np.where(w[:, None] == 0.0, lo_v, (1.0 - w[:, None]) * lo_v + w[:, None] * hi_v)
        resp = {f: resp_arr[:, i] for i, f in enumerate(_FIELDS)}
        dv = ks[r] * resp["wear_per_k_m3"] / pad_v
        for f in _FIELDS:
            cols[f][r, k] = resp[f]
        cols["vol"][r, k], cols["t0"][r, k] = vol[r], t0
        acc[r] += dv
        after = layer_start[r] - acc[r]
        prev_peak[r] = resp["temp_peak_c"]
        vol[r] = after
        n_ev[r] += 1
        crossed = after <= lowers[layer[r]]
        for i in r[crossed]:
            if vol[i] <= lowers[-1]:
                alive[i] = False
                continue
            while vol[i] <= lowers[layer[i]]:
                layer[i] += 1
            layer_start[i], acc[i] = vol[i], 0.0
        k += 1
        if progress and k % 1000 == 0:
            progress(1000)
    trajs, ctxs = [], []
    for i in range(n):
        c = int(n_ev[i])
        vols = cols["vol"][i, :c]
        lay = base_atlas.layer_of(np.maximum(vols, base_atlas.failure_volume)).astype(np.int16)
        trajs.append(
            Trajectory(
                wear_coeff=float(ks[i]),
                speed_mps=s_all[i, :c].copy(),
                mass_kg=m_all[i, :c].copy(),
                slope_rad=th_all[i, :c].copy(),
                temp_mean_c=cols["temp_mean_c"][i, :c].copy(),
                stop_dist_m=cols["stop_dist_m"][i, :c].copy(),
                wear_frac=ks[i] * cols["wear_per_k_m3"][i, :c] / pad_v,
                volume_frac=vols.copy(),
                layer=lay,
                final_volume_frac=float(vol[i]),
            )
        )
        ctxs.append(
            SensorContext(
                cols["t0"][i, :c].copy(),
                cols["temp_peak_c"][i, :c].copy(),
                cols["stop_time_s"][i, :c].copy(),
            )
        )
    return trajs, ctxs
