"""Coupled run-to-failure wear simulation through the atlas (paper Steps 3-5; README "The model").

For every braking event, operating conditions are drawn uniformly over the envelope, the
active atlas layer gives the response, and the pad loses ``K * wear_per_k``. When the volume
crosses the next 1% level the next layer becomes active; the run ends at the event that
takes the volume below the critical volume (the severe event can then no longer stop).

Within a layer the events are independent and identically distributed, so a whole layer is
one cumulative sum. The simulation loops over layers (~80), vectorised over all runs at once,
never over events. Each run owns a random stream (``SeedSequence.spawn``), so its trajectory
does not depend on how many runs are simulated beside it, and
:func:`brake_env.model.simulator_reference.simulate_run_reference` (a literal per-event
loop over the same stream) reproduces it exactly.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from brake_env._validate import check_nonnegative
from brake_env.model.atlas import Atlas
from brake_env.model.wear import WearModel

F64 = NDArray[np.float64]
RESPONSE_FIELDS = ("temp_mean_c", "stop_dist_m", "wear_per_k_m3")
_CHUNK_MIN = 4096
_BATCH_EVENTS = 16_384
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


@dataclass(frozen=True)
class SensorNoise:
    """Standard deviations of additive Gaussian sensor noise (paper 2.1.1: about 5% of scale).

    Attributes:
        temp_c: Brake temperature [K].
        stop_dist_m: Stopping distance [m]; readings are floored at 0 (a distance is never
            negative).
        energy_j: Kinetic energy at brake onset [J].
        slope_rad: Road slope [rad].
        speed_kmh: Wheel speed [km/h]; the paper gives none, so 0.
        mass_kg: Vehicle mass [kg]; the paper gives none, so 0.
    """

    temp_c: float = 5.0
    stop_dist_m: float = 1.0
    energy_j: float = 2000.0
    slope_rad: float = 0.01
    speed_kmh: float = 0.0
    mass_kg: float = 0.0

    def __post_init__(self) -> None:
        check_nonnegative(
            self, "temp_c", "stop_dist_m", "energy_j", "slope_rad", "speed_kmh", "mass_kg"
        )

    @classmethod
    def none(cls) -> SensorNoise:
        return cls(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


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


@dataclass(frozen=True)
class AlternatingRoutes:
    """A duty cycle that alternates between two routes in blocks of events.

    Blocks 0, 2, 4... run on the haul road (speeds in the upper half of the envelope's
    range), blocks 1, 3, 5... in the pit (the lower half); mass and slope stay uniform. The
    overall mix is the uniform one of the paper; only its order in time changes. With
    independent conditions from event to event, a wear law that scales each event's wear by
    a function of its conditions only rescales the pad's K; alternating routes make such a
    law show in the wear path (sim2real's validation uses this).

    Attributes:
        block_events: Events per block [-], >= 1.
    """

    block_events: int

    def __post_init__(self) -> None:
        if not isinstance(self.block_events, int) or self.block_events < 1:
            raise ValueError(
                f"AlternatingRoutes.block_events must be an int >= 1, got {self.block_events!r}"
            )

    def apply(self, u: F64, first: int) -> F64:
        """Uniform triples (n, 3) of events ``first``, ``first + 1``... on their routes."""
        haul = ((first + np.arange(len(u))) // self.block_events) % 2 == 0
        out = u.copy()
        out[:, 0] = 0.5 * (u[:, 0] + haul)
        return out


class ConditionStream:
    """A run's operating conditions: uniform triples drawn in order, extended on demand."""

    def __init__(
        self, rng: np.random.Generator, capacity: int, duty: AlternatingRoutes | None = None
    ) -> None:
        self.rng, self.duty = rng, duty
        self.u = self._draw(max(capacity, _CHUNK_MIN), 0)

    def _draw(self, n: int, first: int) -> F64:
        u = self.rng.random((n, 3))
        return u if self.duty is None else self.duty.apply(u, first)

    def take(self, start: int, n: int) -> F64:
        if start + n > len(self.u):
            extra = max(start + n - len(self.u), len(self.u) // 2)
            self.u = np.concatenate([self.u, self._draw(extra, len(self.u))])
        return self.u[start : start + n]


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
    ks = np.asarray(wear_coeffs, dtype=np.float64)
    if ks.ndim != 1 or len(seeds) != ks.size:
        raise ValueError("give one seed per wear coefficient")
    if np.any(~np.isfinite(ks) | (ks <= 0)):
        raise ValueError(
            f"wear coefficients must be finite and > 0, got {ks[(ks <= 0) | ~np.isfinite(ks)]}"
        )
    check_wear_per_event(atlas, float(ks.max()))
    capacity = (1.1 * WearModel.from_atlas(atlas).life(ks)).astype(np.int64) + 1000
    runs = _Runs(atlas, ks, seeds, capacity, duty)
    for j in range(atlas.n_layers):
        runs.cross_layer(j, interpolate_layers)
        if progress:
            progress(1)
    return [runs.outs[r].trajectory(float(ks[r]), float(runs.vol[r])) for r in range(ks.size)]


class _Runs:
    """The state of runs simulated together: streams, output columns, position and volume."""

    def __init__(
        self,
        atlas: Atlas,
        ks: F64,
        seeds: Sequence[np.random.SeedSequence],
        capacity: NDArray[np.int64],
        duty: AlternatingRoutes | None,
    ) -> None:
        self.atlas, self.ks = atlas, ks
        self.streams = [
            ConditionStream(np.random.default_rng(s), int(c), duty)
            for s, c in zip(seeds, capacity, strict=True)
        ]
        self.outs = [RunColumns(int(c)) for c in capacity]
        self.pos = np.zeros(ks.size, dtype=np.int64)
        self.mean_wear = atlas.expected("wear_per_k_m3")
        self.vol = np.ones(ks.size)

    def cross_layer(self, j: int, interpolate: bool) -> None:
        """Advance every run still above layer j's lower edge down to it, in blocks."""
        atlas, ks, vol = self.atlas, self.ks, self.vol
        lower = atlas.lower_edges[j]
        alive = np.flatnonzero(vol > lower)  # runs not yet down to this layer's lower edge
        # Volume = layer start - wear accumulated in the layer, summed in event order.
        start, acc = vol.copy(), np.zeros(ks.size)
        # Block: expected events to cross the layer with a margin, so a second pass is rare.
        # Runs of similar block size go together so that slow runs do not pad fast ones, in
        # batches of ~16k events: arrays that fit in cache are several times faster.
        pad_v = atlas.spec.model.brake.pad_volume_m3
        mean_w = self.mean_wear[j]
        n_exp = np.maximum(vol[alive] - lower, 0.0) * pad_v / (ks[alive] * mean_w)
        blocks = np.ceil(1.15 * n_exp + 6.0 * np.sqrt(n_exp) + 16).astype(np.int64)
        groups = np.ceil(np.log(blocks) / np.log(1.25)).astype(np.int64)
        for g in np.unique(groups):
            members, block = alive[groups == g], int(blocks[groups == g].max())
            per_batch = max(1, _BATCH_EVENTS // block)
            for b0 in range(0, members.size, per_batch):
                todo, size = members[b0 : b0 + per_batch], block
                while todo.size:  # runs that did not cross go on with a doubled block
                    todo = self._block(j, todo, size, start, acc, interpolate)
                    size *= 2

    def _block(
        self, j: int, todo: NDArray[np.intp], size: int, start: F64, acc: F64, interpolate: bool
    ) -> NDArray[np.intp]:
        """Simulate ``size`` events of each run in ``todo`` in layer j; keep each run's
        events up to the one crossing the layer's lower edge. Returns the runs not done."""
        atlas, vol = self.atlas, self.vol
        u = np.stack([self.streams[r].take(int(self.pos[r]), size) for r in todo])
        sp, m, th = conditions_from_uniform(atlas, u)
        temp, dist, dv, cum = _layer_block(
            atlas, j, sp, m, th, self.ks[todo], start[todo], acc[todo], interpolate
        )
        after = start[todo, None] - cum
        crossed = after <= atlas.lower_edges[j]  # reaching a level activates its layer
        done = crossed.any(axis=1)
        # Events kept per run: up to the crossing one, or the whole block if none.
        n_keep = np.where(done, np.argmax(crossed, axis=1) + 1, size)
        for i, r in enumerate(todo):
            c = n_keep[i]
            cols = (sp[i, :c], m[i, :c], th[i, :c], temp[i, :c], dist[i, :c], dv[i, :c])
            self.outs[r].append(*cols, vol[r], after[i, : c - 1], j)
            vol[r], acc[r] = after[i, c - 1], cum[i, c - 1]
            self.pos[r] += c
        return todo[~done]


class RunColumns:
    """Per-run output columns, preallocated and grown by doubling."""

    _NAMES = TRAJECTORY_ARRAYS[:-1]  # all but the int16 layer

    def __init__(self, capacity: int) -> None:
        self.n = 0
        self.cols = {k: np.empty(capacity) for k in self._NAMES}
        self.layer = np.empty(capacity, dtype=np.int16)

    def append(
        self,
        sp: F64,
        m: F64,
        th: F64,
        temp: F64,
        dist: F64,
        dv: F64,
        v_first: float,
        v_rest: F64,
        layer: int | NDArray[np.integer],
    ) -> None:
        c, n = sp.size, self.n
        if n + c > self.layer.size:
            grow = max(n + c, 2 * self.layer.size)
            self.cols = {k: np.resize(v, grow) for k, v in self.cols.items()}
            self.layer = np.resize(self.layer, grow)
        for k, x in zip(self._NAMES[:6], (sp, m, th, temp, dist, dv), strict=True):
            self.cols[k][n : n + c] = x
        self.cols["volume_frac"][n] = v_first  # volume at the start of each event
        self.cols["volume_frac"][n + 1 : n + c] = v_rest
        self.layer[n : n + c] = layer
        self.n += c

    def trajectory(self, wear_coeff: float, final_volume_frac: float) -> Trajectory:
        c, n = self.cols, self.n
        return Trajectory(
            wear_coeff=wear_coeff,
            speed_mps=c["speed_mps"][:n],
            mass_kg=c["mass_kg"][:n],
            slope_rad=c["slope_rad"][:n],
            temp_mean_c=c["temp_mean_c"][:n],
            stop_dist_m=c["stop_dist_m"][:n],
            wear_frac=c["wear_frac"][:n],
            volume_frac=c["volume_frac"][:n],
            layer=self.layer[:n],
            final_volume_frac=final_volume_frac,
        )


def check_wear_per_event(atlas: Atlas, k_max: float) -> None:
    """Reject K so large that a mean event wears more than half a layer: the atlas then no
    longer resolves the coupling (and no real pad loses 0.5% in one stop)."""
    mean_end = k_max * atlas.expected("wear_per_k_m3")[-1] / atlas.spec.model.brake.pad_volume_m3
    if mean_end > 0.5 * atlas.spec.layer_step:
        raise ValueError(
            f"wear coefficient {k_max:.3g} wears {mean_end:.3g} of the pad in a mean event,"
            f" more than half an atlas layer ({0.5 * atlas.spec.layer_step:g})"
        )


def _layer_block(
    atlas: Atlas,
    j: int,
    sp: F64,
    m: F64,
    th: F64,
    k: F64,
    start: F64,
    acc: F64,
    interpolate: bool,
) -> tuple[F64, F64, F64, F64]:
    """Response, wear and accumulated wear of a block of events (runs x events) in layer j.

    ``start`` is each run's volume when it entered the layer and ``acc`` the wear it has
    accumulated in the layer before this block. Returns (temperature, stopping distance,
    wear per event, wear accumulated in the layer after each event).
    """
    pad_v = atlas.spec.model.brake.pad_volume_m3
    resp = atlas.query(sp, m, th, layer=np.int64(j), fields=RESPONSE_FIELDS)
    a = k[:, None] * resp["wear_per_k_m3"] / pad_v
    if not interpolate or j + 1 >= atlas.n_layers:
        # Wear does not depend on the volume inside the layer: a cumulative sum, in event
        # order from the accumulated value (the reference loop adds in the same order).
        cum = np.cumsum(np.concatenate([acc[:, None], a], axis=1), axis=1)[:, 1:]
        return resp["temp_mean_c"], resp["stop_dist_m"], a, cum
    # Blended layers: with x = depth below the layer's volume and w = x / step, an event
    # wears a + (b - a) w, so x_{k+1} = (1 + (b - a) / step) x_k + a_k, a linear recurrence
    # solved in closed form with cumulative products and sums instead of an event loop.
    step = atlas.spec.layer_step
    nxt = atlas.query(sp, m, th, layer=np.int64(j + 1), fields=RESPONSE_FIELDS)
    delta = k[:, None] * nxt["wear_per_k_m3"] / pad_v - a
    log_p = np.cumsum(np.log1p(delta / step), axis=1)  # log of prod_{i<=k} c_i
    p_next = np.exp(log_p)
    x0 = (atlas.volumes[j] - start) + acc
    x = p_next * (x0[:, None] + np.cumsum(a / p_next, axis=1))  # depth after each event
    x_before = np.concatenate([x0[:, None], x[:, :-1]], axis=1)
    w = x_before / step
    temp = (1.0 - w) * resp["temp_mean_c"] + w * nxt["temp_mean_c"]
    dist = (1.0 - w) * resp["stop_dist_m"] + w * nxt["stop_dist_m"]
    return temp, dist, x - x_before, x - (atlas.volumes[j] - start)[:, None]
