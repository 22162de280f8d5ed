"""A first look at learning on BrakeWearFleet-v0 (issue 21's first slice): MaskablePPO on the
small fleet with the oracle's RUL, against the best tuned heuristic and the
perfect-information reference of ``benchmarks/fleet_room.py``, on the same evaluation
episodes (common random numbers).

1. The heuristic is rebuilt from the parameters ``fleet_room.py --json`` saved (``tuned``):
   the one ``--heuristic`` names (default: the best combination, the one selected there).
2. MaskablePPO (``agents.fleet.learning.agent``) is trained for ``--timesteps`` shifts on
   ``--n-envs`` envs, one model per ``--seeds`` seed (episode seeds from the training seed,
   apart from the evaluation seeds 0..); every ``--eval-every`` shifts the agent's cost on
   ``--curve-seeds`` tuning episodes (seeds from 20,000) is recorded: a learning curve.
3. Agent, heuristic and reference run the evaluation episodes (``--eval-seeds``, from 0);
   cost per vehicle-shift, paired BCa intervals of each agent's difference from the
   heuristic and from the reference.

``--imitate EPISODES`` warm-starts each agent by behaviour cloning the heuristic (its
episodes recorded on the training envs, seeds from 1,000,000 x (training seed + 1);
``--imitation-epochs`` passes; ``--imitation-rounds`` DAgger rounds: the clone drives as
many episodes more, labelled by the heuristic, and is refitted on all of them), then PPO
fine-tunes for ``--timesteps`` (0: the clone alone, no curve). The curve then starts with
the clone's cost (at ``--n-envs`` shifts, before PPO's first update) and each agent's line
gives the clone's agreement with the heuristic on the recorded shifts.
``--learning-rate``, ``--ent-coef`` and ``--clip-range`` are PPO's (defaults SB3's, the
entropy bonus 0.01). ``--reorder s S`` leaves the spares to the (s, S) rule (the agent
decides duties only).
A small budget trains little: the figures say what this budget reached, not what learning
can reach. Run: ``.venv/bin/python benchmarks/fleet_learning.py --room-json room.json
[--timesteps 100000] [--seeds 0] [--eval-seeds 40] [--imitate 40] [--json out.json]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from typing import Any

import numpy as np

from agents.fleet.evaluation.costs import evaluate, paired_interval
from agents.fleet.evaluation.tuning import SPACES
from agents.fleet.learning.agent import (
    FleetAgent,
    Imitation,
    oracle_fleet_env,
    train_fleet_agent,
)
from agents.fleet.policies.reference import ReferenceModel, ReferencePolicy, solve
from agents.fleet.policies.view import FleetLayout
from agents.fleet.settings import FleetTraining
from brake_env.env.fleet.config import SMALL_FLEET, FleetConfig
from brake_env.env.shared import default_atlas
from brake_env.output import write_json

CURVE_SEED0 = 20_000


class _Curve:
    """SB3 callback: the agent's mean cost on the curve seeds every ``every`` shifts (and,
    with ``start``, before the first update: after the first step, at ``n_envs`` shifts)."""

    def __init__(self, every: int, run: Any, start: bool = False) -> None:
        from stable_baselines3.common.callbacks import BaseCallback

        outer = self

        class _CB(BaseCallback):  # type: ignore[misc]
            def _on_step(self) -> bool:
                if start and not outer.points:  # the warm start, before any update
                    outer.points.append((self.num_timesteps, run(self.model)))
                if self.num_timesteps >= outer.next:
                    outer.points.append((self.num_timesteps, run(self.model)))
                    outer.next += every
                return True

        self.next, self.points, self.callback = every, [], _CB()


def main() -> None:
    import optuna
    import torch

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--room-json", required=True, help="fleet_room.py --json output")
    ap.add_argument("--heuristic", default="best combination")
    ap.add_argument("--timesteps", type=int, default=100_000)
    ap.add_argument("--n-envs", type=int, default=4)
    ap.add_argument("--seeds", type=int, nargs="+", default=[0])
    ap.add_argument("--eval-seeds", type=int, default=40)
    ap.add_argument("--curve-seeds", type=int, default=4)
    ap.add_argument("--eval-every", type=int, default=20_000)
    ap.add_argument("--shifts", type=int, default=365)
    ap.add_argument("--tail", type=int, default=200)
    ap.add_argument(
        "--reorder", type=int, nargs=2, default=None, metavar=("s", "S"),
        help="spares by (s, S): the agent decides duties only",
    )  # fmt: skip
    ap.add_argument("--normalize-reward", action="store_true", help="VecNormalize's rewards")
    ap.add_argument(
        "--imitate",
        type=int,
        default=0,
        metavar="EPISODES",
        help="behaviour-clone the heuristic on this many episodes first",
    )
    ap.add_argument("--imitation-epochs", type=int, default=FleetTraining.imitation_epochs)
    ap.add_argument("--imitation-lr", type=float, default=FleetTraining.imitation_lr)
    ap.add_argument("--imitation-rounds", type=int, default=FleetTraining.imitation_rounds,
                    help="DAgger rounds after the heuristic's episodes")  # fmt: skip
    ap.add_argument(
        "--no-imitation-value",
        action="store_true",
        help="clone the policy only, not the value head",
    )
    ap.add_argument("--learning-rate", type=float, default=FleetTraining.learning_rate)
    ap.add_argument("--ent-coef", type=float, default=FleetTraining.ent_coef)
    ap.add_argument("--clip-range", type=float, default=FleetTraining.clip_range)
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    torch.set_num_threads(1)  # one core per run; run seeds side by side
    t0 = time.time()
    cfg = FleetConfig(**SMALL_FLEET, episode_shifts=a.shifts)
    atlas = default_atlas(cfg.preset)
    env, layout = oracle_fleet_env(cfg, atlas), FleetLayout.of(cfg)
    with open(a.room_json) as f:
        params = json.load(f)["tuned"][a.heuristic]
    rule = SPACES[a.heuristic](optuna.trial.FixedTrial(params), layout, cfg.window_period)
    model = ReferenceModel.build(cfg, atlas)
    ref = ReferencePolicy(env, model, solve(model, a.tail), rule.params.s, rule.params.S)
    seeds = list(range(a.eval_seeds))
    cost = {a.heuristic: evaluate(env, rule, seeds), "reference": evaluate(env, ref, seeds)}
    curves: dict[str, list[tuple[int, float]]] = {}
    cloned: dict[str, Imitation] = {}
    curve_seeds = list(range(CURVE_SEED0, CURVE_SEED0 + a.curve_seeds))
    for seed in a.seeds:
        reorder = None if a.reorder is None else (a.reorder[0], a.reorder[1])
        settings = FleetTraining(
            a.timesteps, a.n_envs, seed, reorder=reorder, normalize_reward=a.normalize_reward,
            learning_rate=a.learning_rate, ent_coef=a.ent_coef, clip_range=a.clip_range,
            imitation_episodes=a.imitate, imitation_epochs=a.imitation_epochs,
            imitation_lr=a.imitation_lr, imitation_value=not a.no_imitation_value,
            imitation_rounds=a.imitation_rounds,
        )  # fmt: skip
        curve = _Curve(
            a.eval_every, lambda m, r=reorder: _agent_cost(m, env, layout, curve_seeds, r),
            start=a.imitate > 0,
        )  # fmt: skip
        agent = train_fleet_agent(
            lambda: oracle_fleet_env(cfg, atlas), layout, settings, curve.callback,
            teacher=rule if a.imitate else None,
        )  # fmt: skip
        name = f"MaskablePPO seed {seed}"
        cost[name] = evaluate(env, agent, seeds, check_masks=True)
        curves[name] = curve.points
        if agent.imitation is not None:
            cloned[name] = agent.imitation
    print(f"Small fleet {SMALL_FLEET}, {a.shifts} shifts, oracle RUL; MaskablePPO"
          f" {a.timesteps} shifts on {a.n_envs} envs per seed; {a.eval_seeds} evaluation"
          f" episodes (seeds 0..{a.eval_seeds - 1})")  # fmt: skip
    if a.imitate:
        print(f"  warm start: {a.imitate} episodes of {a.heuristic} cloned,"
              f" {a.imitation_epochs} epochs, lr {a.imitation_lr}, {a.imitation_rounds}"
              f" DAgger rounds,"
              f" value head {'no' if a.no_imitation_value else 'yes'}; PPO lr"
              f" {a.learning_rate}, ent_coef {a.ent_coef}, clip {a.clip_range}")  # fmt: skip
    h, r = cost[a.heuristic], cost["reference"]
    for name, x in cost.items():
        line = f"  {name:>28}: {x.mean():8.3f} per vehicle-shift"
        if name not in (a.heuristic, "reference"):
            line += f"; - {a.heuristic} {paired_interval(x, h, 'difference')}"
            line += f"; - reference {paired_interval(x, r, 'difference')}"
            line += f"; curve {[(n, round(c, 2)) for n, c in curves[name]]}"
            if name in cloned:
                c = cloned[name]
                line += (f"; clone agreement {c.agreement:.4f} on {c.samples} shifts"
                         f" (last DAgger round's own states {c.on_policy:.4f}),"
                         f" nll {c.nll:.4f}, {c.seconds:.0f} s")  # fmt: skip
        print(line)
    print(f"wall time {time.time() - t0:.0f} s")
    if a.json:
        out = {"cost": {k: v.tolist() for k, v in cost.items()}, "curves": curves,
               "imitation": {k: dataclasses.asdict(v) for k, v in cloned.items()},
               "args": vars(a)}  # fmt: skip
        write_json(out, a.json)


def _agent_cost(model: Any, env: Any, layout: FleetLayout, seeds: list[int], reorder: Any) -> float:
    """The model's mean cost on ``seeds`` with the training env's current statistics."""
    rms = model.get_env().obs_rms
    mean, var = rms.mean.astype(np.float32), rms.var.astype(np.float32)
    agent = FleetAgent(model, layout, mean, var, reorder=reorder)
    return float(evaluate(env, agent, seeds).mean())


if __name__ == "__main__":
    main()
