"""The Lagrangian bound before and after it became a relaxation (issue 43, item 3), on the
``default`` suite's fleet (12 vehicles, 365 shifts) and its dev episodes (seeds 0..19; never
the test split), priced as the study prices it (:func:`agents.fleet.study.planners.study_bound`:
the net cost, one price search for the episodes' mean start, each episode's bound at its own
start). Printed per model, with the CPU time of the model, the starts and the search:

- ``expectation``: wear per shift at its expectation, mild wear at the least ratio (the
  bound before; an approximation, not a bound);
- ``slack 1 shift``: the same with one hot shift of slack on every pad (the old cover);
- ``relaxed``: :meth:`BoundModel.relaxed`: the slack sized from the realised wear at
  ``--coverage`` (the bound now);
- ``relaxed+layers``: the same with mild wear by the pad's layer (K cut at 3 sd);
- ``relaxed+orders``: the same with each fit beyond the initial stock charged its share of
  an order (``order / max_order``; still a relaxation: :mod:`agents.fleet.policies.lagrangian`).

Also printed: the realised slack at a few coverages, and the mild route's spread against the
hot route's (both on the env's own pad code).

Run: ``.venv/bin/python benchmarks/analysis/fleet_bound_relaxation.py [--iterations 100]
[--models expectation,slack,relaxed,relaxed+layers,relaxed+orders]``
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from agents.fleet.benchmark.suite import Suite, read_suite
from agents.fleet.policies.lagrangian import BoundModel, bound, start_counts
from agents.fleet.policies.lagrangian_search import search
from agents.fleet.policies.lagrangian_wear import pads_ahead
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.pads import FleetPads
from brake_env.env.fleet.routes import HOT, MILD, ROUTE_INDEX, route_wear_model
from brake_env.model.atlas import Atlas


def model_of(name: str, args: argparse.Namespace, cfg: FleetConfig, atlas: Atlas) -> BoundModel:
    if name == "expectation":
        return BoundModel.build(cfg, atlas, credit=True)
    if name == "slack":
        return BoundModel.build(cfg, atlas, slack_shifts=1.0, credit=True)
    layers, orders = "+layers" in name, "+orders" in name
    return BoundModel.relaxed(
        cfg, atlas, args.units, args.coverage, credit=True, orders=orders, layers=layers
    )


def one_bound(name: str, args: argparse.Namespace, suite: Suite, atlas: Atlas) -> None:
    cfg = suite.study_config("dev").fleet
    env = BrakeWearFleetEnv(cfg, atlas=atlas)
    t0 = time.process_time()
    model = model_of(name, args, cfg, atlas)
    states = []
    for seed in suite.seeds("dev"):
        env.reset(seed=seed)
        tr = env.truth()
        states.append(model.state(tr["volume_frac"], tr["wear_coeff"]))
    result = search(model, start_counts(model, np.array(states)), args.iterations)
    per = cfg.n_vehicles * cfg.episode_shifts
    b = [bound(model, result.program, result.prices, start_counts(model, s)) / per for s in states]
    cpu = time.process_time() - t0
    print(f"{name:12s} bound {np.mean(b):.4f} per vehicle-shift (episodes {min(b):.4f}.."
          f"{max(b):.4f}); zero prices {result.zero_bound / per:.4f}; units {model.units},"
          f" slack {model.slack} units, states {model.H + 1}; CPU {cpu:.1f} s")  # fmt: skip


def spread(atlas: Atlas, cfg: FleetConfig, pads: int) -> None:
    """Each route's realised wear over 100 shifts of new pads, in hot shifts of RUL: the
    sd around the expectation."""
    wear = route_wear_model(atlas, HOT)
    eps = cfg.events_per_shift
    for route in (HOT, MILD):
        sim = FleetPads(atlas, pads, cfg.noise, max(4 * eps, 4096))
        rng = np.random.default_rng(1)
        k = cfg.wear.draw(rng, "id", pads)
        for v in range(pads):
            sim.install(v, float(k[v]), "id", int(rng.integers(2**63)))
        shifts = 100 if route is HOT else 300
        for _ in range(shifts):
            sim.advance(np.full(pads, eps), np.full(pads, ROUTE_INDEX[route.name]), measure=False)
        used = (wear.life(k) - wear.rul(np.clip(sim.vol, wear.lower_edges[-1], 1.0), k)) / eps
        print(f"  {route.name} route, {shifts} shifts: RUL used {used.mean():.2f} hot shifts,"
              f" sd {used.std():.3f} (pads {pads})")  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--iterations", type=int, default=100)
    ap.add_argument("--units", type=int, default=20)
    ap.add_argument("--coverage", type=float, default=0.99)
    ap.add_argument("--models", default="expectation,slack,relaxed")
    ap.add_argument("--pads", type=int, default=256)
    args = ap.parse_args()
    suite = read_suite("default")
    cfg = suite.study_config("dev").fleet
    atlas = BrakeWearFleetEnv(cfg).atlas
    t0 = time.process_time()
    ahead = pads_ahead(atlas, cfg, args.pads)
    for cov in (0.5, 0.9, 0.99, 0.999):
        print(f"realised slack at coverage {cov}: {np.quantile(ahead, cov):.3f} hot shifts"
              f" ({args.pads} pads; most ahead {ahead.max():.3f})")  # fmt: skip
    print(f"  ({time.process_time() - t0:.1f} s CPU)")
    spread(atlas, cfg, 64)
    for name in args.models.split(","):
        one_bound(name, args, suite, atlas)


if __name__ == "__main__":
    main()
