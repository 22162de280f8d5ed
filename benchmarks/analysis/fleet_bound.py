"""The Lagrangian lower bound on BrakeWearFleet-v0 (issue 30, items 1-2): its figure at the
default 12-vehicle fleet with its wall time (target < 10 min on 2 cores), the
price-directed policy's cost on the same episodes with a paired bootstrap interval of its
gap to the bound, an untuned (n, N) = (14, 3) rule on the oracle's expected RUL on the
same episodes (a comparison, not tuned), and on the small fleet the bound against the
exact reference.

Each evaluation episode (seeds 0..N-1) starts from the pads of ``env.reset(seed=s)``
(true volume and K). The prices are searched once for the mean of the episodes' starting
states; every episode's bound uses them (a bound at any prices is valid, so each is a
lower bound on that episode's expected cost). Costs are per vehicle-shift, pads priced
when fitted (:attr:`EpisodeCost.per_vehicle_shift`).

Also printed: the law-of-large-numbers check (the pads' realised hot RUL, simulated on
their streams, against the expected RUL the model uses), the one approximation of the
bound.

Run: ``.venv/bin/python benchmarks/analysis/fleet_bound.py [--episodes 10] [--iterations 80]``
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from agents.fleet.evaluation.costs import paired_interval, run_episodes
from agents.fleet.policies import reference
from agents.fleet.policies.lagrangian import BoundModel, bound, start_counts
from agents.fleet.policies.lagrangian_search import search
from agents.fleet.policies.priced import PricedPolicy
from agents.fleet.policies.rules import opportunistic_rule
from agents.fleet.policies.view import FleetLayout
from brake_env.env.fleet.config import SMALL_FLEET, FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.wrappers import ExpectedRULObservation


def starts(env: BrakeWearFleetEnv, model: BoundModel, seeds: list[int]) -> np.ndarray:
    """Each episode's pad states (rows) from its reset's truth."""
    rows = []
    for s in seeds:
        env.reset(seed=s)
        tr = env.truth()
        rows.append(model.state(tr["volume_frac"], tr["wear_coeff"]))
    return np.array(rows)


def lln_check(env: BrakeWearFleetEnv, model: BoundModel, seeds: list[int]) -> None:
    """Realised hot RUL (streams simulated ahead) minus the expected one, in hot shifts."""
    assert model.wear is not None
    if not seeds:
        return
    diff = []
    for s in seeds:
        env.reset(seed=s)
        tr = env.truth()
        expected = model.wear.rul(tr["volume_frac"], tr["wear_coeff"])
        diff.append((env.true_rul("hot") - expected) / env.config.events_per_shift)
    d = np.concatenate(diff)
    print(f"LLN check ({d.size} pads): realised - expected hot RUL [shifts]: mean {d.mean():+.2f},"
          f" sd {d.std():.2f}, min {d.min():+.2f}, max {d.max():+.2f}")  # fmt: skip


def default_fleet(args: argparse.Namespace) -> None:
    cfg = FleetConfig(episode_shifts=args.shifts)
    env = BrakeWearFleetEnv(cfg)
    seeds = list(range(args.episodes))
    t0 = time.perf_counter()
    model = BoundModel.build(cfg, env.atlas, units=args.units)
    states = starts(env, model, seeds)
    result = search(model, start_counts(model, states), args.iterations, args.step)
    per = cfg.n_vehicles * cfg.episode_shifts
    bounds = np.array([bound(model, result.program, result.prices, start_counts(model, s))
                       for s in states]) / per  # fmt: skip
    wall = time.perf_counter() - t0
    print(f"default fleet ({cfg.n_vehicles} vehicles, {cfg.episode_shifts} shifts, "
          f"{len(seeds)} episodes, units {model.units}, "
          f"mild units {model.mild_units}):")  # fmt: skip
    print(f"  bound per vehicle-shift: mean {bounds.mean():.4f} (episodes {bounds.min():.4f}"
          f"..{bounds.max():.4f}); at zero prices {result.zero_bound / per:.4f}")  # fmt: skip
    print(f"  search: {result.iterations} price vectors in {result.seconds:.1f} s; "
          f"wall time with the model and starts {wall:.1f} s")  # fmt: skip
    last = result.history[-10:] / per
    print(f"  last 10 iterations' bounds: {np.array2string(last, precision=4)}")
    t1 = time.perf_counter()
    policy = PricedPolicy(env, model, result.prices, result.program)
    costs = np.array([e.per_vehicle_shift for e in run_episodes(env, policy, seeds, True)])
    print(f"  price-directed policy: {costs.mean():.4f} per vehicle-shift "
          f"({time.perf_counter() - t1:.1f} s for {len(seeds)} episodes)")  # fmt: skip
    print(f"  its gap to the bound (paired, 95%): {paired_interval(costs, bounds)}; ratio "
          f"{paired_interval(costs, bounds, 'ratio')}")  # fmt: skip
    t2 = time.perf_counter()
    rule = opportunistic_rule(FleetLayout.of(cfg), n=14, N=3)
    rule_env = ExpectedRULObservation(BrakeWearFleetEnv(cfg, atlas=env.atlas))
    untuned = np.array([e.per_vehicle_shift for e in run_episodes(rule_env, rule, seeds, True)])
    print(f"  UNTUNED (n, N) = (14, 3) rule, oracle's expected RUL (same episodes): "
          f"{untuned.mean():.4f} per vehicle-shift ({time.perf_counter() - t2:.1f} s)")  # fmt: skip
    print(f"  price-directed minus untuned (n, N) (paired, 95%): "
          f"{paired_interval(costs, untuned)}")  # fmt: skip
    lln_check(env, model, seeds[: args.lln_episodes])


def small_fleet(args: argparse.Namespace) -> None:
    cfg = FleetConfig(**SMALL_FLEET, episode_shifts=args.small_shifts)
    env = BrakeWearFleetEnv(cfg)
    seeds = list(range(args.episodes))
    t0 = time.perf_counter()
    model = BoundModel.build(cfg, env.atlas, units=args.units)
    ref = reference.ReferenceModel.build(cfg, env.atlas)
    sol = reference.solve(ref)
    t_ref = time.perf_counter() - t0
    states = starts(env, model, seeds)
    ref_states = []
    for s in seeds:
        env.reset(seed=s)
        tr = env.truth()
        ref_states.append(ref.state(tr["volume_frac"], tr["wear_coeff"]))
    predicted = np.array([sol.predicted(ref, h) for h in ref_states])
    t1 = time.perf_counter()
    pooled = search(model, start_counts(model, states), args.iterations, args.step)
    common = np.array([bound(model, pooled.program, pooled.prices, start_counts(model, s))
                       for s in states])  # fmt: skip
    own = np.array([search(model, start_counts(model, s), iterations=args.small_iterations,
                           prices=pooled.prices).bound for s in states])  # fmt: skip
    best = np.maximum(common, own)
    per = cfg.n_vehicles * cfg.episode_shifts
    print(f"small fleet ({cfg.n_vehicles} vehicles, {cfg.episode_shifts} shifts, "
          f"{len(seeds)} episodes; reference solved in {t_ref:.1f} s, bounds in "
          f"{time.perf_counter() - t1:.1f} s):")  # fmt: skip
    print(f"  exact reference's predicted cost: {predicted.mean() / per:.4f} per vehicle-shift")
    print(f"  bound, common prices: {common.mean() / per:.4f}; each episode's own prices: "
          f"{best.mean() / per:.4f} ({1 - best.mean() / predicted.mean():.1%} below the "
          f"reference; every episode below it: {bool(np.all(best <= predicted))})")  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--episodes", type=int, default=10)
    ap.add_argument("--shifts", type=int, default=365)
    ap.add_argument("--iterations", type=int, default=80)
    ap.add_argument("--units", type=int, default=20)
    ap.add_argument("--step", type=float, default=0.0025)
    ap.add_argument("--small-shifts", type=int, default=365)
    ap.add_argument("--small-iterations", type=int, default=10)
    ap.add_argument("--lln-episodes", type=int, default=3)
    ap.add_argument("--only", choices=("default", "small"), default=None)
    args = ap.parse_args()
    if args.only != "small":
        default_fleet(args)
    if args.only != "default":
        small_fleet(args)


if __name__ == "__main__":
    main()
