"""Room to decide on BrakeWearFleet-v0's small fleet (issue 20): every tuned heuristic with
the oracle's RUL against the perfect-information reference.

Small fleet (``SMALL_FLEET``): the default fleet scaled down to 2 vehicles, 1 needed on the
hot route and 1 on the mild one (both always needed: a mine does not buy trucks to park
them), 1 window slot, 1 bay; a half-year episode (365 shifts); every other setting is the
env's default (window every 14 shifts, 4 spares at the start, lead time 14, breakdowns
0.02 per working shift, costs). The oracle's RUL is the
closed-form expected RUL on the hot route from the true volume and K
(``ExpectedRULObservation``; ``--rul oracle``: the oracle predictor through
``FleetRULObservation`` on ``truth=True``, the simulated-ahead RUL, ~20x slower).

1. Each heuristic (agents.fleet.policies.rules; search spaces in agents.fleet.evaluation.tuning,
   the seven of issue 20 and ``standby``) is tuned with Optuna (TPE, seeded) on the tuning
   seeds (``--tune-seeds`` episodes from seed 10_000) for ``--trials`` trials (the
   combination, 8 parameters, for ``--trials-best``, default 3x).
2. The reference (agents.fleet.policies.reference): exact dynamic program over the
   episode plus ``--tail`` shifts, followed in the env by one-step look-ahead, spares by
   the (s, S) of the heuristic chosen as best on the tuning seeds.
3. Every policy runs the evaluation seeds (``--eval-seeds`` episodes from seed 0): common
   random numbers. Cost per vehicle-shift with pads priced when fitted (the headline),
   and paired bootstrap intervals (BCa, 95%) over episodes of each heuristic's gap to the
   reference (difference and ratio of means). The best heuristic is the one best on the
   tuning seeds (no selection on evaluation episodes).
   Also on the reference model's terms (order and holding costs left out, so that the
   reorder rules do not enter the comparison): the column ``gap, model terms``.
4. The reference's predicted cost (its model's terms: no order nor holding cost) against
   its realised cost on the same terms, paired over the evaluation episodes.

Default budget ~5 min of CPU on one core (~4-5 min measured). Run:
``.venv/bin/python benchmarks/fleet_room.py [--trials 10] [--trials-best 30] [--tune-seeds 2]
[--eval-seeds 10] [--shifts 365] [--tail 200] [--rul closed-form|oracle] [--markdown]
[--json f]``.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

from agents.fleet.evaluation.costs import EpisodeCost, paired_interval, run_episodes, term_means
from agents.fleet.evaluation.tuning import SPACES, tune
from agents.fleet.policies.reference import ReferenceModel, ReferencePolicy, solve
from agents.fleet.policies.view import FleetLayout
from brake_env.env.fleet.config import SMALL_FLEET, FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.wrappers import ExpectedRULObservation, FleetRULObservation
from brake_env.output import table, write_json
from brake_env.prognostics.registry import make_predictor

TUNE_SEED0 = 10_000
BEST = "best combination"


def _row(name: str, eps: list[EpisodeCost], ref: list[EpisodeCost]) -> dict[str, Any]:
    x = np.array([e.per_vehicle_shift for e in eps])
    r = np.array([e.per_vehicle_shift for e in ref])
    per = {k: np.mean([e.counts.get(k, 0) for e in eps]) for k in
           ("window_fits", "visits", "shop_fits", "failures", "shortfall", "deferred")}  # fmt: skip
    row: dict[str, Any] = {"policy": name, "cost/veh-shift": float(x.mean()),
                           "billed": float(np.mean([e.billed for e in eps]))}  # fmt: skip
    xm = np.array([e.model_terms for e in eps])
    rm = np.array([e.model_terms for e in ref])
    row["model terms"] = float(xm.mean())
    if eps is not ref:
        row["gap to ref"] = str(paired_interval(x, r, "difference"))
        row["ratio to ref"] = str(paired_interval(x, r, "ratio"))
        row["gap, model terms"] = str(paired_interval(xm, rm, "difference"))
    row.update({k: round(float(v), 2) for k, v in per.items()})
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=10)
    ap.add_argument("--trials-best", type=int, default=None, help="default: 3x --trials")
    ap.add_argument("--tune-seeds", type=int, default=2)
    ap.add_argument("--eval-seeds", type=int, default=10)
    ap.add_argument("--shifts", type=int, default=365)
    ap.add_argument("--tail", type=int, default=200)
    ap.add_argument("--json", default=None)
    ap.add_argument("--markdown", action="store_true")
    ap.add_argument(
        "--rul", choices=("closed-form", "oracle"), default="closed-form",
        help="oracle: the oracle predictor through FleetRULObservation (truth=True; ~20x slower)",
    )  # fmt: skip
    a = ap.parse_args()
    t0 = time.process_time()
    cfg = FleetConfig(**SMALL_FLEET, episode_shifts=a.shifts, truth=a.rul == "oracle")
    env = _rul_env(BrakeWearFleetEnv(cfg), a.rul)
    layout = FleetLayout.of(cfg)
    tune_seeds = list(range(TUNE_SEED0, TUNE_SEED0 + a.tune_seeds))
    eval_seeds = list(range(a.eval_seeds))
    n_best = a.trials_best or 3 * a.trials  # the combination has 8 parameters, not 1-3
    tuned = {
        name: tune(name, env, layout, tune_seeds, n_best if name == BEST else a.trials)
        for name in SPACES
    }
    best = min(tuned.values(), key=lambda t: t.tuning_cost)
    model = ReferenceModel.build(cfg, env.unwrapped.atlas)
    solution = solve(model, a.tail)
    ref = ReferencePolicy(env, model, solution, best.rule.params.s, best.rule.params.S)
    ref_eps = run_episodes(env, ref, eval_seeds, check_masks=True)
    predicted = np.array([_predicted(env, model, solution, s) for s in eval_seeds])
    rows = [_row("perfect-information reference", ref_eps, ref_eps)]
    results = {}
    for name, t in tuned.items():
        results[name] = run_episodes(env, t.rule, eval_seeds, check_masks=True)
        rows.append(_row(name, results[name], ref_eps))
    print(f"Small fleet: {SMALL_FLEET}, {a.shifts} shifts; {a.trials} Optuna trials"
          f" ({n_best} for the combination) x {a.tune_seeds} tuning episodes per heuristic;"
          f" {a.eval_seeds} evaluation"
          f" episodes (seeds 0..{a.eval_seeds - 1}), oracle RUL ({a.rul})")  # fmt: skip
    cols = list(rows[-1])
    print(table([cols, *([_fmt(r.get(c, "")) for c in cols] for r in rows)], a.markdown))
    _room(best.name, results[best.name], ref_eps)
    _every_gap(results, ref_eps)
    _terms({"reference": ref_eps, best.name: results[best.name]}, a.markdown)
    realised = np.array([e.model_terms for e in ref_eps])
    check = paired_interval(realised, predicted, "difference")
    print(
        f"reference: predicted {predicted.mean():.4g}, realised {realised.mean():.4g}"
        f" per vehicle-shift on the model's terms; realised - predicted {check}"
    )
    print("tuned:", {n: {k: _r(v) for k, v in t.params.items()} for n, t in tuned.items()})
    print(f"CPU time {time.process_time() - t0:.0f} s")
    if a.json:
        write_json({"rows": rows, "predicted": predicted.tolist(),
                    "tuned": {n: t.params for n, t in tuned.items()}}, a.json)  # fmt: skip


def _rul_env(env: BrakeWearFleetEnv, rul: str) -> Any:
    if rul == "closed-form":
        return ExpectedRULObservation(env)
    return FleetRULObservation(env, make_predictor("oracle", env.atlas), fields=("rul_mean",))


def _predicted(env: Any, model: ReferenceModel, solution: Any, seed: int) -> float:
    env.reset(seed=seed)
    truth = env.unwrapped.truth()
    h = model.state(truth["volume_frac"], truth["wear_coeff"])
    c = model.config
    return solution.predicted(model, h) / (c.n_vehicles * c.episode_shifts)


def _room(name: str, best: list[EpisodeCost], ref: list[EpisodeCost]) -> None:
    x = np.array([e.per_vehicle_shift for e in best])
    r = np.array([e.per_vehicle_shift for e in ref])
    diff, ratio = paired_interval(x, r, "difference"), paired_interval(x, r, "ratio")
    verdict = "a measurable gap" if diff.low > 0 else "NO measurable gap"
    print(
        f"Room to decide: best tuned heuristic ({name}) {x.mean():.4g} vs reference"
        f" {r.mean():.4g} per vehicle-shift; gap {diff} (95% paired BCa), ratio {ratio}:"
        f" {verdict}"
    )
    xm = np.array([e.model_terms for e in best])
    rm = np.array([e.model_terms for e in ref])
    print(
        f"  on the reference model's terms (no order nor holding cost): {xm.mean():.4g} vs"
        f" {rm.mean():.4g}; gap {paired_interval(xm, rm, 'difference')},"
        f" ratio {paired_interval(xm, rm, 'ratio')}"
    )


def _every_gap(results: dict[str, list[EpisodeCost]], ref: list[EpisodeCost]) -> None:
    """The smallest gap among all heuristics (chosen on evaluation: context, not a claim)
    and how many of the heuristics' gap intervals exclude 0."""
    r = np.array([e.per_vehicle_shift for e in ref])
    gaps = {
        n: paired_interval(np.array([e.per_vehicle_shift for e in eps]), r, "difference")
        for n, eps in results.items()
    }
    low = min(gaps, key=lambda n: gaps[n].point)
    above = sum(g.low > 0 for g in gaps.values())
    print(
        f"  smallest gap on the evaluation episodes: {low} {gaps[low]}; {above} of"
        f" {len(gaps)} heuristics' gap intervals exclude 0"
    )


def _terms(named: dict[str, list[EpisodeCost]], markdown: bool) -> None:
    """Mean cost per vehicle-shift of each term (pads priced when fitted), and the
    difference of the last policy from the first: where the gap comes from."""
    names = list(named)
    per = {n: term_means(eps) for n, eps in named.items()}
    rows = [["term", *names, f"{names[-1]} - {names[0]}"]]
    for t in per[names[0]]:
        vals = [per[n][t] for n in names]
        if any(abs(v) > 0 for v in vals):
            rows.append([t, *(f"{v:.3f}" for v in vals), f"{vals[-1] - vals[0]:+.3f}"])
    print("cost per vehicle-shift by term (pads priced when fitted):")
    print(table(rows, markdown))


def _fmt(v: Any) -> str:
    return f"{v:.4g}" if isinstance(v, float) else str(v)


def _r(v: Any) -> Any:
    return round(v, 2) if isinstance(v, float) else v


if __name__ == "__main__":
    main()
