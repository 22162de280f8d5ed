"""One vehicle's brake over an episode: pads installed, their events served, costs counted.

This is the whole transition logic of BrakeWear-v0. The single env drives one
:class:`PadService`; the vector env drives one per sub-environment, so the logic exists once.

Actions cannot change how a pad wears (the operating conditions do not depend on them), so a
pad's whole life is simulated when it is installed: one vectorised run through the atlas
plus its sensor noise. Serving the events of a step is then slicing, and the true RUL is
exact.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from brake_env.data.datasets import measure
from brake_env.env.config import EnvConfig
from brake_env.model.atlas import Atlas
from brake_env.model.simulator import F64, simulate_runs
from brake_env.prognostics.protocol import MEASURED, TRUTH, EventBatch

COST_TERMS = ("planned_replacement", "corrective_replacement", "downtime", "damage", "revenue")


@dataclass(frozen=True)
class RetiredPad:
    """A pad taken off in a step (an entry of ``info["retired"]``).

    Attributes:
        life_left: Events of life it still had [events]; 0 for a pad that failed.
        life: Events of its whole life [events].
        regime: Its wear regime, ``id``, ``ood-slow`` or ``ood-fast``.
    """

    life_left: int
    life: int
    regime: str

    @property
    def failed(self) -> bool:
        """It was taken off by a brake failure, not by a planned replacement."""
        return self.life_left == 0


@dataclass(frozen=True, eq=False)
class PadLife:
    """A pad simulated from installation to failure.

    Attributes:
        wear_coeff: Its Archard coefficient K [-].
        label: Its wear regime, ``id``, ``ood-slow`` or ``ood-fast``.
        measured: Logged channels of each event, columns in ``MEASURED`` order, shape (n, 6).
        volume_frac: True volume at the start of each event [-].
        volume_after: True volume after each event [-].
    """

    wear_coeff: float
    label: str
    measured: F64
    volume_frac: F64
    volume_after: F64

    @property
    def n_events(self) -> int:
        """Events the pad completes; after the last one it can no longer stop the vehicle."""
        return len(self.volume_frac)

    def events(self, start: int = 0, stop: int | None = None) -> EventBatch:
        """Events ``start`` to ``stop`` (default: to the end of life) with ground truth."""
        b = self.n_events if stop is None else stop
        cols: dict[str, Any] = {"event": np.arange(start, b)}
        cols.update((k, self.measured[start:b, i]) for i, k in enumerate(MEASURED))
        cols["volume_frac"] = self.volume_frac[start:b]
        cols["wear_coeff"] = np.full(b - start, self.wear_coeff)
        cols["rul_events"] = np.arange(self.n_events - 1 - start, self.n_events - 1 - b, -1)
        return EventBatch(**cols)


def simulate_pad(
    atlas: Atlas, config: EnvConfig, wear_coeff: float, label: str, seed: np.random.SeedSequence
) -> PadLife:
    """Simulate one pad's life and its sensor readings; ``seed`` spawns both streams, as
    :func:`brake_env.data.datasets.seeded_plan` does for a dataset run."""
    cond_seed, noise_seed = seed.spawn(2)
    (t,) = simulate_runs(atlas, [wear_coeff], [cond_seed], None, config.interpolate_layers)
    measured = np.empty((t.n_events, len(MEASURED)))
    cols = {k: measured[:, i] for i, k in enumerate(MEASURED)}
    measure(t, config.noise, np.random.default_rng(noise_seed), out=cols)
    after = np.append(t.volume_frac[1:], t.final_volume_frac)
    return PadLife(wear_coeff, label, measured, t.volume_frac, after)


_POOL: dict[tuple[Any, ...], PadLife] = {}


def _pool_pad(atlas: Atlas, config: EnvConfig, index: int) -> PadLife:
    """Pad ``index`` of the config's pool, simulated on first use and kept for the process."""
    key = (
        atlas.content_hash,
        config.pad_regime,
        config.noise,
        config.interpolate_layers,
        config.pad_pool_seed,
        config.pad_pool,
        index,
    )
    if key not in _POOL:
        rng = np.random.default_rng([config.pad_pool_seed, config.pad_pool])
        draws = [(*config.pad_regime.draw(rng), int(rng.integers(2**63))) for _ in range(index + 1)]
        k, label, entropy = draws[index]
        _POOL[key] = simulate_pad(atlas, config, k, label, np.random.SeedSequence(entropy))
    return _POOL[key]


class PadService:
    """Installs pads, serves braking events and counts the cost terms of one vehicle.

    A failure happens when an event needs a pad that has completed all the events of its
    life: a corrective replacement is forced and that event is braked on the new pad, so a
    step always ends with at least one event on the installed pad.
    """

    def __init__(self, atlas: Atlas, config: EnvConfig) -> None:
        self.atlas = atlas
        self.config = config
        self.regime = config.pad_regime
        w = config.costs
        self._planned = {"planned_replacement": w.planned_replacement}
        self._failure = {
            "corrective_replacement": w.corrective_replacement,
            "downtime": w.downtime,
            "damage": w.damage,
        }
        self.pad: PadLife | None = None
        self.pos = 0  # events the installed pad has completed
        # Pads are a pure function of (K, seed): with cache_pads > 0, the last pads made
        # are kept, so episodes replayed with the same seed (policy comparisons, threshold
        # tuning) simulate each pad once.
        self._cache: OrderedDict[tuple[float, int], PadLife] = OrderedDict()
        self.events_done = 0  # events of the episode so far

    # ------------------------------------------------------------------ transitions
    def start(self, rng: np.random.Generator) -> dict[str, Any]:
        """Begin an episode: a new pad, and its first event. Returns the info dict."""
        self.rng = rng
        self.events_done = 0
        self._install()
        return self._serve(1, replaced=False)

    def step(self, replace: bool) -> dict[str, Any]:
        """Replace the pad first if asked, then serve the step's events. Returns the info."""
        n = min(self.config.decision_interval, self.config.episode_events - self.events_done)
        if n <= 0:
            raise RuntimeError("the episode is over; call reset()")
        return self._serve(n, replaced=replace)

    @property
    def truncated(self) -> bool:
        return self.events_done >= self.config.episode_events

    def observation(self) -> NDArray[np.float32]:
        """Latest measured event and events since installation."""
        assert self.pad is not None
        obs = np.empty(len(MEASURED) + 1, dtype=np.float32)
        obs[:-1] = self.pad.measured[self.pos - 1]
        obs[-1] = self.pos
        return obs

    # ------------------------------------------------------------------ internals
    def _install(self) -> None:
        if self.config.pad_pool:
            self.pad = _pool_pad(
                self.atlas, self.config, int(self.rng.integers(self.config.pad_pool))
            )
            self.pos = 0
            return
        k, label = self.regime.draw(self.rng)
        entropy = int(self.rng.integers(2**63))
        pad = self._cache.get((k, entropy))
        if pad is None:
            pad = simulate_pad(self.atlas, self.config, k, label, np.random.SeedSequence(entropy))
            if self.config.cache_pads:
                self._cache[(k, entropy)] = pad
                while len(self._cache) > self.config.cache_pads:
                    self._cache.popitem(last=False)
        else:
            self._cache.move_to_end((k, entropy))
        self.pad, self.pos = pad, 0

    def _retire(self) -> RetiredPad:
        """The installed pad's record as it is taken off, before the next is installed."""
        assert self.pad is not None
        return RetiredPad(self.pad.n_events - self.pos, self.pad.n_events, self.pad.label)

    def _serve(self, n: int, replaced: bool) -> dict[str, Any]:
        costs = dict.fromkeys(COST_TERMS, 0.0)
        retired: list[RetiredPad] = []  # each pad taken off in the step, in order
        if replaced:
            retired.append(self._retire())
            costs.update(self._planned)
            self._install()
        segments = []  # (pad, first event, last event + 1) in service order
        failures, left = 0, n
        while left:
            assert self.pad is not None
            take = min(left, self.pad.n_events - self.pos)
            if take == 0:  # the next event needs a pad that has no life left: failure
                failures += 1
                retired.append(self._retire())  # life_left 0: all of it was used
                for key, value in self._failure.items():
                    costs[key] += value
                self._install()
                continue
            segments.append((self.pad, self.pos, self.pos + take))
            self.pos += take
            left -= take
        self.events_done += n
        costs["revenue"] = n * self.config.costs.revenue
        return self._info(segments, costs, replaced, failures, retired)

    def _info(
        self,
        segments: list[tuple[PadLife, int, int]],
        costs: dict[str, float],
        replaced: bool,
        failures: int,
        retired: list[RetiredPad],
    ) -> dict[str, Any]:
        pad = self.pad
        assert pad is not None
        events = _event_columns(segments)
        return {
            "events": events,
            "costs": costs,
            "replaced": replaced,
            "failures": failures,
            "pads_retired": len(retired),
            "retired": retired,
            "truth": {
                "volume_frac": float(pad.volume_after[self.pos - 1]),
                "wear_coeff": pad.wear_coeff,
                "rul_events": pad.n_events - self.pos,
                "life_events": pad.n_events,
                "regime": pad.label,
            },
        }


def _event_columns(segments: list[tuple[PadLife, int, int]]) -> EventBatch:
    """The step's events: views of the pad's arrays, unless a failure split the step between
    two pads. An EventBatch, not a dict, so vector envs keep each sub-env's batch whole
    instead of stacking arrays whose lengths differ between sub-envs."""
    parts = [pad.events(a, b) for pad, a, b in segments]
    if len(parts) == 1:
        return parts[0]
    merged = {
        k: np.concatenate([getattr(p, k) for p in parts]) for k in ("event", *MEASURED, *TRUTH)
    }
    return EventBatch(**merged)
