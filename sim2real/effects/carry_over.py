"""Thermal carry-over between events: the truth simulator's per-event recurrence.

With a between-events effect, event k's start temperature depends on event k-1's peak
temperature, so a run's events must be simulated in order. All runs advance together, in
blocks of events within each run's current atlas layer:

1. the response of every event of the block at the layer is looked up at once in every
   start-temperature atlas (one gather per atlas);
2. the recurrence runs over the block's events, vectorised across runs: start
   temperature from the previous peak, blend of the two atlases around it, peak;
3. the wear is summed in event order and each run keeps its events up to the one that
   crosses its layer's lower edge; a run that did not cross goes on in the next block.

Layer bookkeeping and wear summation follow
``brake_env.model.simulator_reference.simulate_run_reference``, so with a neutral effect
the runs equal ``simulate_runs``'s bit for bit. Below an atlas's own end of life (hotter
starts fail earlier) its last layer is held.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from brake_env.model.atlas import Atlas
from brake_env.model.simulator import AlternatingRoutes, Trajectory, conditions_from_uniform
from sim2real.effects.grid import GRID_FIELDS
from sim2real.effects.interface import Effect, SensorContext

F64 = NDArray[np.float64]
IDX = NDArray[np.intp]
_FIELDS = GRID_FIELDS  # the fields of the response, in the effect grid's order
_TEMP, _DIST, _WEAR, _PEAK, _TIME = range(len(_FIELDS))


@dataclass(frozen=True, eq=False)
class _Streams:
    """Every run's events as drawn: conditions, grid cells and gaps (runs x capacity)."""

    speed: F64
    mass: F64
    slope: F64
    cell: IDX
    frac: F64  # (3, runs, capacity)
    gaps: F64
    caps: NDArray[np.int64]

    @classmethod
    def draw(
        cls,
        atlas: Atlas,
        seeds: Sequence[np.random.SeedSequence],
        times: list[F64],
        duty: AlternatingRoutes | None,
    ) -> _Streams:
        caps = np.array([len(t) for t in times])
        cap = int(caps.max())
        # The same uniform stream as simulate_runs draws (sequential triples per run).
        u = np.stack([np.random.default_rng(sd).random((cap, 3)) for sd in seeds])
        if duty is not None:
            u = np.stack([duty.apply(x, 0) for x in u])
        gaps = np.stack(
            [np.diff(np.pad(t, (0, cap - len(t)), mode="edge"), prepend=t[0]) for t in times]
        )
        s, m, th = conditions_from_uniform(atlas, u)
        # Every event's grid cell, located once (all atlases share the grid).
        cell, frac = atlas.lookup.locate(s, m, th, clip=False)
        return cls(s, m, th, cell, frac, gaps, caps)


class _Runs:
    """State of the runs: position, layer, volume, wear in the layer, last peak, outputs."""

    def __init__(self, ks: F64, cap: int, base_c: float) -> None:
        n = ks.size
        self.ks = ks
        self.pos = np.zeros(n, dtype=np.int64)  # events done
        self.layer = np.zeros(n, dtype=np.intp)
        self.vol = np.ones(n)
        self.layer_start, self.acc = np.ones(n), np.zeros(n)
        self.peak = np.full(n, base_c)
        self.alive = np.ones(n, dtype=bool)
        self.resp = np.full((n, cap, len(_FIELDS)), np.nan)
        self.vol_col = np.full((n, cap), np.nan)  # volume at the start of each event
        self.t0_col = np.full((n, cap), np.nan)


def carry_over_runs(
    atlases: list[Atlas],
    start_temps: F64,
    ks: F64,
    seeds: Sequence[np.random.SeedSequence],
    times: list[F64],
    effect: Effect,
    *,
    progress: Callable[[int], object] | None = None,
    duty: AlternatingRoutes | None = None,
) -> tuple[list[Trajectory], list[SensorContext]]:
    """Runs to failure whose start temperatures carry over from event to event.

    Args:
        atlases: Atlases of the in-event physics at increasing start temperatures, the
            first at the nominal one (its layers and grid rule the runs).
        start_temps: Their start temperatures [deg C].
        ks: Archard coefficient of each run.
        seeds: One ``SeedSequence`` per run, for its operating conditions.
        times: Each run's event start times [s]; their count bounds its life.
        effect: The between-events effect (``start_temp``).
        progress: Called with the number of events simulated, block by block.
        duty: Order of the operating conditions in time (default: independent draws).
    """
    base = atlases[0]
    streams = _Streams.draw(base, seeds, times, duty)
    runs = _Runs(ks, int(streams.caps.max()), base.spec.model.brake.start_temp_c)
    while runs.alive.any():
        r = np.flatnonzero(runs.alive)
        size = _block_size(base, runs, r)
        table = _block_table(atlases, streams, runs, r, size)
        resp, t0 = _recurrence(table, streams, runs, r, start_temps, effect)
        kept = _advance(base, streams, runs, r, resp, t0)
        if progress:
            progress(kept)
    return _collect(base, streams, runs)


def _block_size(atlas: Atlas, runs: _Runs, r: IDX) -> int:
    """Events per block: about what the slowest run needs to cross its layer."""
    pad_v = atlas.spec.model.brake.pad_volume_m3
    mean_w = atlas.expected("wear_per_k_m3")[runs.layer[r]]
    n_exp = np.maximum(runs.vol[r] - atlas.lower_edges[runs.layer[r]], 0.0) * pad_v
    n_exp = n_exp / (runs.ks[r] * mean_w)
    # A small margin: a run that has not crossed goes on in the next block, while events a
    # run simulates past its crossing are wasted (the loop's cost is per event of a block).
    return int(np.clip(np.ceil(n_exp + 2.0 * np.sqrt(n_exp) + 4.0).max(), 16, 4096))


def _block_table(atlases: list[Atlas], streams: _Streams, runs: _Runs, r: IDX, size: int) -> F64:
    """(atlases, runs, events, fields): the response of the block's events in each atlas at
    the run's current layer (an atlas's last layer below its own end of life)."""
    ev = np.minimum(runs.pos[r][:, None] + np.arange(size), streams.cell.shape[1] - 1)
    cell = streams.cell[r[:, None], ev]
    frac = streams.frac[:, r[:, None], ev]
    out = []
    for a in atlases:
        lay = np.minimum(runs.layer[r], a.n_layers - 1)[:, None]
        out.append(a.lookup.interp_array(_FIELDS, lay, cell, frac))
    return np.stack(out)


def _recurrence(
    table: F64, streams: _Streams, runs: _Runs, r: IDX, start_temps: F64, effect: Effect
) -> tuple[F64, F64]:
    """The block's events in order, all runs at once: (responses (runs, events, fields),
    start temperatures (runs, events)).

    Only the peak temperature feeds the next event, so the loop blends only it; the other
    fields are blended after it, for the whole block at once (the same arithmetic).
    """
    size = table.shape[2]
    ev = np.minimum(runs.pos[r][:, None] + np.arange(size), streams.gaps.shape[1] - 1)
    gaps = streams.gaps[r[:, None], ev]
    fresh = runs.pos[r] == 0  # a pad's first event starts at the nominal temperature
    base = float(start_temps[0])
    t_lo, t_hi, n_t = start_temps[0], start_temps[-1], start_temps.size
    at = np.arange(r.size)
    peaks = table[..., _PEAK]  # (atlases, runs, events)
    t0s, his = np.empty((r.size, size)), np.empty((r.size, size), dtype=np.intp)
    peak = runs.peak[r]
    for b in range(size):
        t0 = np.asarray(effect.start_temp(peak, gaps[:, b], base), dtype=np.float64)
        if b == 0:
            t0 = np.where(fresh, base, t0)
        if t0.shape != r.shape:  # an effect may answer with a scalar
            t0 = np.broadcast_to(t0, r.shape)
        t0 = np.minimum(np.maximum(t0, t_lo), t_hi)  # np.clip, without its Python overhead
        hi = np.minimum(np.maximum(np.searchsorted(start_temps, t0, side="right"), 1), n_t - 1)
        t0s[:, b], his[:, b] = t0, hi
        peak = _blend(start_temps, t0, hi, peaks[hi - 1, at, b], peaks[hi, at, b])
    cols = at[:, None], np.arange(size)
    t0_f = t0s[..., None]
    resp = _blend(start_temps, t0_f, his[..., None], table[(his - 1, *cols)], table[(his, *cols)])
    return resp, t0s


def _blend(start_temps: F64, t0: F64, hi: IDX, lo_v: F64, hi_v: F64) -> F64:
    """Linear in the start temperature between the atlases ``hi - 1`` and ``hi``."""
    w = (t0 - start_temps[hi - 1]) / (start_temps[hi] - start_temps[hi - 1])
    return np.where(w == 0.0, lo_v, (1.0 - w) * lo_v + w * hi_v)


def _advance(atlas: Atlas, streams: _Streams, runs: _Runs, r: IDX, resp: F64, t0: F64) -> int:
    """Keep each run's events up to the one crossing its layer's lower edge, record them,
    and move the run on (next layer, or dead at the end of life). Returns the events kept."""
    pad_v = atlas.spec.model.brake.pad_volume_m3
    lowers = atlas.lower_edges
    size = resp.shape[1]
    dv = runs.ks[r][:, None] * resp[..., _WEAR] / pad_v
    # Volume = layer start - wear accumulated in the layer, summed in event order.
    cum = np.cumsum(np.concatenate([runs.acc[r][:, None], dv], axis=1), axis=1)[:, 1:]
    after = runs.layer_start[r][:, None] - cum
    crossed = after <= lowers[runs.layer[r]][:, None]
    done = crossed.any(axis=1)
    n_keep = np.where(done, np.argmax(crossed, axis=1) + 1, size)
    if np.any(runs.pos[r] + n_keep > streams.caps[r]):
        raise RuntimeError("carry-over run longer than its preallocated event stream")
    i, b = np.nonzero(np.arange(size) < n_keep[:, None])
    row, col = r[i], runs.pos[r][i] + b
    runs.resp[row, col] = resp[i, b]
    runs.t0_col[row, col] = t0[i, b]
    runs.vol_col[row, col] = np.concatenate([runs.vol[r][:, None], after[:, :-1]], axis=1)[i, b]
    at, last = np.arange(r.size), n_keep - 1
    runs.vol[r], runs.acc[r] = after[at, last], cum[at, last]
    runs.peak[r] = resp[at, last, _PEAK]
    runs.pos[r] += n_keep
    dead = done & (runs.vol[r] <= lowers[-1])
    runs.alive[r[dead]] = False
    nxt = r[done & ~dead]  # reaching a level activates its layer
    runs.layer[nxt] = np.searchsorted(-lowers, -runs.vol[nxt], side="right")
    runs.layer_start[nxt], runs.acc[nxt] = runs.vol[nxt], 0.0
    return int(n_keep.sum())


def _collect(
    atlas: Atlas, streams: _Streams, runs: _Runs
) -> tuple[list[Trajectory], list[SensorContext]]:
    pad_v = atlas.spec.model.brake.pad_volume_m3
    trajs, ctxs = [], []
    for i in range(runs.ks.size):
        c = int(runs.pos[i])
        vols = runs.vol_col[i, :c]
        resp = runs.resp[i, :c]
        trajs.append(
            Trajectory(
                wear_coeff=float(runs.ks[i]),
                speed_mps=streams.speed[i, :c].copy(),
                mass_kg=streams.mass[i, :c].copy(),
                slope_rad=streams.slope[i, :c].copy(),
                temp_mean_c=resp[:, _TEMP].copy(),
                stop_dist_m=resp[:, _DIST].copy(),
                wear_frac=runs.ks[i] * resp[:, _WEAR] / pad_v,
                volume_frac=vols.copy(),
                layer=atlas.layer_of(np.maximum(vols, atlas.failure_volume)).astype(np.int16),
                final_volume_frac=float(runs.vol[i]),
            )
        )
        ctxs.append(
            SensorContext(runs.t0_col[i, :c].copy(), resp[:, _PEAK].copy(), resp[:, _TIME].copy())
        )
    return trajs, ctxs
