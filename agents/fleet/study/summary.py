"""The fleet study's figures from its units (``costs.json``): each policy's cost per
vehicle-shift, its gap to the perfect-information reference, predictors ranked by their
best policy's cost, and the agents aggregated over training seeds.

Every interval pairs episodes (all policies ran the same evaluation episodes): BCa over
episodes for two policies (:func:`~agents.fleet.evaluation.costs.paired_interval`). An agent is
a distribution over training seeds: its figure is the interquartile mean (IQM) of the
seeds' mean costs, as rliable reports it, and its interval comes from a two-level
bootstrap that resamples the seeds and, paired with the heuristic's, the episodes
(percentile intervals of the IQM, its difference from the heuristic and their ratio).
A study with effects also compares every two predictors' best heuristics (``effect``).
Every row's figures a year and ``money`` (the fleet file's currency; each predictor's value
against the fixed interval and the oracle): :mod:`agents.fleet.study.money`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.fleet.evaluation.costs import (
    EpisodeCost,
    Interval,
    figures,
    paired_interval,
    seeds_interval,
    term_means,
)
from agents.fleet.settings import FED_BACK, FleetStudyConfig, Objective
from agents.fleet.study.build import episodes_of
from agents.fleet.study.money import add_money
from agents.fleet.study.planners import BOUND, PRICED
from agents.fleet.study.units import best_heuristic
from brake_env.prognostics.registry import ORACLE

F64 = NDArray[np.float64]
REFERENCE = "perfect-information reference"
AGENT = "MaskablePPO"


def costs(eps: list[EpisodeCost]) -> F64:
    return np.array([e.per_vehicle_shift for e in eps])


def summarise(
    config: FleetStudyConfig, units: dict[str, Any], n_resamples: int = 4000
) -> dict[str, Any]:
    """``costs.json``: the rows, the best heuristic per predictor, the predictors' ranking
    and the agents' aggregate (the targets are read from it by
    ``benchmarks/analysis/fleet_study_targets.py``)."""
    eps = {(p, h): episodes_of(units[config.heuristic_key(p, h)]["episodes"])
           for p in config.predictors for h in config.heuristics}  # fmt: skip
    ref_key = config.reference_key()
    ref = episodes_of(units[ref_key]["episodes"]) if ref_key in units else None
    rows = []
    if ref is not None:
        rows.append(_row(ORACLE, REFERENCE, ref, None, None))
        if "predicted" in units[ref_key]:
            rows[-1]["episodes"]["predicted"] = np.asarray(units[ref_key]["predicted"]).tolist()
    for (p, h), e in eps.items():
        u = units[config.heuristic_key(p, h)]
        rows.append(_row(p, h, e, ref, u["tuning_cost"], params=u["params"]))
        if "best_so_far" in u:  # whether more trials still moved the tuning objective
            rows[-1]["best_so_far"] = np.asarray(u["best_so_far"]).tolist()
    best = {p: best_heuristic(config, units, p) for p in config.predictors}
    planners = _planners(config, units, eps, best, ref, rows)
    money = add_money(config, rows, eps, best)  # every row's figures a year, too
    ranking = _ranking(config, eps, best)
    agents = {}
    for kind, n in (("central", config.agent_seeds), ("shared", config.shared_seeds)):
        for p in config.agent_predictors if n else ():
            runs = [units[config.agent_key(p, s, kind)] for s in range(n)]
            label = p if kind == "central" else f"{p}, shared"
            agents[label] = _agents(runs, best[p], eps[(p, best[p])], ref=ref,
                                    n_resamples=n_resamples,
                                    objective=config.objective)  # fmt: skip
    out: dict[str, Any] = {
        "config": _config_dict(config),
        "rows": rows,
        "best_heuristic": best,
        "ranking": ranking,
        "agents": agents,
        "terms": {f"{p} / {best[p]}": term_means(eps[(p, best[p])]) for p in config.predictors},
        "money": money,
        **planners,
    }
    if ref is not None:
        out["terms"][REFERENCE] = term_means(ref)
    if config.effects:
        out["effect"] = _effect(config, eps, best)
    return out


def _effect(
    config: FleetStudyConfig, eps: dict[tuple[str, str], list[EpisodeCost]], best: dict[str, str]
) -> dict[str, Any]:
    """The effects, and every two predictors' best heuristics compared (paired over the
    evaluation episodes, on the net and the headline cost): NAME against NAME+effect as
    NAME minus NAME+effect (what the misfit costs, which feeding the diagnosis back
    recovers), any other two as the one listed later minus the one listed earlier."""
    pairs = {}
    ps = config.predictors
    for j, a in enumerate(ps):
        for b in ps[:j]:
            x, y = (b, a) if a == b + FED_BACK else (a, b)
            ex, ey = eps[(x, best[x])], eps[(y, best[y])]
            pairs[f"{x} minus {y}"] = {
                o: _iv(paired_interval(figures(ex, o), figures(ey, o), "difference"))
                for o in ("net", "cost")
            }
    return {"effects": list(config.effects), "pairs": pairs}


def _planners(
    config: FleetStudyConfig, units: dict[str, Any], eps: dict[tuple[str, str], list[EpisodeCost]],
    best: dict[str, str], ref: list[EpisodeCost] | None, rows: list[dict[str, Any]],
) -> dict[str, Any]:  # fmt: skip
    """The price-directed policy's and the rollout planners' rows (appended to ``rows``);
    every row's paired gap to the Lagrangian bound; ``bound`` and ``rollout`` summaries."""
    out: dict[str, Any] = {"rollout": {}}
    for p in config.rollout_predictors:
        chunks = [units[config.rollout_key(p, i)] for i in range(len(config.rollout_chunks()))]
        got = [e for c in chunks for e in episodes_of(c["episodes"])]
        rows.append(_row(p, chunks[0]["policy"], got, ref, None))
        x, base = figures(got, config.objective), figures(eps[(p, best[p])], config.objective)
        seconds = sum(float(c["seconds"]) for c in chunks)
        out["rollout"][p] = {
            "base": best[p], "cost": float(x.mean()), "base_cost": float(base.mean()),
            "minus_base": _iv(paired_interval(x, base, "difference")),
            "ratio_to_base": _iv(paired_interval(x, base, "ratio")),
            "seconds": seconds, "seconds_per_shift": seconds / sum(e.shifts for e in got),
        }  # fmt: skip
    if not config.bound_iterations:
        return out
    b = units[config.bound_key()]
    rows.append(_row(ORACLE, PRICED, episodes_of(b["priced"]), ref, None))
    bound = np.asarray(b["bound"], dtype=float)
    to_bound(rows, bound)
    out["bound"] = {
        "policy": BOUND, "cost": float(bound.mean()), "episodes": bound.tolist(),
        "zero_prices": float(b["zero_prices_bound"]), "iterations": int(b["iterations"]),
        "seconds": dict(b["seconds"]),
    }  # fmt: skip
    return out


def to_bound(rows: list[dict[str, Any]], bound: F64) -> None:
    """Each row's paired gap to the bound per episode (on the cost net of the pad life left,
    :attr:`EpisodeCost.net`), and its ratio where both figures are positive (none to a
    figure that is not: a ratio of negative costs ranks them backwards)."""
    for r in rows:
        x = np.asarray(r["episodes"]["net"], dtype=float)
        r["gap_to_bound"] = _iv(paired_interval(x, bound, "difference"))
        if x.mean() > 0 and bound.mean() > 0:
            r["ratio_to_bound"] = _iv(paired_interval(x, bound, "ratio"))


def _config_dict(config: FleetStudyConfig) -> dict[str, Any]:
    from dataclasses import asdict

    d = asdict(config)
    for k in ("effects", "models"):  # a study without them writes the config it always wrote
        if not d[k]:
            del d[k]
    d["fleet"] = {k: v for k, v in asdict(config.fleet).items() if not isinstance(v, dict)}
    return d


def _row(
    predictor: str, policy: str, eps: list[EpisodeCost], ref: list[EpisodeCost] | None,
    tuning: float | None, params: dict[str, Any] | None = None,
) -> dict[str, Any]:  # fmt: skip
    x = costs(eps)
    net = np.array([e.net for e in eps])
    row: dict[str, Any] = {"predictor": predictor, "policy": policy, "cost": float(x.mean()),
                           "net_cost": float(net.mean()), "tuning_cost": tuning}  # fmt: skip
    if ref is not None and eps is not ref:
        r = costs(ref)
        row["gap_to_reference"] = _iv(paired_interval(x, r, "difference"))
        row["ratio_to_reference"] = _iv(paired_interval(x, r, "ratio"))
    for k in ("window_fits", "visits", "shop_fits", "corrective_fits", "failures", "shortfall"):
        row[k] = float(np.mean([e.counts.get(k, 0.0) for e in eps]))
    if params is not None:
        row["params"] = params
    # Per evaluation episode (the same seeds for every row): what a reader needs to pair
    # any two policies (benchmarks/analysis/fleet_room.py).
    row["episodes"] = {"seed": [e.seed for e in eps], "cost": x.tolist(), "net": net.tolist(),
                       "model_terms": [e.model_terms for e in eps]}  # fmt: skip
    return row


def _ranking(
    config: FleetStudyConfig, eps: dict[tuple[str, str], list[EpisodeCost]], best: dict[str, str]
) -> dict[str, Any]:
    """Each predictor's best heuristic's cost (``config.objective``'s figure), and the
    twin's (or the first predictor's) difference from every other predictor's best (paired
    over episodes)."""

    def fig(p: str) -> F64:
        return figures(eps[(p, best[p])], config.objective)

    order = sorted(config.predictors, key=lambda p: fig(p).mean())
    head = "twin" if "twin" in config.predictors else order[0]
    h = fig(head)
    against = {}
    for p in config.predictors:
        if p != head:
            o = fig(p)
            against[p] = {"difference": _iv(paired_interval(h, o, "difference")),
                          "ratio": _iv(paired_interval(h, o, "ratio"))}  # fmt: skip
    return {
        "order": order,
        "objective": config.objective,
        "cost": {p: float(fig(p).mean()) for p in config.predictors},
        "head": head,
        "head_minus": against,
    }


def _agents(
    runs: list[dict[str, Any]], heuristic_name: str, heuristic: list[EpisodeCost], *,
    ref: list[EpisodeCost] | None, n_resamples: int, objective: Objective = "cost",
) -> dict[str, Any]:  # fmt: skip
    """One kind of agent with one predictor's RUL over its training seeds (``runs``),
    against that predictor's best heuristic and the reference (on ``objective``'s figure)."""
    per_seed = np.stack([figures(episodes_of(r["episodes"]), objective) for r in runs])
    h = figures(heuristic, objective)
    vs = seeds_interval(per_seed, h, n_resamples=n_resamples)
    out: dict[str, Any] = {
        "predictor": runs[0]["predictor"],
        "kind": runs[0]["kind"],
        "seeds": len(runs),
        "seed_costs": per_seed.mean(axis=1).tolist(),
        "iqm": _iv(vs["iqm"]),
        "minus_heuristic": _iv(vs["difference"]),
        "ratio_to_heuristic": _iv(vs["ratio"]),
        "heuristic": heuristic_name,
        "heuristic_cost": float(h.mean()),
        "seeds_beating_heuristic": int((per_seed.mean(axis=1) < h.mean()).sum()),
        "train_seconds": [float(r["seconds"]["train"]) for r in runs],
        "curves": [{"timesteps": np.asarray(r["curve"]["timesteps"]).tolist(),
                    "cost": np.asarray(r["curve"]["cost"]).tolist()} for r in runs],
        "teacher": runs[0]["teacher"],
        # the clone's agreement with its teacher on the teacher's data, per seed
        "clone_agreement": [r["imitation"].get("agreement") for r in runs],
    }  # fmt: skip
    if ref is not None:
        out["ratio_to_reference"] = _iv(
            seeds_interval(per_seed, figures(ref, objective), n_resamples=n_resamples)["ratio"]
        )
    return out


def _iv(i: Interval) -> dict[str, float]:
    return {"point": i.point, "low": i.low, "high": i.high}
