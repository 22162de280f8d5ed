"""Coupled run-to-failure wear simulation through the atlas (paper Steps 3-5; docs/model.md).

For every braking event, operating conditions are drawn uniformly over the envelope, the
active atlas layer gives the response, and the pad loses ``K * wear_per_k``. When the volume
crosses the next 1% level the next layer becomes active; the run ends at the event that
takes the volume below the critical volume (the severe event can then no longer stop).

Within a layer the events are independent and identically distributed, so a block of events
is one cumulative sum. :class:`Runs` advances runs a block at a time, vectorised over the
runs of a layer, never looping over events; :func:`simulate_runs` takes them to failure
(~80 layers). A run's blocks depend on nothing but the run (its K and its random stream,
``SeedSequence.spawn``), so its trajectory is the same whether it is simulated with other
runs, whole, or a block at a time as the environment streams a pad; and
:func:`brake_env.model.simulator_reference.simulate_run_reference` (a literal per-event loop
over the same stream) reproduces it exactly.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from brake_env.model.atlas import Atlas
from brake_env.model.streams import AlternatingRoutes, ConditionStream, SensorNoise
from brake_env.model.wear import WearModel

__all__ = [
    "F64",
    "RESPONSE_FIELDS",
    "TRAJECTORY_ARRAYS",
    "AlternatingRoutes",
    "Block",
    "ConditionStream",
    "RunColumns",
    "Runs",
    "SensorNoise",
    "Trajectory",
    "check_wear_per_event",
    "conditions_from_uniform",
    "layer_block",
    "simulate_runs",
]

F64 = NDArray[np.float64]
RESPONSE_FIELDS = ("temp_mean_c", "stop_dist_m", "wear_per_k_m3")
WEAR = "wear_per_k_m3"
# Events per batch of runs simulated together: arrays that fit in cache are several times
# faster. Also the largest block of one run, which bounds a streamed run's memory.
BLOCK_MAX = 16_384
# Per-event arrays of a Trajectory, in field order.
TRAJECTORY_ARRAYS = (
    "speed_mps",
    "mass_kg",
    "slope_rad",
    "temp_mean_c",
    "stop_dist_m",
    "wear_frac",
    "volume_frac",
    "layer",
)


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Ground truth of one run to failure; event k is the k-th braking event of the pad.

    Attributes:
        wear_coeff: Archard coefficient K of the pad [-].
        speed_mps, mass_kg, slope_rad: Operating conditions of each event.
        temp_mean_c, stop_dist_m: True (noise-free) response of each event.
        wear_frac: Pad volume fraction lost in each event [-].
        volume_frac: Pad volume fraction at the start of each event [-].
        layer: Atlas layer active during each event [-].
        final_volume_frac: Volume after the last event, just below the critical volume [-].
    """

    wear_coeff: float
    speed_mps: F64
    mass_kg: F64
    slope_rad: F64
    temp_mean_c: F64
    stop_dist_m: F64
    wear_frac: F64
    volume_frac: F64
    layer: NDArray[np.int16]
    final_volume_frac: float

    @property
    def n_events(self) -> int:
        return int(self.speed_mps.size)

    @property
    def rul_events(self) -> NDArray[np.int64]:
        """Events the pad still completes after event k before failing (0 at the last)."""
        return np.arange(self.n_events - 1, -1, -1, dtype=np.int64)

    @property
    def energy_j(self) -> F64:
        return 0.5 * self.mass_kg * self.speed_mps**2


class Block(NamedTuple):
    """Consecutive events of one run, all in one atlas layer (what :meth:`Runs.advance`
    returns). ``temp_mean_c`` and ``stop_dist_m`` are None when only wear was asked for."""

    first: int  # index of the first event in the run
    layer: int
    speed_mps: F64
    mass_kg: F64
    slope_rad: F64
    temp_mean_c: F64 | None
    stop_dist_m: F64 | None
    wear_frac: F64
    volume_frac: F64  # at the start of each event


def conditions_from_uniform(atlas: Atlas, u: F64) -> tuple[F64, F64, F64]:
    """Map uniform triples in [0, 1)^3 to (speed [m/s], mass [kg], slope [rad])."""
    lo = np.array([atlas.speed_mps[0], atlas.mass_kg[0], atlas.slope_rad[0]])
    hi = np.array([atlas.speed_mps[-1], atlas.mass_kg[-1], atlas.slope_rad[-1]])
    x = lo + (hi - lo) * u
    return x[..., 0], x[..., 1], x[..., 2]


def simulate_runs(
    atlas: Atlas,
    wear_coeffs: Sequence[float] | F64,
    seeds: Sequence[np.random.SeedSequence],
    progress: Callable[[int], object] | None = None,
    interpolate_layers: bool = False,
    duty: AlternatingRoutes | None = None,
) -> list[Trajectory]:
    """Simulate one pad to failure per wear coefficient, all runs at once.

    Args:
        atlas: The atlas to run through.
        wear_coeffs: Archard coefficient K of each run, > 0.
        seeds: One ``SeedSequence`` per run, for its operating conditions.
        progress: Called with 1 after each atlas layer.
        interpolate_layers: Blend the active layer with the next one linearly in the volume
            at the start of each event (the paper's footnote 1), instead of holding the
            active layer until the volume crosses the next 1% level.
        duty: Order of the operating conditions in time (default: independent draws).
    """
    runs = Runs(atlas, wear_coeffs, seeds, interpolate_layers, duty)
    capacity = (1.1 * WearModel.from_atlas(atlas).life(runs.ks)).astype(np.int64) + 1000
    outs = [RunColumns(int(c)) for c in capacity]
    for j in range(atlas.n_layers):
        # Runs of similar block size go together so that slow runs do not pad fast ones, in
        # batches of ~BLOCK_MAX events. A run that did not cross the layer comes back with
        # a doubled block; one that did is in a later layer.
        while (members := runs.in_layer(j)).size:
            if members.size == 1:
                outs[members[0]].append(runs.advance(members)[0])
                continue
            sizes = runs.size[members]
            groups = np.ceil(np.log(sizes) / np.log(1.25)).astype(np.int64)
            for g in np.unique(groups):
                todo = members[groups == g]
                per_batch = max(1, BLOCK_MAX // int(sizes[groups == g].max()))
                for b0 in range(0, todo.size, per_batch):
                    batch = todo[b0 : b0 + per_batch]
                    for r, block in zip(batch, runs.advance(batch), strict=True):
                        outs[r].append(block)
        if progress:
            progress(1)
    return [outs[r].trajectory(float(runs.ks[r]), float(runs.vol[r])) for r in range(runs.n)]


class Runs:
    """Runs in progress: their streams and where each is (layer, volume, event).

    The unit of work is a block: up to ``size`` events of a run in its active layer, cut
    after the event that crosses the layer's lower edge. A run's first block in a layer
    is the expected events to cross it with a margin (so that a second block is rare) and
    each further one twice the last, at most ``BLOCK_MAX``, so
    a run's blocks (and the rounding of the blended-layer recurrence, restarted at each
    block) depend on that run alone.

    Args:
        atlas: The atlas to run through.
        wear_coeffs: Archard coefficient K of each run, > 0.
        seeds: One ``SeedSequence`` per run, for its operating conditions.
        interpolate_layers: Blend adjacent layers (see :func:`simulate_runs`).
        duty: Order of the operating conditions in time (default: independent draws).
    """

    def __init__(
        self,
        atlas: Atlas,
        wear_coeffs: Sequence[float] | F64,
        seeds: Sequence[np.random.SeedSequence],
        interpolate_layers: bool = False,
        duty: AlternatingRoutes | None = None,
    ) -> None:
        ks = np.asarray(wear_coeffs, dtype=np.float64)
        if ks.ndim != 1 or len(seeds) != ks.size:
            raise ValueError("give one seed per wear coefficient")
        bad = ~np.isfinite(ks) | (ks <= 0)
        if np.any(bad):
            raise ValueError(f"wear coefficients must be finite and > 0, got {ks[bad]}")
        check_wear_per_event(atlas, float(ks.max()))
        self.atlas, self.ks, self.interpolate = atlas, ks, interpolate_layers
        self.edges = atlas.lower_edges
        self._pad_v, self._mean_wear = atlas.spec.model.brake.pad_volume_m3, atlas.expected(WEAR)
        self.streams = [ConditionStream(np.random.default_rng(s), duty=duty) for s in seeds]
        self.pos = np.zeros(ks.size, dtype=np.int64)  # events simulated
        self.vol = np.ones(ks.size)  # volume after them
        self.layer = np.zeros(ks.size, dtype=np.int64)  # active layer
        self.start = np.ones(ks.size)  # volume when the run entered its layer
        self.acc = np.zeros(ks.size)  # wear accumulated in the layer since
        self.size = self._first_block(self.layer, self.vol, ks)  # next block
        self.done = np.zeros(ks.size, dtype=bool)  # at end of life

    @property
    def n(self) -> int:
        return int(self.ks.size)

    def clone(self) -> Runs:
        """An independent copy in the same state (the atlas is shared)."""
        new = copy.copy(self)
        for name in ("pos", "vol", "layer", "start", "acc", "size", "done"):
            setattr(new, name, getattr(self, name).copy())
        new.streams = [s.clone() for s in self.streams]
        return new

    def in_layer(self, j: int) -> NDArray[np.intp]:
        """Runs still alive whose active layer is j."""
        return np.flatnonzero((self.layer == j) & ~self.done)

    def advance(self, todo: NDArray[np.intp], response: bool = True) -> list[Block]:
        """Simulate the next block of each run in ``todo`` (alive, all in one layer).

        With ``response=False`` only the wear is computed (to find the end of life
        sooner); the events are the same.
        """
        atlas, j = self.atlas, int(self.layer[todo[0]])
        if np.any(self.done[todo]) or np.any(self.layer[todo] != j):
            raise ValueError("Runs.advance: give alive runs of one layer")
        own = self.size[todo]
        u = np.stack([self.streams[r].take(int(self.pos[r]), int(own.max())) for r in todo])
        sp, m, th = conditions_from_uniform(atlas, u)
        fields = RESPONSE_FIELDS if response else (WEAR,)
        resp, dv, cum = layer_block(
            atlas, j, sp, m, th, k=self.ks[todo], start=self.start[todo], acc=self.acc[todo],
            interpolate=self.interpolate, fields=fields,
        )  # fmt: skip
        after = self.start[todo, None] - cum
        # Only a run's own block counts: events past it belong to its next block.
        crossed = (after <= self.edges[j]) & (np.arange(u.shape[1]) < own[:, None])
        done = crossed.any(axis=1)
        n_keep = np.where(done, np.argmax(crossed, axis=1) + 1, own)
        temp, dist = resp.get("temp_mean_c"), resp.get("stop_dist_m")
        before = np.concatenate([self.vol[todo, None], after[:, :-1]], axis=1)
        blocks = []
        for i, r in enumerate(todo):
            c = int(n_keep[i])
            t_i = None if temp is None else temp[i, :c]
            d_i = None if dist is None else dist[i, :c]
            blocks.append(
                Block(
                    int(self.pos[r]),
                    j,
                    sp[i, :c],
                    m[i, :c],
                    th[i, :c],
                    t_i,
                    d_i,
                    dv[i, :c],
                    before[i, :c],
                )
            )
            self.vol[r], self.acc[r] = after[i, c - 1], cum[i, c - 1]
            self.pos[r] += c
        self.size[todo[~done]] = np.minimum(2 * own[~done], BLOCK_MAX)
        self._enter_next_layer(todo[done])
        return blocks

    def _enter_next_layer(self, runs: NDArray[np.intp]) -> None:
        """Runs that crossed their layer's lower edge: the next layer whose band holds the
        volume (an event may skip one), or end of life below the last."""
        edges = self.edges
        nxt = (edges[None, :] >= self.vol[runs, None]).sum(axis=1)
        end = nxt >= edges.size
        self.done[runs[end]] = True
        go = runs[~end]
        self.layer[go], self.start[go], self.acc[go] = nxt[~end], self.vol[go], 0.0
        self.size[go] = self._first_block(self.layer[go], self.vol[go], self.ks[go])

    def _first_block(self, layer: NDArray[np.int64], vol: F64, ks: F64) -> NDArray[np.int64]:
        """First block of runs entering ``layer`` at volume ``vol``."""
        gap = np.maximum(vol - self.edges[layer], 0.0)
        n_exp = gap * self._pad_v / (ks * self._mean_wear[layer])
        blocks = np.ceil(1.15 * n_exp + 6.0 * np.sqrt(n_exp) + 16).astype(np.int64)
        return np.minimum(blocks, BLOCK_MAX)


class RunColumns:
    """Per-run output columns, preallocated and grown by doubling."""

    _NAMES = TRAJECTORY_ARRAYS[:-1]  # all but the int16 layer

    def __init__(self, capacity: int) -> None:
        self.n = 0
        self.cols = {k: np.empty(capacity) for k in self._NAMES}
        self.layer = np.empty(capacity, dtype=np.int16)

    def append(self, block: Block) -> None:
        assert block.temp_mean_c is not None and block.stop_dist_m is not None
        c, n = block.speed_mps.size, self.n
        if n + c > self.layer.size:
            grow = max(n + c, 2 * self.layer.size)
            self.cols = {k: np.resize(v, grow) for k, v in self.cols.items()}
            self.layer = np.resize(self.layer, grow)
        for k in self._NAMES:
            self.cols[k][n : n + c] = getattr(block, k)
        self.layer[n : n + c] = block.layer
        self.n += c

    def trajectory(self, wear_coeff: float, final_volume_frac: float) -> Trajectory:
        c, n = self.cols, self.n
        arrays = {k: c[k][:n] for k in self._NAMES}
        return Trajectory(
            wear_coeff, **arrays, layer=self.layer[:n], final_volume_frac=final_volume_frac
        )


def check_wear_per_event(atlas: Atlas, k_max: float) -> None:
    """Reject K so large that a mean event wears more than half a layer: the atlas then no
    longer resolves the coupling (and no real pad loses 0.5% in one stop)."""
    mean_end = k_max * atlas.expected(WEAR)[-1] / atlas.spec.model.brake.pad_volume_m3
    if mean_end > 0.5 * atlas.spec.layer_step:
        raise ValueError(
            f"wear coefficient {k_max:.3g} wears {mean_end:.3g} of the pad in a mean event,"
            f" more than half an atlas layer ({0.5 * atlas.spec.layer_step:g})"
        )


def layer_block(
    atlas: Atlas,
    j: int,
    sp: F64,
    m: F64,
    th: F64,
    *,
    k: F64,
    start: F64,
    acc: F64,
    interpolate: bool,
    fields: tuple[str, ...] = RESPONSE_FIELDS,
) -> tuple[dict[str, F64], F64, F64]:
    """Response, wear and accumulated wear of a block of events (runs x events) in layer j.

    ``start`` is each run's volume when it entered the layer and ``acc`` the wear it has
    accumulated in the layer before this block. Returns (the response ``fields`` other
    than wear, wear per event [-], wear accumulated in the layer after each event [-]).
    Every value of an event depends only on the events of the block before it, so a longer
    block computes the same values for its first events.
    """
    pad_v = atlas.spec.model.brake.pad_volume_m3
    resp = atlas.query(sp, m, th, layer=np.int64(j), fields=fields)
    a = k[:, None] * resp.pop(WEAR) / pad_v
    if not interpolate or j + 1 >= atlas.n_layers:
        # Wear does not depend on the volume inside the layer: a cumulative sum, in event
        # order from the accumulated value (the reference loop adds in the same order).
        cum = np.cumsum(np.concatenate([acc[:, None], a], axis=1), axis=1)[:, 1:]
        return resp, a, cum
    # Blended layers: with x = depth below the layer's volume and w = x / step, an event
    # wears a + (b - a) w, so x_{k+1} = (1 + (b - a) / step) x_k + a_k, a linear recurrence
    # solved in closed form with cumulative products and sums instead of an event loop.
    step = atlas.spec.layer_step
    nxt = atlas.query(sp, m, th, layer=np.int64(j + 1), fields=fields)
    delta = k[:, None] * nxt.pop(WEAR) / pad_v - a
    log_p = np.cumsum(np.log1p(delta / step), axis=1)  # log of prod_{i<=k} c_i
    p_next = np.exp(log_p)
    x0 = (atlas.volumes[j] - start) + acc
    x = p_next * (x0[:, None] + np.cumsum(a / p_next, axis=1))  # depth after each event
    x_before = np.concatenate([x0[:, None], x[:, :-1]], axis=1)
    w = x_before / step
    blend = {f: (1.0 - w) * resp[f] + w * nxt[f] for f in resp}
    return blend, x - x_before, x - (atlas.volumes[j] - start)[:, None]
