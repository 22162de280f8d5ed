"""Is the rollout planner's decision noise? (issue 43, item 2) On a suite's dev split only
(a seed at or beyond the suite's ``test_from`` is refused).

**Agreement** (``--mode agreement``): states sampled from dev rollouts of the base (every
``--every``-th shift of episodes ``--episodes-from``.. of the suite's tuned rule with the
predictor's RUL), and at each state the planner's joint duties under two planner seeds.
Prints, per planner setting, the share of states where each seed departs from the base and
the share where the two seeds decide the same joint duties (the issue's target: >= 90%),
with the share of departures the other seed repeats. ``old`` is the planner before issue 43
(16 futures, one standard error, no correction, pad life priced linearly); ``N`` the
corrected one with N futures (Bonferroni at ``--alpha``, the programs' terminal value).

**Paired** (``--mode paired``): the rollout with ``--planner-seeds`` and its base on the same
dev episodes; prints each seed's mean net cost per vehicle-shift and its difference from the
base (95% paired bootstrap over episodes), then the per-episode mean over the seeds minus
the base (the seeds' variance inside the interval) and the seeds' spread. ``--json`` writes
the per-episode figures; ``--merge`` prints one table from several such files of the same
episodes (one process per predictor or base on a busy machine).

Run (the figures in the report): ``.venv/bin/python benchmarks/analysis/rollout_stability.py
--mode agreement --predictors oracle,twin --samples 16,64``, then ``... --mode paired
--predictors oracle --base rule --episodes 10 --json o.json`` (and twin, and ``--base
index``), ``... --merge o.json t.json``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from agents.fleet.benchmark.baselines import read_baselines
from agents.fleet.benchmark.suite import read_suite
from agents.fleet.evaluation.costs import paired_interval, run_episodes
from agents.fleet.policies.index import CHOSEN, IndexPolicy, searched
from agents.fleet.policies.planning import PlanningModel
from agents.fleet.policies.rollout import RolloutPolicy, program_value
from agents.fleet.policies.view import FleetLayout, FleetView
from agents.fleet.study.build import rebuild_rule, rul_env
from agents.fleet.study.planners import planner_fields
from agents.fleet.study.units import study_fit
from brake_env.model.atlas import AtlasSpec, cached_atlas
from brake_env.model.params import BrakeModel
from brake_env.prognostics.registry import ORACLE


@dataclasses.dataclass
class Setup:
    """One predictor's env, tuned rule, index policy and planning model on the dev split."""

    env: Any
    rule: Any
    index: IndexPolicy
    model: PlanningModel
    terminal: Any
    seeds: list[int]


def setup(args: argparse.Namespace, predictor: str, episodes: int) -> Setup:
    suite = read_suite(args.suite)
    try:
        config = suite.dev_config(args.episodes_from, episodes)
    except ValueError as e:
        raise SystemExit(str(e)) from None
    seeds = config.eval_seeds()
    cfg = config.fleet
    atlas = cached_atlas(AtlasSpec(model=BrakeModel.preset(cfg.preset)), None)
    entry = (read_baselines(suite) or {"baselines": {}})["baselines"].get(f"{predictor}-rule")
    if entry is None:
        raise SystemExit(f"suite {suite.name!r} ships no tuned rule for {predictor!r}")
    fitted = None if predictor == ORACLE else study_fit(config, predictor, atlas, atlas)
    fields = planner_fields(predictor)
    lay = FleetLayout.of(cfg, fields=fields)
    env = rul_env(config, atlas, predictor, fitted, fields)
    rule = rebuild_rule(config, entry["policy"], entry["params"], lay)
    s = int(entry["params"]["s"])
    S = s + int(entry["params"]["S_minus_s"])
    index = IndexPolicy(lay, *searched(cfg, atlas), s=s, S=S, cover=CHOSEN["cover"],
                        floor=CHOSEN["floor"], name=f"{predictor}-index")  # fmt: skip
    model = PlanningModel.build(cfg, atlas)
    return Setup(env, rule, index, model, program_value(cfg, atlas), seeds)


def planner(u: Setup, base: str, setting: str, seed: int, args: argparse.Namespace) -> Any:
    """The rollout of ``setting`` (``old`` or a number of futures) on ``base``."""
    if setting == "old":
        return RolloutPolicy(u.rule, u.model, 28, 16, seed, confidence=1.0)
    if base == "index":
        return RolloutPolicy(u.index, u.model, 1, int(setting), seed, alpha=args.alpha)
    return RolloutPolicy(u.rule, u.model, args.horizon, int(setting), seed, alpha=args.alpha,
                         terminal=u.terminal)  # fmt: skip


def sampled_states(u: Setup, every: int) -> list[Any]:
    """Observations every ``every``-th shift of the tuned rule's dev episodes."""
    out = []
    for seed in u.seeds:
        obs, _ = u.env.reset(seed=seed)
        done, t = False, 0
        while not done:
            if t % every == every // 2:
                out.append(obs.copy())
            obs, _, term, trunc, _ = u.env.step(u.rule.act(FleetView.read(obs, u.rule.layout)))
            done, t = term or trunc, t + 1
    return out


def agreement(args: argparse.Namespace) -> None:
    for p in filter(None, args.predictors.split(",")):
        u = setup(args, p, args.episodes)
        states = sampled_states(u, args.every)
        print(f"{p}: {len(states)} states, episodes {u.seeds[0]}..{u.seeds[-1]} every"
              f" {args.every} shifts, base {args.base}", flush=True)  # fmt: skip
        for setting in args.samples.split(","):
            t0 = time.process_time()
            same, departs = 0, np.zeros(2)
            both = 0
            for obs in states:
                base = (u.index if args.base == "index" else u.rule).action(obs)[:-1]
                a, b = (planner(u, args.base, setting, s, args).act(obs)[:-1] for s in (0, 1))
                same += bool((a == b).all())
                departs += [(a != base).any(), (b != base).any()]
                both += bool((a != base).any() and (a == b).all())
            cpu = (time.process_time() - t0) / (2 * len(states))
            print(f"  {setting:>5}: agree {same / len(states):.3f}  depart seed0"
                  f" {departs[0] / len(states):.3f} seed1 {departs[1] / len(states):.3f}"
                  f"  departures repeated {both / max(departs[0], 1):.3f}"
                  f"  {cpu:.3f} CPU s a decision", flush=True)  # fmt: skip


def paired(args: argparse.Namespace) -> dict[str, Any]:
    """Episode by episode (a partial run is still paired): the base, then each planner
    seed; each episode's net cost printed as it ends."""
    rows: dict[str, Any] = {}
    planner_seeds = [int(s) for s in args.planner_seeds.split(",")]
    for p in filter(None, args.predictors.split(",")):
        u = setup(args, p, args.episodes)
        base = u.index if args.base == "index" else u.rule
        names = [f"{p}-{args.base}"] + [f"{p}-{args.base}-rollout-seed{s}" for s in planner_seeds]
        pols = [base] + [planner(u, args.base, args.samples.split(",")[0], s, args)
                         for s in planner_seeds]  # fmt: skip
        cpu = np.zeros(len(pols))
        for seed in u.seeds:
            for i, (name, pol) in enumerate(zip(names, pols, strict=True)):
                t0 = time.process_time()
                rows.setdefault(name, []).append(run_episodes(u.env, pol, [seed], True)[0].net)
                cpu[i] += time.process_time() - t0
                print(f"episode {seed} {name}: {rows[name][-1]:.4f} ({cpu[i]:.0f} CPU s so"
                      " far)", flush=True)  # fmt: skip
    return {"seeds": u.seeds, "rows": rows, "args": vars(args)}


def table(out: dict[str, Any]) -> str:
    rows = {k: np.array(v) for k, v in out["rows"].items()}
    lines = [f"episodes {out['seeds'][0]}..{out['seeds'][-1]} (dev), net per vehicle-shift"]
    for name in [k for k in rows if "-rollout-" not in k]:
        base = rows[name]
        lines.append(f"{name:24} {base.mean():.3f}")
        runs = {k: v for k, v in rows.items() if k.startswith(f"{name}-rollout-")}
        for k, v in runs.items():
            lines.append(f"  {k:38} {v.mean():.3f}  minus base {paired_interval(v, base)}")
        if len(runs) > 1:
            m = np.mean(list(runs.values()), axis=0)
            spread = np.std([v.mean() for v in runs.values()], ddof=1)
            lines.append(f"  {'mean over ' + str(len(runs)) + ' planner seeds':38} {m.mean():.3f}"
                         f"  minus base {paired_interval(m, base)}  (sd of the seeds' means"
                         f" {spread:.3f})")  # fmt: skip
    return "\n".join(lines)


def from_logs(paths: list[str]) -> dict[str, Any]:
    """The paired mode's printed episodes (``episode SEED NAME: NET``), those every policy
    of a log finished."""
    rows: dict[str, Any] = {}
    for path in paths:
        got: dict[str, dict[int, float]] = {}
        for line in Path(path).read_text(encoding="utf-8").splitlines():
            if line.startswith("episode "):
                _, seed, name, net = line.split()[:4]
                got.setdefault(name.rstrip(":"), {})[int(seed)] = float(net)
        done = sorted(set.intersection(*(set(v) for v in got.values())))
        if len(done) < 2:
            raise SystemExit(f"{path}: {len(done)} episode(s) finished by every policy; need 2")
        rows.update({k: [v[s] for s in done] for k, v in got.items()})
    return {"seeds": done, "rows": rows}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--mode", choices=("agreement", "paired"), default="agreement")
    ap.add_argument("--suite", default="default")
    ap.add_argument("--predictors", default="oracle,twin")
    ap.add_argument("--base", choices=("rule", "index"), default="rule")
    ap.add_argument("--episodes-from", type=int, default=0)
    ap.add_argument("--episodes", type=int, default=5, help="dev episodes")
    ap.add_argument("--every", type=int, default=15, help="agreement: a state every so many")
    ap.add_argument("--samples", default="old,16,64", help="futures (paired: the first)")
    ap.add_argument("--horizon", type=int, default=28, help="shifts (a rule base)")
    ap.add_argument("--alpha", type=float, default=0.05)
    ap.add_argument("--planner-seeds", default="0,1,2")
    ap.add_argument("--json", default=None)
    ap.add_argument("--merge", nargs="+", default=None, metavar="JSON")
    ap.add_argument("--logs", nargs="+", default=None, help="paired runs' printouts: the table"
                    " of their episodes every policy finished (a partial run)")  # fmt: skip
    args = ap.parse_args()
    if args.logs:
        print(table(from_logs(args.logs)))
        return
    if args.merge:
        docs = [json.loads(Path(p).read_text(encoding="utf-8")) for p in args.merge]
        if any(d["seeds"] != docs[0]["seeds"] for d in docs):
            raise SystemExit(f"--merge: {args.merge} were run on different episodes")
        rows = {k: v for d in docs for k, v in d["rows"].items()}
        print(table({"seeds": docs[0]["seeds"], "rows": rows}))
        return
    if args.json and Path(args.json).exists():
        raise SystemExit(f"--json {args.json} exists: this writes only a new file")
    if args.mode == "agreement":
        agreement(args)
        return
    out = paired(args)
    print(table(out))
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1), encoding="utf-8")


if __name__ == "__main__":
    main()
