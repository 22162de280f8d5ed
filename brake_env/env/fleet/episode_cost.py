"""An episode's cost per vehicle-shift, as the benchmark scores it: the headline (pads priced
when fitted) and the net (less the pad life left at the end), and the wrapper that puts both
in the last step's ``info`` (``BrakeWearFleet-v2``).

The headline prices pads when fitted, so that neither the free initial stock nor the spares
left at the end (which the env's bill prices when ordered) move it; order and holding costs
are in. The net also credits the pad life left at the end at the price of a fitted pad's
expected hot life (:func:`credit_life`): an episode's end is arbitrary (the mine goes on),
and a policy that runs its pads down before it leaves the next shifts the bill. The
Lagrangian bound is on the net.

``BrakeWearFleet-v2`` prices that life over a new pad's life with each wear label at its
mean K, weighted by the regime's shares; ``v1`` priced it over a mean-K pad's life. The two
are the same number in the ``id`` regime; in ``mixed`` the v1 price credited a fresh pad
1.33 times its cost on average (slow pads live 2.5 times as long as a mean-K one), so a
policy gained by fitting pads just before the episode's end.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np

from brake_env.env.config import RegimeFields
from brake_env.env.fleet.config import COST_TERMS
from brake_env.env.fleet.routes import HOT, route_wear_model
from brake_env.model.wear import WearModel

FITS = ("window_fits", "shop_fits", "visits", "corrective_fits")
"""The counts that each fit a pad set (``info["counts"]``)."""


def credit_life(config: RegimeFields, wear: WearModel) -> float:
    """The hot life [events] over which a fit's ``pad + labour`` prices the life left: a new
    pad's expected life with each label at its mean K, weighted by the regime's shares
    (``wear.life(k_mean)`` exactly in the ``id`` regime; module docstring)."""
    return float(sum(s * float(wear.life(k)) for s, k in config.pad_regime.components()))


def life_value(env: Any) -> float:
    """The fleet's pad life left now, priced: each pad's expected hot life [events] (its
    true volume and K) times ``pad + labour`` over :func:`credit_life`, summed."""
    c = env.config
    wear = route_wear_model(env.atlas, HOT)
    truth = env.truth()
    left = wear.rul(np.clip(truth["volume_frac"], wear.lower_edges[-1], 1.0), truth["wear_coeff"])
    per_event = (c.costs.pad + c.costs.labour) / credit_life(c, wear)
    return float(per_event * left.sum())


def headline(
    terms: Mapping[str, float], counts: Mapping[str, float], vehicles: int, shifts: int,
    pad_price: float,
) -> float:  # fmt: skip
    """The headline cost per vehicle-shift: the bill with pads priced when fitted."""
    pads = pad_price * float(sum(counts.get(k, 0) for k in FITS)) - terms["pad"]
    return (float(sum(terms.values())) + pads) / (vehicles * shifts)


class EpisodeCostInfo(gym.Wrapper[Any, Any, Any, Any]):
    """Adds ``info["episode_cost"]`` on an episode's last step (terminated or truncated):
    ``cost`` (:func:`headline`), ``net`` (less :func:`life_value`), ``billed`` (the env's
    bill per vehicle-shift) and ``shifts``; every figure per vehicle-shift, in the fleet's
    currency. The sums run over the steps since the last reset.
    """

    def __init__(self, env: gym.Env[Any, Any]) -> None:
        super().__init__(env)
        self._terms: dict[str, float] = {}
        self._counts: dict[str, float] = {}
        self._shifts = 0

    def reset(self, **kwargs: Any) -> Any:
        self._terms, self._counts, self._shifts = dict.fromkeys(COST_TERMS, 0.0), {}, 0
        return self.env.reset(**kwargs)

    def step(self, action: Any) -> Any:
        obs, reward, terminated, truncated, info = self.env.step(action)
        for k, v in info["costs"].items():
            self._terms[k] = self._terms.get(k, 0.0) + float(v)
        for k, v in info["counts"].items():
            self._counts[k] = self._counts.get(k, 0.0) + float(v)
        self._shifts += 1
        if terminated or truncated:
            base = self.env.unwrapped
            c: Any = base.config  # type: ignore[attr-defined]
            n, s = int(c.n_vehicles), self._shifts
            cost = headline(self._terms, self._counts, n, s, c.costs.pad)
            info = {**info, "episode_cost": {
                "cost": cost, "net": cost - life_value(base) / (n * s),
                "billed": sum(self._terms.values()) / (n * s), "shifts": s,
            }}  # fmt: skip
        return obs, reward, terminated, truncated, info
