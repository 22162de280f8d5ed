"""BrakeWearFleet-v0 as a maintenance planner meets it: the small fleet, three fleet rules
with the oracle's RUL, and the perfect-information reference on the same episodes.

Run: ``python examples/fleet_policies.py`` (~20 s on 2 cores). The small fleet
(``SMALL_FLEET``: 2 vehicles, one needed on the ramp and one in the drifts, a window crew
of one) runs a few short episodes under a per-vehicle RUL threshold, the time-to-window
control limit and the (n, N) opportunistic limits, each with fixed (untuned) limits in
shifts of hot duty, and under the reference (an exact dynamic program on the true pad
states, followed in the env). Every policy sees the same pads and breakdowns (common random
numbers); the printout is the cost per vehicle-shift and where it goes. Tuning and
intervals are in ``brakewear fleet-study`` and ``benchmarks/analysis/fleet_room.py``
(docs/results/fleet.md, "Room to decide").
"""

from __future__ import annotations

from typing import Any

import numpy as np

from agents.fleet.evaluation.costs import run_episodes, term_means
from agents.fleet.policies.reference import ReferenceModel, ReferencePolicy, solve
from agents.fleet.policies.rules import opportunistic_rule, threshold_rule, window_rule
from agents.fleet.policies.view import FleetLayout
from brake_env.env.fleet.config import SMALL_FLEET, FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.wrappers import ExpectedRULObservation
from brake_env.output import table

SHOWN = ("pad", "labour", "shop_visit", "damage", "downtime", "shortfall", "mild_shortfall")


def main(episodes: int = 3, shifts: int = 180, tail: int = 100) -> dict[str, Any]:
    """Run the rules and the reference on ``episodes`` episodes (seeds 0, 1, ...).

    Returns:
        ``{policy: {"cost": mean cost per vehicle-shift, "failures": per episode,
        "window_fits": per episode}}``.
    """
    config = FleetConfig(**SMALL_FLEET, episode_shifts=shifts)
    env = ExpectedRULObservation(BrakeWearFleetEnv(config))  # the oracle's RUL appended
    layout = FleetLayout.of(config)
    period = config.window_period
    policies: dict[str, Any] = {
        "threshold (5 shifts)": threshold_rule(layout, 5.0),
        "time-to-window (+5)": window_rule(layout, period, margin=5.0, must=3.0),
        "(n, N) = (15, 2)": opportunistic_rule(layout, n=15.0, N=2.0),
    }
    model = ReferenceModel.build(config, env.unwrapped.atlas)
    policies["perfect-information reference"] = ReferencePolicy(env, model, solve(model, tail))
    seeds = list(range(episodes))
    out, rows = {}, [["policy", "cost/veh-shift", *SHOWN, "failures", "window fits"]]
    for name, policy in policies.items():
        eps = run_episodes(env, policy, seeds, check_masks=True)
        cost = float(np.mean([e.per_vehicle_shift for e in eps]))
        terms = [term_means(eps)[t] for t in SHOWN]
        failures = float(np.mean([e.counts["failures"] for e in eps]))
        fits = float(np.mean([e.counts["window_fits"] for e in eps]))
        out[name] = {"cost": cost, "failures": failures, "window_fits": fits}
        rows.append([name, f"{cost:.2f}", *(f"{t:.2f}" for t in terms), f"{failures:.1f}",
                     f"{fits:.1f}"])  # fmt: skip
    print(f"Small fleet {SMALL_FLEET}, {episodes} episodes of {shifts} shifts, oracle RUL;")
    print("cost per vehicle-shift and its terms (pads priced when fitted):")
    print(table(rows))
    return out


if __name__ == "__main__":
    main()
