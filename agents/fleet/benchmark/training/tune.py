"""Tune a plain-RL configuration on the dev split with Optuna: a few trials on a short
budget, each trained from scratch and measured by its net cost on dev episodes
``0..episodes-1``; prints each trial and the best settings (to copy into the config).

Run: ``python -m agents.fleet.benchmark.training.tune --config maskable_ppo --trials 6
--timesteps 5000 --episodes 5 --out out/rl/tune-maskable`` (writes ``trials.json`` there).

Searched (``SPACES``): the learning rate, the rollout length (``n_steps``; MAPPO's
``frames_per_batch``), the entropy coefficient, the discount, the reward scale, and for
MaskablePPO the action's repairs: the order quantity learned or by the config's (s, S) rule,
and the shift's needs covered from idle vehicles or not.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

from agents.fleet.benchmark.training.config import TrainingConfig, read_config, suite_atlas
from agents.fleet.benchmark.training.run import dev_net, train
from agents.fleet.benchmark.training.train import BUDGET
from brake_env.model.atlas import Atlas

REPAIRS = ("none", "spares", "spares+cover")


def sample(trial: Any, config: TrainingConfig) -> dict[str, Any]:
    """One trial's settings (the module's search space)."""
    s = config.settings
    out: dict[str, Any] = {
        "learning_rate": trial.suggest_float("learning_rate", 1e-4, 2e-3, log=True),
        "gamma": trial.suggest_categorical("gamma", [0.98, 0.99, 0.995]),
        "reward_scale": trial.suggest_float("reward_scale", 1e-4, 1e-2, log=True),
    }
    if config.algorithm == "mappo":
        out["frames_per_batch"] = trial.suggest_categorical("frames_per_batch", [500, 1000])
        out["entropy"] = trial.suggest_float("entropy", 1e-4, 3e-2, log=True)
        out["minibatch"] = min(s.minibatch, out["frames_per_batch"])
        return out
    out["n_steps"] = trial.suggest_categorical("n_steps", [128, 256, 512])
    out["ent_coef"] = trial.suggest_float("ent_coef", 1e-4, 3e-2, log=True)
    repair = trial.suggest_categorical("repairs", list(REPAIRS))
    if s.reorder is None and repair != "none":
        raise ValueError(f"{config.path}: the repairs need [train] reorder = [s, S]")
    out["reorder"] = None if repair == "none" else s.reorder
    out["cover_needs"] = repair == "spares+cover"
    return out


def tune(
    config: TrainingConfig, atlas: Atlas, trials: int, budget: int, episodes: int,
    log: Any = print,
) -> list[dict[str, Any]]:  # fmt: skip
    """``trials`` Optuna trials (TPE, seeded by the config's seed) of ``budget`` steps each:
    a row per trial with its settings, dev figures and CPU seconds."""
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    rows: list[dict[str, Any]] = []

    def objective(trial: Any) -> float:
        t0 = time.process_time()
        settings = sample(trial, config) | {BUDGET[config.algorithm]: budget}
        policy, cost = train(config.with_settings(**settings), atlas)
        net = dev_net(config, policy, atlas, episodes)
        mean = sum(net) / len(net)
        rows.append({"trial": trial.number, "params": trial.params, "dev_net": net,
                     "mean": mean, "training_steps": cost["training_steps"],
                     "cpu_seconds": time.process_time() - t0})  # fmt: skip
        log(f"trial {trial.number}: dev net {mean:.3f} {trial.params}"
            f" ({rows[-1]['cpu_seconds']:.0f} s CPU)")  # fmt: skip
        return mean

    sampler = optuna.samplers.TPESampler(seed=config.settings.seed)
    study = optuna.create_study(direction="minimize", sampler=sampler)
    study.optimize(objective, n_trials=trials)
    log(f"best: trial {study.best_trial.number}, dev net {study.best_value:.3f},"
        f" {study.best_params}")  # fmt: skip
    return rows


def main(argv: list[str] | None = None) -> list[dict[str, Any]]:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--config", required=True, help="a shipped config's name or a TOML file")
    ap.add_argument("--trials", type=int, default=6)
    ap.add_argument("--timesteps", type=int, default=5000, help="each trial's budget")
    ap.add_argument("--episodes", type=int, default=5, help="dev episodes 0..N-1 to measure")
    ap.add_argument("--out", required=True, help="a folder for trials.json")
    args = ap.parse_args(argv)
    if args.trials < 1 or args.timesteps < 1:
        raise SystemExit("--trials and --timesteps must be >= 1")
    config = read_config(args.config)
    out = Path(args.out) / "trials.json"
    if out.exists():
        raise SystemExit(f"{out} exists: choose another --out")
    rows = tune(config, suite_atlas(config.suite), args.trials, args.timesteps, args.episodes)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"config": config.path, "budget": args.timesteps,
                               "episodes": args.episodes, "trials": rows}, indent=1))  # fmt: skip
    return rows


if __name__ == "__main__":
    main()
