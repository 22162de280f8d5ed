"""The Lagrangian index policy (:mod:`agents.fleet.policies.index`) on a suite's dev split,
against the tuned rule with the same RUL and the price-directed policy, paired over episodes
(issue 43, item 1). Never the test split: a seed at or beyond the suite's ``test_from`` is
refused.

For each predictor (its fit as the suite's study makes it; none for the oracle) the suite's
shipped tuned rule of that predictor (tuned on the dev side's tuning seeds) and the index
policy act on the same env and episodes; the index policy orders by that rule's (s, S). The
prices are the bound's, searched from the tuning seeds' starts; the price-directed policy
(on the truth, as the study runs it) and the bound are computed at them. Prints one row per
policy: mean net cost per vehicle-shift, the index policy minus the rule and minus the
price-directed policy (95% paired bootstrap), the ratio to the bound, and CPU seconds an
episode.

Run: ``.venv/bin/python benchmarks/analysis/index_policy.py --suite default --episodes 20``;
on a busy machine one process per predictor and one for the price-directed policy, then
their table: ``... --predictors oracle --no-priced --json o.json``, ``... --predictors twin
--no-priced --json t.json``, ``... --predictors= --json p.json``, ``... --merge p.json o.json
t.json``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from agents.fleet.benchmark.baselines import read_baselines
from agents.fleet.benchmark.suite import read_suite
from agents.fleet.evaluation.costs import paired_interval, run_episodes
from agents.fleet.policies.index import CHOSEN, IndexPolicy, searched
from agents.fleet.policies.lagrangian import BoundModel, bound, solve, start_counts
from agents.fleet.policies.priced import PricedPolicy
from agents.fleet.policies.view import FleetLayout
from agents.fleet.study.build import rebuild_rule, rul_env
from agents.fleet.study.units import study_fit
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.model.atlas import AtlasSpec, cached_atlas
from brake_env.model.params import BrakeModel
from brake_env.prognostics.registry import ORACLE

PRICED = "priced (truth)"


def timed(env: Any, policy: Any, seeds: list[int]) -> tuple[np.ndarray, float]:
    """(each episode's net cost, CPU seconds an episode)."""
    t0 = time.process_time()
    eps = run_episodes(env, policy, seeds, check_masks=True)
    return np.array([e.net for e in eps]), (time.process_time() - t0) / len(seeds)


def bounds(model: BoundModel, found: tuple[Any, Any, Any], seeds: list[int], atlas: Any) -> Any:
    """The bound on each episode at the searched prices [per vehicle-shift]."""
    _, prices, program = found
    c = model.config
    env = BrakeWearFleetEnv(c, atlas=atlas)
    out = []
    for seed in seeds:
        env.reset(seed=seed)
        tr = env.truth()
        s = start_counts(model, model.state(tr["volume_frac"], tr["wear_coeff"]))
        out.append(bound(model, program, prices, s) / (c.n_vehicles * c.episode_shifts))
    return np.array(out)


def run(args: argparse.Namespace) -> dict[str, Any]:
    suite = read_suite(args.suite)
    try:
        config = suite.dev_config(args.episodes_from, args.episodes)
    except ValueError as e:
        raise SystemExit(str(e)) from None
    seeds = config.eval_seeds()
    cfg = config.fleet
    atlas = cached_atlas(AtlasSpec(model=BrakeModel.preset(cfg.preset)), None)
    t0 = time.process_time()
    found = searched(cfg, atlas, args.iterations)
    out: dict[str, Any] = {"suite": suite.name, "seeds": seeds, "iterations": args.iterations,
                           "search_cpu_s": time.process_time() - t0, "rows": {}}  # fmt: skip
    out["bound"] = bounds(found[0], found, seeds, atlas)
    if not args.no_priced:  # the study's priced policy: on the uncredited program
        plain = BoundModel.build(cfg, atlas)
        env = BrakeWearFleetEnv(cfg, atlas=atlas)
        priced = PricedPolicy(env, plain, found[1], solve(plain, found[1]))
        out["rows"][PRICED] = timed(env, priced, seeds)
    shipped = read_baselines(suite) or {"baselines": {}}
    for p in filter(None, args.predictors.split(",")):
        entry = shipped["baselines"].get(f"{p}-rule")
        if entry is None:
            raise SystemExit(f"suite {suite.name!r} ships no tuned rule for {p!r}")
        fitted = None if p == ORACLE else study_fit(config, p, atlas, atlas)
        env = rul_env(config, atlas, p, fitted)
        rule = rebuild_rule(config, entry["policy"], entry["params"])
        s = int(entry["params"]["s"])
        S = s + int(entry["params"]["S_minus_s"])
        index = IndexPolicy(FleetLayout.of(cfg), *found, s=s, S=S, cover=args.cover,
                            floor=args.floor)  # fmt: skip
        out["rows"][f"{p}-rule"] = timed(env, rule, seeds)
        out["rows"][f"{p}-index"] = timed(env, index, seeds)
    return out


def merged(paths: list[str]) -> dict[str, Any]:
    """The rows of several ``--json`` files of one suite's same episodes, as one run."""
    docs = [json.loads(Path(p).read_text(encoding="utf-8")) for p in paths]
    if any(d["seeds"] != docs[0]["seeds"] for d in docs):
        raise SystemExit(f"--merge: {paths} were run on different episodes")
    rows = {k: (np.array(v["net"]), v["cpu_s_per_episode"]) for d in docs
            for k, v in d["rows"].items()}  # fmt: skip
    return {**docs[0], "bound": np.array(docs[0]["bound"]), "rows": rows}


def table(out: dict[str, Any]) -> str:
    """One row per policy (module docstring)."""
    rows, b = out["rows"], out["bound"]
    priced = rows[PRICED][0] if PRICED in rows else None
    lines = [f"{'policy':16} {'net':>7} {'minus rule (95%)':>26} {'minus priced (95%)':>26}"
             f" {'/ bound (95%)':>22} {'cpu s/ep':>8}"]  # fmt: skip
    for name, (net, cpu) in rows.items():
        rule = rows.get(name.replace("-index", "-rule"))
        vs_rule = (str(paired_interval(net, rule[0])) if name.endswith("-index") and rule
                   else "")  # fmt: skip
        vs_priced = (str(paired_interval(net, priced))
                     if name.endswith("-index") and priced is not None else "")  # fmt: skip
        ratio = str(paired_interval(net, b, "ratio"))
        lines.append(f"{name:16} {net.mean():7.3f} {vs_rule:>26} {vs_priced:>26} {ratio:>22}"
                     f" {cpu:8.1f}")  # fmt: skip
    lines.append(f"{'bound':16} {b.mean():7.3f}   (price search {out['search_cpu_s']:.0f} CPU s,"
                 f" {out['iterations']} iterations; episodes {out['seeds'][0]}.."
                 f"{out['seeds'][-1]})")  # fmt: skip
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--suite", default="default")
    ap.add_argument("--episodes-from", type=int, default=0)
    ap.add_argument("--episodes", type=int, default=20)
    ap.add_argument("--iterations", type=int, default=30, help="price search steps")
    ap.add_argument("--predictors", default="twin,oracle")
    ap.add_argument("--cover", type=float, default=CHOSEN["cover"], help="[hot shifts]")
    ap.add_argument("--floor", type=float, default=CHOSEN["floor"], help="on the needs")
    ap.add_argument("--json", default=None, help="write the per-episode figures here")
    ap.add_argument("--no-priced", action="store_true", help="skip the price-directed policy")
    ap.add_argument(
        "--merge",
        nargs="+",
        default=None,
        metavar="JSON",
        help="print the table of --json files of runs on the same episodes",
    )
    args = ap.parse_args()
    if args.merge:
        print(table(merged(args.merge)))
        return
    out = run(args)
    print(table(out))
    if args.json:
        rows = {
            k: {"net": v[0].tolist(), "cpu_s_per_episode": v[1]} for k, v in out["rows"].items()
        }
        doc = {**out, "bound": out["bound"].tolist(), "rows": rows, "args": vars(args)}
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(doc, f, indent=1)


if __name__ == "__main__":
    main()
