"""How far ``brakewear plan`` can be trusted, on simulated fleets whose truth is known.

Each case runs a 16-truck fleet (the default fleet scaled by 4/3: 8 hot, 5 mild, a crew of
4, 3 bays) under the default suite's tuned twin rule, acting on the twin's RUL, for a random
number of shifts (30-250) of a dev-split episode. There the plan is made as
``brakewear plan`` makes it, from the twin's estimates of the pads in service (the wrapper's
own, as ``predict`` would give them on the log) and the true shop. It is then checked
against the truth:

- **marked:** of the pads on hot or mild duty that will fail before the next window if they
  keep that duty (their true RUL on the route, simulated ahead on the episode's streams), the
  share the plan services now or gives new pads by the window in most of its futures; and of
  the pads that would fail before the window on the ramp, those renewed by the window, and
  those renewed or not sent up the ramp in the coming shift;
- **interval:** the plan's cost over the horizon re-simulated from the true state (the
  episode's own streams, the same policy on the same belief) inside the plan's stated 90%
  interval of the futures' costs.

    .venv/bin/python benchmarks/analysis/plan_accuracy.py [--cases 40] [--futures 200]
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np

from agents.fleet.benchmark.suite import read_suite
from agents.fleet.operate.belief import BeliefRULObservation
from agents.fleet.operate.estimates import of_estimate, state_of
from agents.fleet.operate.futures import simulate
from agents.fleet.operate.plan import plan_summary, plan_table
from agents.fleet.operate.run import rule_factory
from agents.fleet.study.units import study_fit
from brake_env.env.atlases import default_atlas
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.route_rul import duty_clocks
from brake_env.env.fleet.wrappers import FleetRULObservation
from brake_env.prognostics.events import RULEstimate


def fleet16(config):  # type: ignore[no-untyped-def]
    return replace(config, n_vehicles=16, hot_need=8, mild_need=5, window_slots=4, bays=3,
                   episode_shifts=400)  # fmt: skip


def one_case(case: int, ctx: dict, futures: int) -> dict:  # type: ignore[type-arg]
    config, atlas, twin, factory = ctx["config"], ctx["atlas"], ctx["twin"], ctx["factory"]
    rng = np.random.default_rng(case)
    shifts = int(rng.integers(30, 251))
    env = FleetRULObservation(BrakeWearFleetEnv(config, atlas=atlas), twin.predictor,
                              fields=("rul_mean",), atlas=twin.atlas)  # fmt: skip
    obs, info = env.reset(seed=case)
    act = factory(env)
    for _ in range(shifts):
        a, _ = act.predict(obs)
        obs, _, _, _, info = env.step(a)
    base = env.unwrapped
    true = base.state()
    ri = info["rul_estimate"]
    clock = duty_clocks(atlas).base
    new = np.isnan(ri["rul_mean"])  # a pad fitted in the last shift, not read yet
    prior = clock.life(config.wear.k_mean)
    mean = np.where(new, prior, ri["rul_mean"])
    est = of_estimate(
        RULEstimate(mean, np.where(new, prior, ri["rul_lower"]),
                    np.where(new, prior, ri["rul_upper"]),
                    volume_frac=np.where(new, 1.0, ri["volume_frac"])),
        ri["base_age"], clock, [f"v{v:02d}" for v in range(config.n_vehicles)], predictor="twin",
    )  # fmt: skip
    shop = {"stock": true.stock, "transit": true.transit, "down": true.down}
    state = replace(state_of(est, config, base.shift, shop), failed_down=true.failed_down,
                    waiting=true.waiting)  # fmt: skip
    to_window = config.shifts_to_window(base.shift)
    horizon = to_window + 1
    t0 = time.process_time()
    fut = simulate(config, atlas, est, state, policy=factory, horizon=horizon, futures=futures,
                   seed=case)  # fmt: skip
    cpu = time.process_time() - t0
    plan = plan_table(est, config, atlas, fut, base.shift)
    summary = plan_summary(est, config, fut, {})
    duty = fut.first_action[: config.n_vehicles]
    drives = np.isin(duty, (0, 1))
    left = to_window * config.events_per_shift
    true_rul = base.true_rul(np.where(duty == 1, 1, 0))
    will_fail = drives & (true_rul < left)
    renewed = (duty == 3) | (plan["p_new_pads_by_window"].to_numpy() >= 0.5)
    marked = renewed
    hot_fail = base.true_rul("hot") < left  # would fail on the ramp before the window
    hot_safe = renewed | (duty != 0)  # renewed, or not sent up the ramp now
    real = BeliefRULObservation(BrakeWearFleetEnv(config, atlas=atlas), est)
    obs, _ = real.reset(seed=0, options={"state": true})
    act2, cost = factory(real), 0.0
    for _ in range(horizon):
        a, _ = act2.predict(obs)
        obs, r, _, _, _ = real.step(a)
        cost -= float(r)
    lo, hi = summary["cost_interval"]
    return {"will_fail": int(will_fail.sum()), "marked": int((will_fail & marked).sum()),
            "hot_fail": int(hot_fail.sum()), "hot_renewed": int((hot_fail & renewed).sum()),
            "hot_safe": int((hot_fail & hot_safe).sum()),
            "inside": lo <= cost <= hi, "cost": cost, "lo": lo, "hi": hi,
            "cpu": cpu, "horizon": horizon}  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", type=int, default=40)
    ap.add_argument("--futures", type=int, default=200)
    args = ap.parse_args()
    suite = read_suite("default")
    study = suite.study_config("dev")
    config = fleet16(study.fleet)
    atlas = default_atlas(config.preset)
    twin = study_fit(study, "twin", atlas, atlas)
    factory, _ = rule_factory("default", "twin", config)
    ctx = {"config": config, "atlas": atlas, "twin": twin, "factory": factory}
    rows = []
    for case in range(args.cases):
        rows.append(one_case(case, ctx, args.futures))
        r = rows[-1]
        print(f"case {case:3d}: horizon {r['horizon']:2d}, will fail {r['will_fail']}, marked"
              f" {r['marked']} (on the ramp {r['hot_fail']}, renewed {r['hot_renewed']}),"
              f" realised {r['cost']:9,.0f} in [{r['lo']:9,.0f}, {r['hi']:9,.0f}]"
              f" {'yes' if r['inside'] else 'NO'}  ({r['cpu']:.1f} s CPU)", flush=True)  # fmt: skip
    fail = sum(r["will_fail"] for r in rows)
    marked = sum(r["marked"] for r in rows)
    inside = sum(r["inside"] for r in rows)
    hot = sum(r["hot_fail"] for r in rows)
    print(f"pads that would fail before the window on the ramp: {hot}; the plan renews"
          f" {sum(r['hot_renewed'] for r in rows)} of them by the window and keeps"
          f" {sum(r['hot_safe'] for r in rows)} off the ramp or renewed")  # fmt: skip
    print(f"\npads that would fail before the window on their coming duty: {fail}, marked"
          f" {marked} ({marked / max(fail, 1):.0%}; target >= 95%)")  # fmt: skip
    print(f"realised cost inside the stated 90% interval: {inside} of {len(rows)}"
          f" ({inside / len(rows):.0%}; target >= 90%)")  # fmt: skip
    cpu = np.array([r["cpu"] for r in rows])
    print(f"futures' simulation ({args.futures} futures, 16 vehicles): median {np.median(cpu):.1f}"
          f" s CPU, max {cpu.max():.1f} s")  # fmt: skip


if __name__ == "__main__":
    main()
