"""The rollout planner's parts at the default 12-vehicle fleet (issue 30, item 3): the
planning model's error against the env, the batched rule's speed against the rule one
state at a time, and the planner's decision time.

1. **Model error.** From the env's own state at shifts 0, 30, 60, ... of evaluation
   episodes (its truth: pads' expected hot life, the shop, the stock and the orders in
   transit), the base rule is run ``--horizon`` shifts in a copy of the env and in the
   planning model (``--samples`` futures); the cost of the two is compared (mean and
   spread of the difference, per vehicle-shift). The env copy is one realisation of its
   randomness (its breakdown draws, the wear's noise), the model's figure an average: the
   mean difference is the model's bias, its spread mostly the env's noise.
2. **Batched rule.** ``batch_rule.act`` on a batch of states against ``FleetRule.act`` on
   each (the same decisions, tested equal): states per second of each, and their ratio.
3. **Decision time.** ``RolloutPolicy.act`` per shift at the default settings, over the
   first shifts of an episode.

Run: ``.venv/bin/python benchmarks/analysis/rollout_model_error.py [--episodes 4] [--horizon 28]``
"""

from __future__ import annotations

import argparse
import copy
import time

import numpy as np

from agents.fleet.policies import batch_rule
from agents.fleet.policies.planning import PlanningModel
from agents.fleet.policies.rollout import RolloutPolicy
from agents.fleet.policies.rules import FleetRule, FleetRuleParams
from agents.fleet.policies.view import FleetLayout, FleetView
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.routes import HOT, route_wear_model
from brake_env.env.fleet.wrappers import ExpectedRULObservation

# A capacity-aware rule with the healthiest on the ramp (untuned; any base works)
BASE = FleetRuleParams(must=3, window_limit=20, shop_limit=15, greedy=True, duty="rul")


def model_error(env, model, rule, args) -> np.ndarray:
    """Per start: (model's mean cost - the env copy's cost) per vehicle-shift."""
    c = model.config
    wear = route_wear_model(env.unwrapped.atlas, HOT)
    out = []
    for seed in range(args.episodes):
        obs, _ = env.reset(seed=seed)
        for t in range(c.episode_shifts - args.horizon):
            if t % 30 == 0:
                out.append(_one(env, obs, model, rule, wear, args))
            obs, *_ = env.step(rule.act(FleetView.read(obs, rule.layout)))
    return np.array(out)


def _one(env, obs, model, rule, wear, args) -> float:
    base, c = env.unwrapped, model.config
    tr, shop = base.truth(), base.shop
    h = wear.rul(np.clip(tr["volume_frac"], wear.lower_edges[-1], 1.0), tr["wear_coeff"])
    s = model.start(np.repeat(h[None] / c.events_per_shift, args.samples, 0), tr["pad_age"],
                    shop.down, shop.stock, shop.transit, base.shift)  # fmt: skip
    s.failed[:], s.waiting[:] = shop.failed_down, shop.waiting
    futures = model.draw(np.random.default_rng(base.shift), args.samples, args.horizon)
    rows, cost = np.arange(args.samples), np.zeros(args.samples)
    for k in range(args.horizon):
        view = batch_rule.BatchView(s.h, s.down > 0, s.stock, s.transit.sum(1),
                                    s.free_bays(c.bays), c.shifts_to_window(s.shift))  # fmt: skip
        duty, order = batch_rule.act(rule.params, c, view)
        cost += model.step(s, duty, order, futures, k, rows)
    twin, o, real = copy.deepcopy(env), obs, 0.0
    for _ in range(args.horizon):
        a = rule.act(FleetView.read(o, rule.layout))
        o, _, _, _, info = twin.step(a)
        n = info["counts"]
        fits = n["window_fits"] + n["shop_fits"] + n["visits"] + n["corrective_fits"]
        real += sum(info["costs"].values()) + c.costs.pad * (fits - n["ordered"])
    return float((cost.mean() - real) / (c.n_vehicles * args.horizon))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--episodes", type=int, default=4)
    p.add_argument("--horizon", type=int, default=28)
    p.add_argument("--samples", type=int, default=16)
    p.add_argument("--decisions", type=int, default=40, help="shifts timed")
    args = p.parse_args()
    cfg = FleetConfig(episode_shifts=365)
    env = ExpectedRULObservation(BrakeWearFleetEnv(cfg))
    model = PlanningModel.build(cfg, env.unwrapped.atlas)
    rule = FleetRule(FleetLayout.of(cfg), BASE, "base")
    t0 = time.perf_counter()
    err = model_error(env, model, rule, args)
    print(f"model error, {len(err)} starts ({args.episodes} episodes, every 30 shifts), "
          f"{args.horizon} shifts of the base rule: model - env per vehicle-shift mean "
          f"{err.mean():+.3f} (sd {err.std():.3f}, median {np.median(err):+.3f}, "
          f"|err| < 0.5 at {np.mean(np.abs(err) < 0.5):.0%}); "
          f"{time.perf_counter() - t0:.0f} s")  # fmt: skip
    views = []
    obs, _ = env.reset(seed=100)
    for _ in range(200):
        v = FleetView.read(obs, rule.layout)
        views.append(v)
        obs, *_ = env.step(rule.act(v))
    bv = batch_rule.BatchView(np.stack([v.rul for v in views]), np.stack([v.down for v in views]),
                              np.array([v.stock for v in views]),
                              np.array([v.transit for v in views]),
                              np.array([v.free_bays for v in views]), 1)  # fmt: skip
    t1 = time.perf_counter()
    for _ in range(20):
        batch_rule.act(rule.params, cfg, bv)
    fast = 20 * len(views) / (time.perf_counter() - t1)
    t2 = time.perf_counter()
    for v in views:
        rule.act(v)
    slow = len(views) / (time.perf_counter() - t2)
    print(f"batched rule: {fast:,.0f} states/s against FleetRule.act's {slow:,.0f} "
          f"({fast / slow:.0f}x), batches of {len(views)}")  # fmt: skip
    policy = RolloutPolicy(rule, model, args.horizon, args.samples)
    obs, _ = env.reset(seed=0)
    times = []
    for _ in range(args.decisions):
        t3 = time.perf_counter()
        a = policy.act(obs)
        times.append(time.perf_counter() - t3)
        obs, *_ = env.step(a)
    print(f"rollout decision: {np.mean(times):.3f} s a shift (median {np.median(times):.3f},"
          f" max {np.max(times):.3f}; {args.decisions} shifts, horizon {args.horizon},"
          f" {args.samples} futures)")  # fmt: skip


if __name__ == "__main__":
    main()
