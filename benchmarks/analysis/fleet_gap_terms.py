"""Where a policy's gap to the Lagrangian bound is, term by term, on a suite's dev split
(never the test split: episodes reaching it are refused).

Each policy (as ``fleet-score`` takes it: ``MODULE:FACTORY`` on the suite's observation,
or ``baseline:NAME`` rebuilt from the shipped settings) runs the dev episodes; its net cost
is split into the bill's groups (:func:`agents.fleet.evaluation.gap_terms.episode_terms`:
fits, orders and holding, shop visits, damage, downtime, shortfalls, less the pad life
left). The study's bound (relaxed, orders charged:
:func:`agents.fleet.study.planners.study_bound`) is split the same way on each episode's
start (:func:`agents.fleet.evaluation.gap_terms.bound_terms`; its ``shortfall`` is the
prices' terms). Printed: what the net credits a new pad for against its fit (above 1 where
slow pads outlive a mean-K pad: ``default-mixed``), each group's mean per vehicle-shift for the
bound and each policy, and the policy minus the bound with a 95% paired bootstrap interval
over episodes; the groups add up to the net cost and to the bound. Pad use and the needs
are read together (:data:`PADS_AND_NEEDS`).

Run: ``.venv/bin/python benchmarks/analysis/fleet_gap_terms.py --suite default --episodes 10
--policies agents.fleet.policies.index:factory,baseline:twin-rule``
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

from agents.fleet.benchmark.baselines import read_baselines
from agents.fleet.benchmark.score import suite_policy
from agents.fleet.benchmark.suite import read_suite
from agents.fleet.evaluation.costs import paired_interval, run_episode
from agents.fleet.evaluation.gap_terms import TERMS, bound_terms, episode_terms
from agents.fleet.policies.lagrangian import BoundModel, start_counts
from agents.fleet.policies.lagrangian_search import occupation
from agents.fleet.study.planners import study_bound
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.model.atlas import AtlasSpec, cached_atlas
from brake_env.model.params import BrakeModel
from brake_env.output import table

PADS_AND_NEEDS = "fits+shortfall+credit"
"""Read together: at the searched prices a vehicle is near indifferent between driving (and
wearing its pad) and the needs' price, so the program's split between pad use (fits less
the life left) and the needs' prices is one of many as cheap; only their sum is the
bound's."""


def bound_rows(config: Any, atlas: Any, iterations: int) -> np.ndarray:
    """(episodes, terms): the study's bound on each episode's start, by term."""
    cfg = config.fleet
    result, _ = study_bound(config, atlas, iterations)
    model = BoundModel.relaxed(cfg, atlas, credit=True, orders=True)  # study_bound's model
    env = BrakeWearFleetEnv(cfg, atlas=atlas)
    rows, fits = [], []
    for seed in config.eval_seeds():
        env.reset(seed=seed)
        tr = env.truth()
        start = start_counts(model, model.state(tr["volume_frac"], tr["wear_coeff"]))
        excess = model.excess(tr["volume_frac"], tr["wear_coeff"])
        terms = bound_terms(model, result.program, result.prices, start, excess)
        rows.append([terms[k] for k in TERMS])
        occ = occupation(model, result.program, start)
        fits.append(occ.window_fits + occ.visits + occ.shop_fits)
    print(new_pad_line(model, np.mean(fits, axis=0)))
    return np.array(rows)


def new_pad_line(model: BoundModel, fits: np.ndarray) -> str:
    """What the net credits a new pad for, on average, against what fitting it costs; and the
    bound's fits (the fleet's, expected) at the last two windows."""
    credit = model.credit * (float(model.new_prob @ np.arange(model.H + 1)) + model.new_tail)
    cfg = model.config
    last = [t for t in range(cfg.episode_shifts) if cfg.is_window(t)][-2:]
    at = ", ".join(f"shift {t}: {fits[t]:.2f}" for t in last)
    return (
        f"a new pad: credited {credit:.1f} on average, fitted for"
        f" {model.fit_cost + model.order_share:.1f}; the bound's fits at the last windows"
        f" ({at})"
    )


def policy_rows(suite: Any, spec: str, config: Any, atlas: Any) -> tuple[np.ndarray, float]:
    """((episodes, terms) of the policy, CPU seconds an episode)."""
    env, adapted, _ = suite_policy(suite, spec, atlas, config, read_baselines(suite))
    if not hasattr(adapted, "predict"):
        raise ValueError(f"--policies {spec}: a policy over seeds or per agent gives no"
                         " one episode's terms; give a rule, a rollout or one policy")  # fmt: skip
    t0 = time.process_time()
    rows = []
    for seed in config.eval_seeds():
        terms = episode_terms(run_episode(env, adapted, seed, check_masks=True))
        rows.append([terms[k] for k in TERMS])
    return np.array(rows), (time.process_time() - t0) / len(rows)


def report(low: np.ndarray, rows: dict[str, np.ndarray]) -> str:
    """One line per group (and the total): the bound, then each policy and its excess."""
    head = ["group", "bound"]
    for name in rows:
        head += [name, "minus bound (95%)"]
    body = []
    groups = {g: [TERMS.index(g)] for g in TERMS}
    groups[PADS_AND_NEEDS] = [TERMS.index(g) for g in ("fits", "shortfall", "credit")]
    groups["net"] = list(range(len(TERMS)))
    for group, cols in groups.items():
        b = low[:, cols].sum(axis=1)
        line = [group, f"{b.mean():.3f}"]
        for x in rows.values():
            p = x[:, cols].sum(axis=1)
            i = paired_interval(p, b)
            line += [f"{p.mean():.3f}", f"{i.point:+.3f} [{i.low:+.3f}, {i.high:+.3f}]"]
        body.append(line)
    return table([head, *body])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--suite", default="default")
    ap.add_argument("--episodes-from", type=int, default=0)
    ap.add_argument("--episodes", type=int, default=10)
    ap.add_argument("--iterations", type=int, default=100, help="the bound's price steps")
    ap.add_argument("--policies", default="agents.fleet.policies.index:factory,baseline:twin-rule",
                    help="comma-separated MODULE:FACTORY or baseline:NAME")  # fmt: skip
    args = ap.parse_args()
    suite = read_suite(args.suite)
    try:
        config = suite.dev_config(args.episodes_from, args.episodes)
    except ValueError as e:
        raise SystemExit(str(e)) from None
    atlas = cached_atlas(AtlasSpec(model=BrakeModel.preset(config.fleet.preset)), None)
    t0 = time.process_time()
    low = bound_rows(config, atlas, args.iterations)
    print(f"bound: {time.process_time() - t0:.0f} CPU s ({args.iterations} price steps)")
    rows = {}
    for spec in filter(None, args.policies.split(",")):
        name = spec.split(":")[1] if spec.startswith("baseline:") else spec.split(":")[0]
        rows[name.rsplit(".", 1)[-1]], cpu = policy_rows(suite, spec, config, atlas)
        print(f"{spec}: {cpu:.1f} CPU s an episode")
    seeds = config.eval_seeds()
    print(f"{suite.name}, dev episodes {seeds[0]}..{seeds[-1]}, per vehicle-shift")
    print(report(low, rows))


if __name__ == "__main__":
    main()
