"""Accuracy of route RUL on fleet episodes (issue 31, item 3): every predictor's hot- and
mild-route RUL against the simulated-ahead true RUL of the same pads, by age.

One env runs a stated duty (:class:`AccuracyConfig`); every predictor reads the same
shifts through its own :class:`~brake_env.env.fleet.route_rul.RouteTracker` (as
:class:`~brake_env.env.fleet.wrappers.FleetRULObservation` would). Every ``sample_every``
shifts each vehicle's estimate on each route is compared with
:meth:`~brake_env.env.fleet.env.BrakeWearFleetEnv.true_rul` on that route. The error is in
per cent of the pad's life on that route at its true K; its age is the share of its hot
life used, ``1 - true hot RUL / hot life``. ``oracle`` is the closed-form expected RUL
(:class:`~brake_env.env.fleet.wrappers.ExpectedRULObservation`, the study's oracle): the
simulated-ahead oracle is the truth itself.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.route_rul import ROUTE_NAMES, RouteTracker, duty_clocks
from brake_env.env.fleet.shop import HOT, MILD, SERVICE
from brake_env.model.atlas import Atlas
from brake_env.prognostics.fleet import LoopFleet, vectorises
from brake_env.prognostics.protocol import Predictor

AGE_BINS = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)


@dataclass(frozen=True)
class AccuracyConfig:
    """The episodes the route RUL is scored on.

    Attributes:
        episodes: Episodes (seeds ``seed``, ``seed + 1``, ...) [-].
        shifts: Shifts per episode [shifts].
        sample_every: Shifts between two comparisons [shifts].
        block: Each vehicle keeps a route this many shifts, then the next in its cycle
            [shifts].
        hot_share: Every this-many-th block of a vehicle is on the ramp, the others in the
            drifts; vehicles start at different places in the cycle [-].
        replace_below: At a window, pads whose true hot RUL is below this many hot shifts
            get new pads (the truth decides: this scores prognostics, not a policy)
            [shifts].
    """

    episodes: int = 2
    shifts: int = 730
    sample_every: int = 10
    block: int = 5
    hot_share: int = 2
    replace_below: float = 15.0

    def __post_init__(self) -> None:
        for name in ("episodes", "shifts", "sample_every", "block", "hot_share"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ValueError(f"AccuracyConfig.{name} must be an int >= 1, got {v!r}")
        if not self.replace_below >= 0:
            raise ValueError(f"AccuracyConfig.replace_below must be >= 0, got {self.replace_below}")


def duty(config: AccuracyConfig, env: BrakeWearFleetEnv) -> np.ndarray:
    """The shift's action: each vehicle on its route of the cycle; at a window, service
    for the pads the truth says will not last (no order: the stock is refilled by hand)."""
    n, shift = env.config.n_vehicles, env.shift
    cycle = (shift // config.block + np.arange(n)) % config.hot_share
    action = np.append(np.where(cycle == 0, HOT, MILD), 0)
    if env.config.is_window(shift):
        hot = env.true_rul("hot") / env.config.events_per_shift
        action[:n] = np.where(hot < config.replace_below, SERVICE, 2)
    return action


def _trackers(fitted: dict[str, Predictor], env: BrakeWearFleetEnv) -> dict[str, RouteTracker]:
    n, k_mean = env.config.n_vehicles, env.config.wear.k_mean
    return {
        name: RouteTracker(
            p.fleet(n) if vectorises(p) else LoopFleet(p, n),
            env.atlas,
            ROUTE_NAMES,
            k_mean,
        )
        for name, p in fitted.items()
    }


def _sample(
    env: BrakeWearFleetEnv, trackers: dict[str, RouteTracker], episode: int
) -> list[dict[str, Any]]:
    """One comparison of every predictor's route RUL (and the closed-form oracle's) with
    the true RUL of every vehicle."""
    clocks = duty_clocks(env.atlas, ROUTE_NAMES)
    truth = env.truth()
    v = np.clip(truth["volume_frac"], clocks.base.lower_edges[-1], 1.0)
    k = truth["wear_coeff"]
    true = {r: env.true_rul(r).astype(np.float64) for r in ROUTE_NAMES}
    lives = {r: c.life(k) for r, c in zip(ROUTE_NAMES, clocks.routes, strict=True)}
    age = 1.0 - true["hot"] / lives["hot"]
    est = {name: t.route_rul() for name, t in trackers.items()}
    rows = []
    for j, route in enumerate(ROUTE_NAMES):
        expected = clocks.routes[j].rul(v, k)
        per = {n: (e.mean[:, j], e.lower[:, j], e.upper[:, j]) for n, e in est.items()}
        per["oracle"] = (expected, expected, expected)
        for name, r in per.items():
            for i in range(env.config.n_vehicles):
                rows.append({
                    "episode": episode, "shift": env.shift, "vehicle": i, "predictor": name,
                    "route": route, "mean": r[0][i], "lower": r[1][i], "upper": r[2][i],
                    "true": true[route][i], "life": lives[route][i], "age": age[i],
                })  # fmt: skip
    return rows


def route_samples(
    atlas: Atlas, fitted: dict[str, Predictor], config: AccuracyConfig, seed: int = 0
) -> pd.DataFrame:
    """Every comparison (module docstring) of every episode, one row per vehicle,
    predictor and route."""
    rows: list[dict[str, Any]] = []
    for e in range(config.episodes):
        env = BrakeWearFleetEnv(
            atlas=atlas, episode_shifts=config.shifts, breakdown_rate=0.0,
            initial_stock=10_000, window_slots=12,
        )  # fmt: skip
        env.reset(seed=seed + e)
        trackers = _trackers(fitted, env)
        for t in trackers.values():
            t.reset(env.pads.pos.astype(np.float64))  # type: ignore[union-attr]
        for s in range(config.shifts):
            _, _, _, _, info = env.step(duty(config, env))
            pos = env.pads.pos  # type: ignore[union-attr]
            for t in trackers.values():
                t.after_step(env.shift_events(), info["vehicles"]["route"], pos)
            if (s + 1) % config.sample_every == 0:
                rows += _sample(env, trackers, e)
    return pd.DataFrame(rows)


def accuracy_table(samples: pd.DataFrame, bins: tuple[float, ...] = AGE_BINS) -> pd.DataFrame:
    """RMSE (% of the route's life) and interval coverage per predictor, route and age bin
    (the share of hot life used), and over all ages; pads with true RUL 0 left out."""
    s = samples[samples["true"] > 0].copy()
    s["err"] = 100.0 * (s["mean"] - s["true"]) / s["life"]
    s["covered"] = (s["lower"] <= s["true"]) & (s["true"] <= s["upper"])
    s["has_interval"] = s["upper"] > s["lower"]
    labels = [f"{100 * a:.0f}-{100 * b:.0f}%" for a, b in itertools.pairwise(bins)]
    s["age_bin"] = pd.cut(s["age"].clip(0, 0.999999), list(bins), labels=labels, right=False)
    out = []
    groups = [
        *s.groupby(["predictor", "route", "age_bin"], observed=True, sort=False),
        *(((*k, "all"), g) for k, g in s.groupby(["predictor", "route"], sort=False)),
    ]
    for keys, g in groups:
        iv = g["has_interval"].any()
        out.append({
            "predictor": keys[0], "route": keys[1], "age": keys[2], "n": len(g),
            "rmse_pct_life": float(np.sqrt((g["err"] ** 2).mean())),
            "bias_pct_life": float(g["err"].mean()),
            "coverage": float(g["covered"].mean()) if iv else float("nan"),
        })  # fmt: skip
    return pd.DataFrame(out)
