"""The fleet's pads: one streamed pad per vehicle, all advanced together a shift at a time.

This is BrakeWear-v0's pad life (:mod:`brake_env.env.pad_life`) on arrays over vehicles.
Each pad has the streams a BrakeWear-v0 pad has (``SeedSequence(entropy).spawn(2)``: one
generator of uniform condition triples, one generator per sensor channel) and walks the
atlas layers with the simulator's rules (:class:`brake_env.model.simulator.Runs`: the wear
of a layer accumulated from where the pad entered it, the layer left after the event that
crosses its lower edge, end of life below the last). Only the mapping of the uniform
triples differs: each vehicle's triples go to its route's box. On the uniform route a
vehicle's events are bit for bit those of a BrakeWear-v0 pad of the same streams (tested).

A shift is one pass through the atlas for the whole fleet, plus one more for the vehicles
whose pad crossed a layer edge in it (a pad crosses a 1% layer every few shifts). The
streams are drawn into per-vehicle buffers of ``capacity`` events, refilled when a shift
needs more than is left: a vehicle costs the same memory whatever the episode's length.
"""

from __future__ import annotations

import copy
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from brake_env.env.fleet.routes import ROUTES, route_table
from brake_env.model.atlas import Atlas
from brake_env.model.simulator import check_wear_per_event
from brake_env.model.streams import SENSOR_CHANNELS, SensorNoise

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
RESPONSE = ("temp_mean_c", "stop_dist_m", "wear_per_k_m3")
N_CH = len(SENSOR_CHANNELS)


class ShiftEvents(NamedTuple):
    """What the fleet braked in one call of :meth:`FleetPads.advance`.

    ``measured`` (channels, vehicles, events) in ``SENSOR_CHANNELS`` order and
    ``volume_frac`` (vehicles, events, at the start of each event) are valid where
    ``valid`` is; ``first_event`` is each pad's age before the shift, so its events are
    ``first_event + 0, 1, ...``; ``n_done`` counts each vehicle's events, ``failed``
    marks the pads that reached their end of life with events still to brake, and
    ``wear_coeff`` is the K of the pads that braked them.
    """

    measured: F64 | None
    volume_frac: F64
    valid: NDArray[np.bool_]
    first_event: I64
    n_done: I64
    failed: NDArray[np.bool_]
    wear_coeff: F64


class FleetPads:
    """The installed pad of each of ``n`` vehicles and its random streams.

    Args:
        atlas: The atlas.
        n: Number of vehicles.
        noise: Sensor noise of the channels.
        capacity: Events of stream buffered per vehicle (>= the largest shift).
    """

    def __init__(self, atlas: Atlas, n: int, noise: SensorNoise, capacity: int) -> None:
        self.atlas, self.n, self.capacity = atlas, n, capacity
        self.sigmas = np.array([float(getattr(noise, c)) for c in SENSOR_CHANNELS])
        self.edges = atlas.lower_edges
        self.pad_v = atlas.spec.model.brake.pad_volume_m3
        self.low, self.span = route_table(atlas, ROUTES)
        self.k = np.zeros(n)
        self.label = np.array(["id"] * n, dtype=object)
        self.serial = np.zeros(n, dtype=np.int64)  # pads installed on each vehicle so far
        self.pos = np.zeros(n, dtype=np.int64)  # events the pad has braked
        self.vol, self.start, self.acc = np.ones(n), np.ones(n), np.zeros(n)
        self.layer = np.zeros(n, dtype=np.int64)
        self.done = np.zeros(n, dtype=bool)  # end of life reached
        self._u = np.zeros((n, capacity, 3))  # buffered uniform triples (0 until drawn)
        # 0 until drawn: a round reads past a short row's draws (discarded), never garbage
        self._z = np.zeros((n, N_CH, capacity))  # buffered standard normals
        self._cur = np.zeros(n, dtype=np.int64)  # next unused buffer column
        self._have = np.zeros(n, dtype=np.int64)  # filled buffer columns
        self._cond: list[np.random.Generator | None] = [None] * n
        self._noise: list[list[np.random.Generator | None]] = [[None] * N_CH for _ in range(n)]

    # ------------------------------------------------------------------ installation
    def install(self, v: int, wear_coeff: float, label: str, entropy: int) -> None:
        """A new pad on vehicle ``v``: K, wear regime and the entropy of its streams (as
        a BrakeWear-v0 pad: :class:`~brake_env.env.pad_life.PadLife`)."""
        check_wear_per_event(self.atlas, wear_coeff)
        cond_seed, noise_seed = np.random.SeedSequence(entropy).spawn(2)
        self._cond[v] = np.random.default_rng(cond_seed)
        self._noise[v] = [
            np.random.default_rng(s) if sigma > 0 else None
            for s, sigma in zip(noise_seed.spawn(N_CH), self.sigmas, strict=True)
        ]
        self.k[v], self.label[v] = wear_coeff, label
        self.serial[v] += 1
        self.pos[v], self.layer[v], self.done[v] = 0, 0, False
        self.vol[v], self.start[v], self.acc[v] = 1.0, 1.0, 0.0
        self._cur[v] = self._have[v] = 0

    def start_at(self, age: NDArray[Any], volume: F64) -> None:
        """Put each installed pad ``age`` events into its life at ``volume`` (the fleet's
        first pads, in service before the episode). Its streams start at that event."""
        self.pos[:] = age
        self.vol[:] = volume
        self.start[:], self.acc[:] = volume, 0.0
        band = (self.edges[None, :] >= self.vol[:, None]).sum(axis=1)
        self.done[:] = band >= self.edges.size
        self.layer[:] = np.minimum(band, self.edges.size - 1)

    def clone(self) -> FleetPads:
        """An independent copy in the same state (the atlas shared): for simulating ahead."""
        new = copy.copy(self)
        for name in ("k", "pos", "vol", "start", "acc", "layer", "done", "_u", "_z"):
            setattr(new, name, getattr(self, name).copy())
        new._cur, new._have = self._cur.copy(), self._have.copy()
        new.serial, new.label = self.serial.copy(), self.label.copy()
        new._cond = copy.deepcopy(self._cond)
        new._noise = copy.deepcopy(self._noise)
        return new

    # ------------------------------------------------------------------ streams
    def _ensure(self, need: I64) -> None:
        """Each vehicle's buffers hold its next ``need`` events (refilled where short, by a
        quarter of the capacity at least: a new pad's buffer starts empty, so a pad
        replaced early wastes few draws)."""
        short = np.flatnonzero(self._cur + need > self._have)
        for v in short:  # amortised: a vehicle refills every few shifts
            cur, have = int(self._cur[v]), int(self._have[v])
            left = have - cur
            upto = min(self.capacity, left + max(int(need[v]), self.capacity // 4))
            self._u[v, :left] = self._u[v, cur:have]
            self._z[v, :, :left] = self._z[v, :, cur:have]
            rng = self._cond[v]
            if rng is None:
                raise RuntimeError(f"FleetPads: vehicle {v} has no pad installed")
            rng.random(out=self._u[v, left:upto])
            for c, g in enumerate(self._noise[v]):
                if g is not None:
                    g.standard_normal(out=self._z[v, c, left:upto])
            self._cur[v], self._have[v] = 0, upto

    # ------------------------------------------------------------------ a shift
    def advance(self, n_events: I64, route: I64, measure: bool = True) -> ShiftEvents:
        """Brake ``n_events[v]`` events of each vehicle on route ``route[v]`` (indices
        into :data:`~brake_env.env.fleet.routes.ROUTES`), at most ``capacity`` each; a pad
        at its end of life stops there (``failed``)."""
        n_events = np.asarray(n_events, dtype=np.int64)
        if np.any(n_events > self.capacity) or np.any(n_events < 0):
            raise ValueError(f"FleetPads.advance: 0 to {self.capacity} events per vehicle")
        width = max(int(n_events.max(initial=0)), 1)
        out_m = np.zeros((N_CH, self.n, width)) if measure else None
        out_v = np.zeros((self.n, width))
        valid = np.zeros((self.n, width), dtype=bool)
        first, done_n = self.pos.copy(), np.zeros(self.n, dtype=np.int64)
        self._ensure(np.where(self.done, 0, n_events))
        active = (n_events > 0) & ~self.done
        while active.any():
            rows = np.flatnonzero(active)
            self._round(
                rows, n_events[rows] - done_n[rows], route[rows], done_n,
                out_m=out_m, out_v=out_v, valid=valid,
            )  # fmt: skip
            active = (done_n < n_events) & ~self.done
        failed = (done_n < n_events) & self.done
        return ShiftEvents(out_m, out_v, valid, first, done_n, failed, self.k.copy())

    def _round(
        self,
        rows: I64,
        need: I64,
        route: I64,
        done_n: I64,
        *,
        out_m: F64 | None,
        out_v: F64,
        valid: NDArray[np.bool_],
    ) -> None:
        """One atlas pass: the next events of ``rows`` up to their need or the event that
        crosses their layer's lower edge, whichever comes first."""
        m = int(need.max())
        col = np.arange(m)
        idx = np.minimum(self._cur[rows, None] + col, self.capacity - 1)
        u = self._u[rows[:, None], idx]  # (R, m, 3)
        x = self.low[route][:, None, :] + self.span[route][:, None, :] * u
        sp, mass, th = x[..., 0], x[..., 1], x[..., 2]
        fields = RESPONSE if out_m is not None else RESPONSE[2:]
        look = self.atlas.lookup
        cell, frac = look.locate(sp, mass, th)
        g = look.interp_array(fields, self.layer[rows, None], cell, frac)
        a = self.k[rows, None] * g[..., -1] / self.pad_v
        # The simulator's sum, in event order from the wear accumulated in the layer.
        a[:, 0] += self.acc[rows]
        cum = np.cumsum(a, axis=1)
        after = self.start[rows, None] - cum
        crossed = (after <= self.edges[self.layer[rows]][:, None]) & (col < need[:, None])
        hit = crossed.any(axis=1)
        n_keep = np.where(hit, np.argmax(crossed, axis=1) + 1, need)
        before = np.empty_like(after)
        before[:, 0], before[:, 1:] = self.vol[rows], after[:, :-1]
        at = done_n[rows]
        if np.all(n_keep == m) and np.all(at == at[0]):  # one block: no scatter
            sl = (rows, slice(int(at[0]), int(at[0]) + m))
            out_v[sl], valid[sl] = before, True
            if out_m is not None:
                out_m[(slice(None), *sl)] = self._measure(rows, idx, sp, mass, th, g)
        else:
            ri, j = np.nonzero(col < n_keep[:, None])
            v, c = rows[ri], at[ri] + j
            out_v[v, c], valid[v, c] = before[ri, j], True
            if out_m is not None:
                out_m[:, v, c] = self._measure(rows, idx, sp, mass, th, g)[:, ri, j]
        last = n_keep - 1
        r_all = np.arange(rows.size)
        self.vol[rows], self.acc[rows] = after[r_all, last], cum[r_all, last]
        self._cur[rows] += n_keep
        self.pos[rows] += n_keep
        done_n[rows] += n_keep
        self._next_layer(rows[hit])

    def _measure(self, rows: I64, idx: I64, sp: F64, mass: F64, th: F64, g: F64) -> F64:
        """Sensor readings (channels, R, m) of a block: true values plus each channel's
        next draws (the arithmetic of :class:`~brake_env.model.streams.NoiseStreams`)."""
        truth = (sp * 3.6, mass, th, 0.5 * mass * sp**2, g[..., 0], g[..., 1])
        out = np.empty((N_CH, *sp.shape))
        for ch, x in enumerate(truth):
            sigma = self.sigmas[ch]
            if sigma == 0:
                out[ch] = x
            else:
                np.multiply(self._z[rows[:, None], ch, idx], sigma, out=out[ch])
                out[ch] += x
        np.maximum(out[3], 0.0, out=out[3])
        np.maximum(out[5], 0.0, out=out[5])
        return out

    def _next_layer(self, rows: I64) -> None:
        """Pads that crossed their layer's lower edge: the layer whose band holds the volume
        (an event may skip one), or end of life below the last."""
        if rows.size == 0:
            return
        nxt = (self.edges[None, :] >= self.vol[rows, None]).sum(axis=1)
        end = nxt >= self.edges.size
        self.done[rows[end]] = True
        go = rows[~end]
        self.layer[go], self.start[go], self.acc[go] = nxt[~end], self.vol[go], 0.0

    # ------------------------------------------------------------------ truth
    def events_to_failure(self, route: I64, vehicles: I64 | None = None) -> I64:
        """Events each pad still completes were it to brake route ``route[v]`` from now on:
        its true RUL, simulated ahead (wear only) on a copy of its streams."""
        sim = self.clone()
        rows = np.arange(self.n) if vehicles is None else np.asarray(vehicles, dtype=np.int64)
        steps = np.zeros(self.n, dtype=np.int64)
        steps[rows] = self.capacity
        routes = np.broadcast_to(np.asarray(route, dtype=np.int64), (self.n,)).copy()
        while True:
            todo = np.where(sim.done, 0, steps)
            if not todo.any():
                break
            sim.advance(todo, routes, measure=False)
        return (sim.pos - self.pos)[rows]
