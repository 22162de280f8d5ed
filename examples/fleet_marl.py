"""A shared policy for every vehicle, trained through TorchRL (MAPPO) on the PettingZoo fleet
env, against the tuned fleet rule it starts from.

Run: ``python examples/fleet_marl.py`` (the small fleet, about a minute), or
``python examples/fleet_marl.py --size default --imitate 10 --frames 10000 --eval-seeds 10``
(the measurement of docs/results/fleet.md, "A shared policy through TorchRL").

The env is ``BrakeWearFleetParallelEnv(predictor="oracle", spares=(s, S))``: each vehicle
sees its own state, the fleet's, the needs of the shift, its RUL (the oracle's closed form)
and its rank by RUL; spares follow the teacher's (s, S) rule, so every agent is a vehicle
with the same spaces. The teacher is the best combination tuned with the oracle's RUL on the
default fleet (``TUNED_DEFAULT``: ``brakewear fleet-study --size default --predictors oracle
--heuristics "(n, N)" "best combination" --trials 15 --trials-best 30 --tune-episodes 2
--eval-episodes 10 --agents ''``). The policy is cloned from it (masked cross-entropy on its
recorded shifts), then fine-tuned with TorchRL's ClipPPOLoss; both are evaluated on the same
episodes (seeds 0, 1, ...; common random numbers) with the same function as every fleet
policy, every action checked against the env's mask.
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from agents.fleet.evaluation.costs import paired_interval, run_episodes
from agents.fleet.learning.marl import MarlTraining, train_marl
from agents.fleet.policies.rules import FleetRule, FleetRuleParams
from agents.fleet.policies.view import FleetLayout
from brake_env.env.fleet.config import SMALL_FLEET, FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.parallel import BrakeWearFleetParallelEnv
from brake_env.env.fleet.wrappers import ExpectedRULObservation

# The best combination's tuned parameters with the oracle's RUL on the default fleet
# (module docstring's command; 3.40 per vehicle-shift on evaluation episodes 0-9).
TUNED_DEFAULT = {"must": 7.823, "margin": 2.866, "shop_minus_must": 9.386, "greedy": True,
                 "duty": "rul", "spare_duty": "mild", "s": 1, "S_minus_s": 2}  # fmt: skip


def teacher(config: FleetConfig) -> FleetRule:
    """The tuned best combination (``TUNED_DEFAULT``), in shifts of hot duty."""
    t = TUNED_DEFAULT
    p = FleetRuleParams(
        must=t["must"], window_limit=config.window_period - 1 + t["margin"],
        shop_limit=t["must"] + t["shop_minus_must"], greedy=t["greedy"], duty=t["duty"],
        spare_duty=t["spare_duty"], s=t["s"], S=t["s"] + t["S_minus_s"],
    )  # fmt: skip
    return FleetRule(FleetLayout.of(config, routes=("hot",)), p, "best combination")


def main(
    size: str = "small", shifts: int = 365, imitate: int = 2, frames: int = 730,
    eval_seeds: int = 2, seed: int = 0,
) -> dict[str, Any]:  # fmt: skip
    """Clone, fine-tune and evaluate; returns each policy's mean cost per vehicle-shift,
    the ratio of the shared policy's to the rule's with its paired interval, the clone's
    agreement with the rule and the training history."""
    fleet = SMALL_FLEET if size == "small" else {}
    config = FleetConfig(**fleet, episode_shifts=shifts)
    rule = teacher(config)
    spares = (rule.params.s, rule.params.S)

    def make_env() -> BrakeWearFleetParallelEnv:
        return BrakeWearFleetParallelEnv(config, predictor="oracle", spares=spares, infos="none")

    settings = MarlTraining(frames=frames, frames_per_batch=min(730, max(frames, 1)),
                            minibatch=min(146, max(frames, 1)), imitation_episodes=imitate,
                            seed=seed)  # fmt: skip
    result = train_marl(make_env, settings, teacher=rule, log=print)
    env = ExpectedRULObservation(BrakeWearFleetEnv(config), routes=("hot",))
    seeds = list(range(eval_seeds))
    costs = {
        name: np.array([e.per_vehicle_shift for e in run_episodes(env, p, seeds, True)])
        for name, p in (("rule", rule), ("shared MAPPO", result.policy))
    }
    ratio = paired_interval(costs["shared MAPPO"], costs["rule"], "ratio")
    print(f"{config.n_vehicles} vehicles, {shifts} shifts, evaluation seeds 0-{eval_seeds - 1}")
    print(f"clone agrees with the rule on {result.imitation_agreement:.3f} of its duties")
    for name, c in costs.items():
        print(f"{name:>14}: {c.mean():.3f} per vehicle-shift")
    print(f"shared / rule: {ratio}; training {result.seconds}")
    return {"cost": {k: float(v.mean()) for k, v in costs.items()}, "ratio": ratio,
            "agreement": result.imitation_agreement, "history": result.history}  # fmt: skip


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", choices=("small", "default"), default="small")
    ap.add_argument("--shifts", type=int, default=365)
    ap.add_argument("--imitate", type=int, default=2, help="teacher episodes to clone")
    ap.add_argument("--frames", type=int, default=730, help="shifts of PPO after cloning")
    ap.add_argument("--eval-seeds", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    main(a.size, a.shifts, a.imitate, a.frames, a.eval_seeds, a.seed)
