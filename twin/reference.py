"""The paper's digital twin procedure, literally (paper 2.4): the slow reference.

At each update the reference

1. infers the pad volume by reverse inference: the atlas layer whose temperature best
   explains the measured temperatures of the recent events, ``argmin_V sum (T_atlas -
   T_meas)^2`` (the paper's formula, summed over a window; a window of 1 is the paper's
   per-event form), taken at the middle of the layer's volume band;
   The fitted volume is that of the window's middle event;
2. identifies K by iteratively simulating degradation from a fresh pad to that volume in
   batches of 100 events through the atlas, with candidate K, until the simulated event
   count matches the events elapsed;
3. simulates forward from that volume with that K, in batches of 100 events, switching the
   atlas layer between batches, until failure: the RUL is the number of events simulated.

Operating conditions of the simulated batches are drawn uniformly over the envelope from a
generator seeded by the caller. Between updates the RUL counts down. It is slow (seconds per
update); :class:`twin.DigitalTwin` replaces steps 2-3 by closed-form sums and step 1 by a
filter, and the tests check that both agree.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import pandas as pd

from brake_env.model.atlas import Atlas
from brake_env.model.simulator import conditions_from_uniform
from brake_env.model.wear import WearModel
from brake_env.prognostics.protocol import MEASURED, EventBatch, Predictor, RULEstimate
from twin.calibration import FIT_COLUMNS

BATCH_EVENTS = 100  # the paper's forward-simulation batch


def simulate_batches(
    atlas: Atlas,
    wear_coeff: float,
    v_start: float,
    v_stop: float,
    rng: np.random.Generator,
    *,
    batch_events: int = BATCH_EVENTS,
    max_events: int = 10_000_000,
) -> int:
    """Events to wear from ``v_start`` down to ``v_stop`` at ``wear_coeff`` (paper Fig. 9).

    Each batch draws uniform operating conditions, queries the layer active at the batch's
    start and accumulates Archard wear; the layer is switched between batches. The count
    includes the event of the last batch at which the volume reaches ``v_stop``.
    """
    pad_v = atlas.spec.model.brake.pad_volume_m3
    v, n = v_start, 0
    while v > v_stop:
        if n >= max_events:
            raise RuntimeError(f"simulate_batches: no wear-out within {max_events} events")
        layer = int(np.searchsorted(-atlas.lower_edges, -v, side="right"))  # v > lower edge
        layer = min(layer, atlas.n_layers - 1)
        s, m, th = conditions_from_uniform(atlas, rng.random((batch_events, 3)))
        wear = atlas.query(s, m, th, layer=np.int64(layer), fields=("wear_per_k_m3",))
        dv = np.cumsum(wear_coeff * wear["wear_per_k_m3"] / pad_v)
        if v - dv[-1] > v_stop:
            v, n = v - float(dv[-1]), n + batch_events
        else:
            return n + int(np.searchsorted(-(v - dv), -v_stop, side="left")) + 1
    return n


def identify_k_iterative(
    atlas: Atlas,
    volume_frac: float,
    n_events: int,
    k_start: float,
    seed: int,
    max_iter: int = 30,
) -> float:
    """K such that simulating a fresh pad down to ``volume_frac`` takes ``n_events`` events.

    Fixed-point iteration ``K <- K * N_sim(K) / n_events`` (events scale as 1/K), each
    simulation with the same random stream (common random numbers), until the simulated
    count is within one batch of ``n_events``.
    """
    if n_events <= 0:
        raise ValueError("identify_k_iterative needs n_events > 0")
    if volume_frac >= 1.0:
        return k_start
    k = k_start
    for _ in range(max_iter):
        n_sim = simulate_batches(atlas, k, 1.0, volume_frac, np.random.default_rng(seed))
        if abs(n_sim - n_events) <= BATCH_EVENTS // 2:
            break
        k *= n_sim / n_events
    return k


def rul_iterative(atlas: Atlas, volume_frac: float, wear_coeff: float, seed: int) -> int:
    """Events from ``volume_frac`` to failure, simulated forward in batches (paper 2.4.2)."""
    rng = np.random.default_rng(seed)
    return simulate_batches(atlas, wear_coeff, volume_frac, atlas.failure_volume, rng)


class ReferenceTwin(Predictor):
    """The paper's twin, literally: reverse inference, iterative K search, forward simulation.

    Args:
        atlas: The atlas.
        update_every: Events between updates (the paper's Fig. 11: 1000).
        window: Recent events used in the reverse inference of the volume.
        seed: Seed of the operating conditions of the simulated batches.
    """

    name: ClassVar[str] = "twin-reference"

    def __init__(
        self, atlas: Atlas, update_every: int = 1000, window: int = 1000, seed: int = 0
    ) -> None:
        super().__init__()
        if update_every < 1 or window < 1:
            raise ValueError("ReferenceTwin: update_every and window must be >= 1")
        self.atlas, self.update_every, self.window, self.seed = atlas, update_every, window, seed
        self._wear = WearModel.from_atlas(atlas)
        self.k_prior: float | None = None
        self._reset()

    def _fit(self, train_log: pd.DataFrame) -> None:
        missing = [c for c in FIT_COLUMNS if c not in train_log.columns]
        if missing:
            raise ValueError(f"twin-reference.fit: the training log lacks column(s) {missing}")
        lives = train_log.groupby("run_id", observed=True)["event"].max().to_numpy() + 1
        if len(lives) == 0:
            raise ValueError("twin-reference.fit: the training log is empty")
        # K of each training run: the K whose simulated life matches the run's life.
        ks = [
            identify_k_iterative(self.atlas, self.atlas.failure_volume, int(n), 2e-6, self.seed)
            for n in lives
        ]
        self.k_prior = float(np.mean(ks))

    def _reset(self) -> None:
        self._recent: list[EventBatch] = []
        self._k = self.k_prior
        self._volume = 1.0
        self._rul_at: tuple[int, float] | None = None  # (events done, RUL then)

    def infer_volume(self, events: EventBatch) -> float:
        """Reverse inference: the layer minimising the squared temperature error, at the
        middle of its volume band."""
        t_atlas, _ = self.atlas.lookup.profile(
            events.speed_kmh / 3.6, events.mass_kg, events.slope_rad
        )
        sse = ((events.temp_c[:, None] - t_atlas) ** 2).sum(axis=0)
        j = int(np.argmin(sse))
        return float(0.5 * (self.atlas.volumes[j] + self.atlas.lower_edges[j]))

    def _update(self, events: EventBatch) -> RULEstimate:
        if self._k is None:
            raise RuntimeError("twin-reference: call fit() before update()")
        n = len(events)
        rul, vol, kk = np.empty(n), np.empty(n), np.empty(n)
        done = events.event.astype(np.int64) + 1  # events completed after each event
        self._recent.append(events)
        for i in range(n):  # the reference loops over events on purpose
            if done[i] % self.update_every == 0:
                self._checkpoint(int(done[i]), events.event[i])
            if self._rul_at is None:
                self._rul_at = (0, float(self._wear.life(self._k)))
            n0, r0 = self._rul_at
            rul[i] = max(r0 - (done[i] - n0), 0.0)
            vol[i], kk[i] = self._volume, self._k
        return RULEstimate(rul_mean=rul, volume_frac=vol, wear_coeff=kk)

    def _checkpoint(self, n_done: int, last_event: int) -> None:
        allev = self._concat()
        sel = allev[max(0, len(allev) - self.window) :]
        sel = sel[: int(np.searchsorted(sel.event, last_event, side="right"))]
        v_hat = max(self.infer_volume(sel), self.atlas.failure_volume)
        # The volume fitted over the window is that of the window's middle event.
        lag = 0.5 * (len(sel) - 1)
        n_mid = max(n_done - lag, 1.0)
        assert self._k is not None
        if v_hat < 1.0 - 1e-12:
            self._k = identify_k_iterative(self.atlas, v_hat, round(n_mid), self._k, self.seed)
        self._volume = v_hat
        rul_mid = float(rul_iterative(self.atlas, v_hat, self._k, self.seed + 1))
        self._rul_at = (n_done, rul_mid - (n_done - n_mid))

    def _concat(self) -> EventBatch:
        if len(self._recent) > 1:
            parts = self._recent
            arrays = {
                k: np.concatenate([getattr(p, k) for p in parts]) for k in ("event", *MEASURED)
            }
            self._recent = [EventBatch.from_arrays(arrays)]
        batch = self._recent[0]
        if len(batch) > self.window + 100_000:  # keep memory bounded
            self._recent = [batch[len(batch) - self.window :]]
        return self._recent[0]
