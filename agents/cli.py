"""``brakewear train`` and ``brakewear compare`` (registered as a plug-in of the CLI).

The ``brakewear`` parser loads this module to register the commands, so it imports only
what parsing needs; the training and the comparison (torch, SB3) are imported by the
commands that run them (README "Architecture"; ``brakewear --help`` stays fast).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from tqdm import tqdm

from agents.hyperparameters import ALGOS
from brake_env.cli.common import (
    add_common_args,
    add_wear_args,
    int_at_least,
    load_atlas,
    wear_regime,
)
from brake_env.env.config import REGIMES
from brake_env.output import table, write_json
from brake_env.prognostics.registry import predictor_names

if TYPE_CHECKING:
    from agents.compare import CompareConfig
    from agents.evaluation import CostReport
    from brake_env.cli.demo import DemoContext
    from brake_env.model.atlas import Atlas
    from brake_env.prognostics.protocol import Predictor


def _names(text: str) -> tuple[str, ...]:
    out = tuple(x.strip() for x in text.split(",") if x.strip())
    bad = [x for x in out if x not in predictor_names()]
    if bad:
        raise argparse.ArgumentTypeError(
            f"unknown predictor(s) {bad}; valid are {predictor_names()}"
        )
    return out


def _env_args(sp: argparse.ArgumentParser) -> None:
    sp.add_argument("--regime", choices=REGIMES, default="mixed", help="wear regime of new pads")
    sp.add_argument("--decision-interval", type=int_at_least(1), default=500, help="events/step")
    sp.add_argument("--episode-events", type=int_at_least(1), default=500_000, help="per episode")
    add_wear_args(sp)


def _env_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """BrakeWear-v0's keyword arguments from the options of :func:`_env_args`."""
    wear = wear_regime(args)
    return {
        "regime": args.regime,
        "decision_interval": args.decision_interval,
        "episode_events": args.episode_events,
        **wear.env_kwargs(),
    }


# ---------------------------------------------------------------------- train
def cmd_train(args: argparse.Namespace) -> dict[str, Any]:
    from agents.compare import fit_predictors
    from agents.hyperparameters import load_hyperparams
    from agents.train import train_agent

    atlas = load_atlas(args)
    names = tuple(dict.fromkeys((args.predictor, "oracle")))
    print(f"fitting {', '.join(names)} on {args.n_train_runs} simulated training pads")
    fitted, _ = fit_predictors(names, atlas, args.seed, args.n_train_runs, wear_regime(args))
    hp = None
    if args.hyperparams:
        hp = load_hyperparams(args.predictor, args.algo, args.hyperparams)
    res = train_agent(
        fitted[args.predictor],
        atlas,
        args.out,
        algo=args.algo,
        timesteps=args.timesteps,
        seed=args.seed,
        env_kwargs=_env_kwargs(args),
        hyperparams=hp,
        progress_bar=not args.quiet,
    )
    seeds = [args.seed * 10_000 + 5_000 + i for i in range(args.eval_seeds)]
    reports = _held_out_check(args, atlas, fitted, seeds)
    summary = {
        "train_seconds": res.seconds,
        "timesteps": res.timesteps,
        "eval_seeds": seeds,
        "policies": {k: r.to_dict() for k, r in reports.items()},
    }
    write_json(summary, Path(args.out) / "evaluation.json")
    print(f"trained in {res.seconds:.0f} s; wrote {args.out}/model.zip, vecnormalize.pkl,")
    print("  obs_normalization.npz, train.json, evaluation.json, checkpoints/, eval/, tb/")
    return summary


def _held_out_check(
    args: argparse.Namespace, atlas: Atlas, fitted: Mapping[str, Predictor], seeds: list[int]
) -> dict[str, CostReport]:
    """The trained agent and the oracle on held-out episodes, printed as a table."""
    from agents.compare import ORACLE, Entry
    from agents.evaluation import run_episodes, summary_rows, with_oracle_ratios
    from agents.policies import PolicyId, RULThreshold
    from agents.train import TrainedAgent, agent_env
    from brake_env.env.brake_wear import BrakeWearEnv
    from brake_env.env.wrappers import RULObservation

    env_kwargs = _env_kwargs(args)
    agent = PolicyId("agent", args.predictor, algo=args.algo)
    predictor_env = agent_env(fitted[args.predictor], atlas, {**env_kwargs, "cache_pads": 32})
    oracle_env = RULObservation(BrakeWearEnv(atlas=atlas, **env_kwargs), fitted["oracle"])
    entries: dict[str, Entry] = {
        agent.label: (TrainedAgent(args.out), predictor_env),
        ORACLE.label: (RULThreshold(args.decision_interval), oracle_env),
    }
    reports = {k: run_episodes(p, e, seeds, k) for k, (p, e) in entries.items()}
    reports = with_oracle_ratios(reports, reports[ORACLE.label])
    print(table(summary_rows(reports)))
    return reports


# ---------------------------------------------------------------------- compare
def cmd_compare(args: argparse.Namespace) -> dict[str, Any]:
    from agents.compare import CompareConfig

    config = CompareConfig(
        regime=args.regime,
        decision_interval=args.decision_interval,
        episode_events=args.episode_events,
        predictors=args.predictors,
        agent_predictors=args.agents,
        algo=args.algo,
        timesteps=args.timesteps,
        n_train_runs=args.n_train_runs,
        tune_seeds=args.tune_seeds,
        eval_seeds=args.eval_seeds,
        wear=wear_regime(args),
    )
    return compare_and_report(config, args, Path(args.out))


def compare_and_report(
    config: CompareConfig,
    args: argparse.Namespace,
    out: Path,
    hyperparams: dict[str, dict[str, Any]] | None = None,
) -> dict[str, Any]:
    """Run the comparison with progress bars; write ``costs.json`` and the figures, print
    the table. Returns the content of ``costs.json``."""
    from agents.compare import run_compare
    from agents.plots import plot_cost_ratios, plot_replacement_timing, plot_sensitivity

    atlas = load_atlas(args)
    bars: list[tqdm[Any]] = []

    def progress(label: str, total: int) -> Any:
        bar = tqdm(total=total, desc=label, unit="episode", disable=args.quiet)
        bars.append(bar)
        return bar.update

    result = run_compare(config, atlas, out, args.seed, progress, hyperparams=hyperparams)
    for bar in bars:
        bar.close()
    summary = result.to_dict()
    write_json(_finite(summary), out / "costs.json")
    figures = out / "figures"
    plot_cost_ratios(result.policies, figures / "cost_ratio.png")
    plot_replacement_timing(
        result.policies, figures / "replacement_timing.png", config.decision_interval
    )
    plot_sensitivity(result.sensitivity, figures / "cost_sensitivity.png")
    print(
        f"\nregime {config.regime}, failure/planned cost {result.failure_to_planned:g},"
        f" {len(result.eval_seeds)} held-out episodes of {config.episode_events} events"
    )
    print(table(_rows(summary)))
    for r, s in result.sensitivity.items():
        print(f"failure/planned {r:>3g}: predictors ranked {' < '.join(s.predictor_ranking)}")
    print(
        f"wrote {out}/costs.json, figures/cost_ratio.png, replacement_timing.png,"
        " cost_sensitivity.png"
    )
    return summary


def _rows(result: dict[str, Any]) -> list[list[str]]:
    rows = [
        [
            "policy",
            "parameter",
            "cost/1000 ev",
            "x oracle",
            "95% CI",
            "fail/100 pads",
            "OOD fail/100",
            "unused life",
        ]
    ]
    items = sorted(result["policies"].items(), key=lambda kv: kv[1]["cost_per_1000_events"])
    for name, p in items:
        lo, hi = p.get("ratio_to_oracle_ci95") or (math.nan, math.nan)
        param = p.get("parameter")
        rows.append(
            [
                name,
                "-" if param is None else f"{param:g}",
                f"{p['cost_per_1000_events']:.2f}",
                f"{p['ratio_to_oracle']:.3f}",
                f"{lo:.2f}-{hi:.2f}",
                f"{p['failures_per_100_pads']:.1f}",
                f"{p['failures_per_100_pads_by_regime']['ood']:.1f}",
                f"{p['mean_unused_life_frac']:.1%}",
            ]
        )
    return rows


def _finite(obj: Any) -> Any:
    """JSON has no NaN: write null instead."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {str(k): _finite(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_finite(v) for v in obj]
    return obj


# ---------------------------------------------------------------------- demo
def demo_compare(ctx: DemoContext) -> tuple[dict[str, Any], str]:
    """The comparison on a small budget: short episodes, few seeds, one short PPO run on the
    twin (trained on a pool of 8 pads). Grids scale with the demo's pad life."""
    from agents.compare import CompareConfig
    from agents.hyperparameters import load_hyperparams
    from brake_env.model.wear import WearModel

    args = ctx.args
    life = float(WearModel.from_atlas(load_atlas(args)).life(args.k_mean))
    interval = int(min(500, max(1, life // 240)))
    config = CompareConfig(
        decision_interval=interval,
        episode_events=int(min(200_000, 4 * life)),
        agent_predictors=("twin",),
        timesteps=10_000,
        n_train_runs=max(3, args.n_train),
        tune_seeds=2,
        eval_seeds=3,
        thresholds=(0, 1, 2, 4, 8, 16, 32, 64),
        fixed_intervals=tuple(int(f * life) for f in (0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0)),
        wear=wear_regime(args),
    )
    hp = {"twin": {**load_hyperparams("twin", config.algo), "pad_pool": 8}}
    out = ctx.out / "compare"
    result = compare_and_report(config, ctx.args, out, hp)
    lines = ["| " + " | ".join(r) + " |" for r in _rows(result)]
    lines.insert(1, "|" + "---|" * len(_rows(result)[0]))
    section = f"""## Maintenance cost by predictor (small budget)

Mixed regime (half OOD pads), failure = {result["failure_to_planned"]:g} planned replacements,
{len(result["eval_seeds"])} held-out episodes of {config.episode_events} events; thresholds
and the fixed interval tuned on {config.tune_seeds} other episodes; PPO on the twin trained
for only {config.timesteps} steps on 8 pads here (`brakewear compare` for the full budget).

{chr(10).join(lines)}

![cost ratio](compare/figures/cost_ratio.png)
![replacement timing](compare/figures/replacement_timing.png)
"""
    return result, section


# ---------------------------------------------------------------------- parser
def register(sub: argparse._SubParsersAction[Any]) -> None:
    """Add ``train`` and ``compare`` to the ``brakewear`` parser."""
    fmt = argparse.ArgumentDefaultsHelpFormatter
    t = sub.add_parser(
        "train",
        formatter_class=fmt,
        help="train an SB3 agent on BrakeWear-v0 with a predictor's RUL estimates",
    )
    add_common_args(t, "out/train")
    t.add_argument("--predictor", choices=predictor_names(), default="twin")
    t.add_argument("--algo", choices=ALGOS, default="ppo")
    t.add_argument("--timesteps", type=int_at_least(1), default=100_000)
    t.add_argument("--hyperparams", default=None, help="TOML file (default agents/hyperparams/)")
    t.add_argument("--n-train-runs", type=int_at_least(1), default=10, help="pads to fit on")
    t.add_argument("--eval-seeds", type=int_at_least(1), default=4, help="held-out episodes")
    t.add_argument("--atlas", default=None, help="atlas .npz instead of the cache")
    _env_args(t)
    t.set_defaults(func=cmd_train)

    c = sub.add_parser(
        "compare",
        formatter_class=fmt,
        help="rank predictors by the maintenance cost their policies lead to",
    )
    add_common_args(c, "out/compare")
    c.add_argument("--timesteps", type=int_at_least(1), default=50_000, help="per agent")
    c.add_argument("--algo", choices=ALGOS, default="ppo")
    c.add_argument("--predictors", type=_names, default=predictor_names(), help="comma-separated")
    c.add_argument(
        "--agents", type=_names, default=predictor_names(), help="predictors given an agent"
    )
    c.add_argument("--n-train-runs", type=int_at_least(1), default=10, help="pads to fit on")
    c.add_argument("--tune-seeds", type=int_at_least(1), default=4)
    c.add_argument("--eval-seeds", type=int_at_least(1), default=8)
    c.add_argument("--atlas", default=None, help="atlas .npz instead of the cache")
    _env_args(c)
    c.set_defaults(func=cmd_compare)
