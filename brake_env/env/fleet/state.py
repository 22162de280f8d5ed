"""The fleet env's state at the start of a shift, read from an episode or built from logs,
and the env reset from it (``reset(options={"state": state})``).

A :class:`FleetState` holds what a maintenance planner knows of the fleet today: each
vehicle's installed pad (K, wear regime, events braked, volume), the spares in stock and on
order, the vehicles in the shop and the shift in the window cycle. Built from a log
(``brakewear plan``), it has no ``streams``: the env draws each pad's future conditions,
sensor noise and breakdowns from the reset's seed, as at any reset. Read from an env
(:func:`read_state`), it also carries the env's random streams and the pads' place in the
atlas layer, so the env reset from it continues that episode exactly (tested array-equal).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from brake_env.env.fleet import spaces as fs
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.pads import FleetPads
from brake_env.model.simulator import check_wear_per_event

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
B = NDArray[np.bool_]
SUMMARY_WIDTH = 8  # spaces.shift_summary's columns


@dataclass(frozen=True, eq=False)
class EpisodeStreams:
    """What makes the rest of an episode exactly its own: the pads with their buffered
    draws and layer state, and the env's generators (copies; the env is not touched)."""

    pads: FleetPads
    pad_rngs: list[np.random.Generator]
    break_rng: np.random.Generator
    serial: I64


@dataclass(frozen=True, eq=False)
class FleetState:
    """The fleet at the start of shift ``shift``.

    Attributes:
        shift: Index of the coming shift; with the config's ``window_period`` it places the
            fleet in the window cycle (``config.shifts_to_window(shift)``).
        wear_coeff: Each vehicle's installed pad's K [m^3/J].
        regime: Each pad's wear-regime label (``id``, ``ood_slow``...).
        pad_age: Events each pad has braked since it was installed.
        volume_frac: Each pad's remaining volume, a fraction of a new pad's.
        stock: Spare pad sets in stock.
        transit: Pads arriving at the start of each of the next ``lead_time`` shifts
            (``transit[0]``: the coming shift's start); shorter is padded with zeros.
        down: Shifts each vehicle is still out in the shop (0: available).
        failed_down: Down because of a brake failure (else another breakdown).
        waiting: Failed and waiting for a spare.
        summary: The last shift's per-vehicle sensor summary (the observation's first 8
            values per vehicle); None: zeros, as after a reset.
        streams: The episode's random streams (:func:`read_state`); None: fresh streams.
    """

    shift: int
    wear_coeff: F64
    regime: tuple[str, ...]
    pad_age: I64
    volume_frac: F64
    stock: int
    transit: I64
    down: I64
    failed_down: B
    waiting: B
    summary: F64 | None = None
    streams: EpisodeStreams | None = field(default=None, repr=False)

    @property
    def n_vehicles(self) -> int:
        return int(np.asarray(self.wear_coeff).size)

    def check(self, config: FleetConfig, pads: FleetPads) -> None:
        """One ``ValueError`` naming the first field that does not fit ``config`` (sizes,
        ranges) or the atlas (a K it cannot resolve, a volume outside the pad's life)."""
        n = config.n_vehicles
        who = "FleetState"
        per = {"wear_coeff": self.wear_coeff, "pad_age": self.pad_age,
               "volume_frac": self.volume_frac, "down": self.down,
               "failed_down": self.failed_down, "waiting": self.waiting,
               "regime": np.asarray(self.regime, dtype=object)}  # fmt: skip
        for name, x in per.items():
            if np.asarray(x).shape != (n,):
                raise ValueError(f"{who}.{name}: {n} values (one per vehicle), got shape"
                                 f" {np.asarray(x).shape}")  # fmt: skip
        k = np.asarray(self.wear_coeff, dtype=np.float64)
        vol = np.asarray(self.volume_frac, dtype=np.float64)
        _check_finite(who, "wear_coeff", k, lowest=0.0, strict=True)
        _check_finite(who, "volume_frac", vol, lowest=float(pads.edges[-1]), highest=1.0)
        _check_finite(who, "pad_age", np.asarray(self.pad_age, dtype=np.float64), lowest=0.0)
        _check_finite(who, "down", np.asarray(self.down, dtype=np.float64), lowest=0.0)
        check_wear_per_event(pads.atlas, float(k.max()))
        if not 0 <= int(self.shift) < config.episode_shifts:
            raise ValueError(f"{who}.shift: {self.shift} is outside the episode's"
                             f" [0, {config.episode_shifts})")  # fmt: skip
        if int(self.stock) < 0:
            raise ValueError(f"{who}.stock: {self.stock} < 0")
        t = np.asarray(self.transit)
        if t.ndim != 1 or t.size > config.lead_time or np.any(t < 0):
            raise ValueError(f"{who}.transit: at most lead_time = {config.lead_time}"
                             f" non-negative counts, got {t.tolist()}")  # fmt: skip
        if self.summary is not None and np.shape(self.summary) != (n, SUMMARY_WIDTH):
            raise ValueError(f"{who}.summary: shape ({n}, {SUMMARY_WIDTH}), got"
                             f" {np.shape(self.summary)}")  # fmt: skip


def _check_finite(
    who: str, name: str, x: F64, *, lowest: float, highest: float = np.inf, strict: bool = False
) -> None:
    bad = ~np.isfinite(x) | (x <= lowest if strict else x < lowest) | (x > highest)
    if bad.any():
        v = int(np.flatnonzero(bad)[0])
        rel = ">" if strict else ">="
        raise ValueError(f"{who}.{name}: vehicle {v} has {float(x[v])!r}; each must be finite,"
                         f" {rel} {lowest:g} and <= {highest:g}")  # fmt: skip


def read_state(env: Any) -> FleetState:
    """The state of a running fleet env (``env.unwrapped``), its streams included: the env
    reset from it goes on exactly as this episode would."""
    base = env.unwrapped
    if base.pads is None:
        raise RuntimeError("read_state: the env has not been reset")
    p, shop = base.pads, base.shop
    return FleetState(
        shift=int(base.shift), wear_coeff=p.k.copy(), regime=tuple(str(x) for x in p.label),
        pad_age=p.pos.copy(), volume_frac=p.vol.copy(), stock=int(shop.stock),
        transit=shop.transit.copy(), down=shop.down.copy(),
        failed_down=shop.failed_down.copy(), waiting=shop.waiting.copy(),
        summary=fs.shift_summary(base.shift_events(), p.n),
        streams=EpisodeStreams(p.clone(), copy.deepcopy(base._pad_rngs),
                               copy.deepcopy(base._break_rng), p.serial.copy()),
    )  # fmt: skip


def restore(env: Any, state: FleetState) -> None:
    """Put the freshly reset ``env`` (its pads installed and aged, its shop new) into
    ``state``. Without streams each pad keeps the streams the reset drew for it and starts
    at the state's age and volume."""
    config: FleetConfig = env.config
    if not isinstance(state, FleetState):
        raise ValueError(f"reset(options={{'state': ...}}) takes a FleetState, got"
                         f" {type(state).__name__}")  # fmt: skip
    state.check(config, env.pads)
    if state.streams is not None:
        s = state.streams
        env.pads = s.pads.clone()
        env._pad_rngs = copy.deepcopy(s.pad_rngs)
        env._break_rng = copy.deepcopy(s.break_rng)
    else:
        pads = env.pads
        for v in range(config.n_vehicles):  # the state's pad on the reset's streams
            entropy = int(env._pad_rngs[v].integers(2**63))
            pads.install(v, float(state.wear_coeff[v]), str(state.regime[v]), entropy)
        pads.serial[:] = 1
        pads.start_at(np.asarray(state.pad_age, dtype=np.int64),
                      np.asarray(state.volume_frac, dtype=np.float64))  # fmt: skip
    shop = env.shop
    shop.stock = int(state.stock)
    shop.transit[:] = 0
    t = np.asarray(state.transit, dtype=np.int64)
    shop.transit[: t.size] = t
    shop.down[:] = state.down
    shop.failed_down[:] = state.failed_down
    shop.waiting[:] = state.waiting
    env.shift = int(state.shift)
