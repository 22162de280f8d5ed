"""``distil.json`` of ``brakewear fleet-distil``: the distilled policy over training seeds
against the study's rows on the same evaluation episodes (common random numbers): the base
heuristic the planner improves, the rollout planner itself and the Lagrangian bound.

Figures are on the study's objective (its ``objective``: the headline or the net cost per
vehicle-shift); the bound is on the net cost, so the ratio to it always uses the net cost.
The policy's figure is the IQM over seeds with a two-level bootstrap (seeds, then episodes
paired with the other policy's: :func:`~agents.fleet.evaluation.costs.seeds_interval`);
the share of the heuristic-to-planner gap it closes comes from the same resamples
(:func:`~agents.fleet.evaluation.costs.gap_closed`).
"""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.fleet.evaluation.costs import figures, gap_closed, seeds_interval
from agents.fleet.settings import Objective
from agents.fleet.study.build import episodes_of
from agents.fleet.study.distil_job import Job
from brake_env.output import table

F64 = NDArray[np.float64]


def study_row(study: dict[str, Any], predictor: str, policy: str) -> dict[str, Any] | None:
    """The study's row of ``predictor``'s ``policy``, if it has one."""
    rows = [r for r in study["rows"] if r["predictor"] == predictor and r["policy"] == policy]
    return rows[0] if rows else None


def _episode_figure(row: dict[str, Any], objective: str, seeds: list[int]) -> F64:
    e = row["episodes"]
    if list(e["seed"]) != seeds:
        raise ValueError(f"fleet-distil: the study's row {row['policy']!r} ran episodes"
                         f" {list(e['seed'])[:5]}..., not the evaluation episodes"
                         f" {seeds[:5]}...")  # fmt: skip
    return np.asarray(e["net" if objective == "net" else "cost"], dtype=np.float64)


def summarise_distil(
    job: Job, study: dict[str, Any], units: dict[str, Any], n_resamples: int = 4000
) -> dict[str, Any]:
    """The labels' cost, and each kind of distilled policy (``central``, ``shared``) over
    its seeds against the study's rows."""
    d = job.distil
    labels = [units[k] for k in job.label_keys(d.label_rounds + 1)]
    out: dict[str, Any] = {
        "predictor": d.predictor, "objective": job.study.objective, "base": job.base[0],
        "params": job.base[1], "distil": asdict(d), "labels": _labels(labels),
    }  # fmt: skip
    for kind in ("central", "shared"):
        trained = [units[job.seed_key(s, kind)] for k, s in job.seed_runs() if k == kind]
        if trained:
            out[kind] = _policy(job, study, trained, out["labels"], n_resamples)
    return out


def _policy(
    job: Job, study: dict[str, Any], trained: list[dict[str, Any]], labels: dict[str, Any],
    n_resamples: int,
) -> dict[str, Any]:  # fmt: skip
    """One kind's seeds, its IQM against the heuristic, the planner and the bound, its speed."""
    d, objective = job.distil, job.study.objective
    seeds = job.study.eval_seeds()
    eps = [episodes_of(u["episodes"]) for u in trained]
    per_seed = np.array([figures(e, objective) for e in eps])
    net = np.array([figures(e, "net") for e in eps])
    out: dict[str, Any] = {
        "seeds": [_seed_row(u, e, objective) for u, e in zip(trained, eps, strict=True)]
    }
    base = study_row(study, d.predictor, job.base[0])
    planner = study_row(study, d.predictor, f"rollout on {job.base[0]}")
    cmp = out["compared"] = {}
    if base is not None:
        b = _episode_figure(base, objective, seeds)
        cmp["base"] = {"cost": float(b.mean()),
                       **_ivs(seeds_interval(per_seed, b, n_resamples=n_resamples))}  # fmt: skip
        if planner is not None:
            p = _episode_figure(planner, objective, seeds)
            vs = seeds_interval(per_seed, p, n_resamples=n_resamples)
            cmp["planner"] = {"cost": float(p.mean()), **_ivs(vs)}
            cmp["gap_closed"] = asdict(gap_closed(per_seed, b, p, n_resamples=n_resamples))
    bound = study.get("bound")
    if bound:
        bd = np.asarray(bound["episodes"], dtype=np.float64)
        ratio = seeds_interval(net, bd, n_resamples=n_resamples)["ratio"]
        cmp["bound"] = {"cost": float(bd.mean()), "ratio": asdict(ratio)}
    agent_s = float(np.median([u["seconds_per_decision"] for u in trained]))
    planner_s = labels["planner_seconds_per_decision"]
    out["speed"] = {"agent_seconds_per_decision": agent_s,
                    "planner_seconds_per_decision": planner_s,
                    "times_faster": planner_s / agent_s}  # fmt: skip
    return out


def _ivs(x: dict[str, Any]) -> dict[str, Any]:
    return {k: asdict(v) for k, v in x.items()}


def _labels(labels: list[dict[str, Any]]) -> dict[str, Any]:
    """What the shared labels cost, and how far each round's driver agreed with the planner."""
    rounds = sorted({int(u["round"]) for u in labels})
    per_round = []
    for r in rounds:
        us = [u for u in labels if int(u["round"]) == r]
        shifts = sum(len(u["rewards"]) for u in us)
        agree = sum(float(u["agreement"]) * len(u["rewards"]) for u in us) / shifts
        per_round.append({"round": r, "episodes": sum(len(u["seeds"]) for u in us),
                          "shifts": shifts, "driver_agreement": agree})  # fmt: skip
    planner_s = sum(float(u["planner_seconds"]) for u in labels)
    decisions = sum(int(u["decisions"]) for u in labels)
    return {"rounds": per_round, "seconds": sum(float(u["seconds"]) for u in labels),
            "planner_seconds_per_decision": planner_s / decisions,
            "repaired": sum(int(u.get("repaired", 0)) for u in labels),
            "shifts": sum(len(u["rewards"]) for u in labels)}  # fmt: skip


def _seed_row(u: dict[str, Any], eps: list[Any], objective: Objective) -> dict[str, Any]:
    return {
        "seed": int(u["seed"]), "figure": float(np.mean(figures(eps, objective))),
        "cost": float(np.mean(figures(eps, "cost"))), "net": float(np.mean(figures(eps, "net"))),
        "failures": float(np.mean([e.counts.get("failures", 0.0) for e in eps])),
        "agreement": float(u["agreement"]), "samples": int(u["samples"]),
        "train_seconds": float(u["seconds"]["train"]),
        "evaluate_seconds": float(u["seconds"]["evaluate"]),
        "seconds_per_decision": float(u["seconds_per_decision"]),
        "curve": {k: np.asarray(v).tolist() for k, v in u["curve"].items()},
        "episodes": {"seed": [int(e.seed) for e in eps], "net": figures(eps, "net").tolist(),
                     "cost": figures(eps, "cost").tolist()},
    }  # fmt: skip


def _iv(x: dict[str, float], digits: int = 3) -> str:
    return f"{x['point']:.{digits}f} [{x['low']:.{digits}f}, {x['high']:.{digits}f}]"


NO_RATIO = (
    "n/a: no ratio where a cost is not positive (a net cost less the pad life left can be"
    " negative, and a ratio of two such costs ranks them backwards); the difference is shown"
)
NAMES = {"central": "Central policy", "shared": "Policy shared by the vehicles (TorchRL)"}


def distil_report(s: dict[str, Any], markdown: bool = False) -> str:
    """Each distilled policy against the heuristic, the planner and the bound; its seeds;
    what the labels cost."""
    lab = s["labels"]
    rounds = ", ".join(f"round {r['round']}: {r['episodes']} episodes, driver agrees with the"
                       f" planner on {r['driver_agreement']:.1%} of shifts"
                       for r in lab["rounds"])  # fmt: skip
    lines = [f"The rollout planner on {s['base']} distilled, {s['predictor']}'s RUL",
             f"Labels (once, shared by every seed): {lab['seconds']:.0f} s of CPU; {rounds}",
             f"The policies' feasibility repair (cover_needs) changes {lab['repaired']} of the"
             f" planner's {lab['shifts']} labelled shifts",
             ""]  # fmt: skip
    for kind in ("central", "shared"):
        if kind in s:
            lines += [_policy_report(s, s[kind], NAMES[kind], markdown), ""]
    return "\n".join(lines).rstrip()


def _ratio(x: dict[str, float], *costs: float) -> str:
    """The ratio's interval, or "n/a" where a cost it divides is not positive."""
    return _iv(x) if min(costs) > 0 else "n/a"


def _policy_report(s: dict[str, Any], p: dict[str, Any], name: str, markdown: bool) -> str:
    c, sp = p["compared"], p["speed"]
    fig = "net cost" if s["objective"] == "net" else "cost"
    mine = float(np.mean([r["figure"] for r in p["seeds"]]))
    net = float(np.mean([r["net"] for r in p["seeds"]]))  # the bound's ratio is on the net
    rows = [["policy", f"{fig} / vehicle-shift", "policy minus it (IQM)", "ratio"]]
    shown = [mine]
    if "base" in c:
        rows.append([f"{s['base']} (tuned)", f"{c['base']['cost']:.3f}",
                     _iv(c["base"]["difference"]),
                     _ratio(c["base"]["ratio"], mine, c["base"]["cost"])])  # fmt: skip
        shown.append(c["base"]["cost"])
    if "planner" in c:
        rows.append([f"rollout on {s['base']}", f"{c['planner']['cost']:.3f}",
                     _iv(c["planner"]["difference"]),
                     _ratio(c["planner"]["ratio"], mine, c["planner"]["cost"])])  # fmt: skip
        shown.append(c["planner"]["cost"])
    if "bound" in c:
        rows.append(["Lagrangian bound (net)", f"{c['bound']['cost']:.3f}", "",
                     _ratio(c["bound"]["ratio"], net, c["bound"]["cost"])])  # fmt: skip
        shown += [net, c["bound"]["cost"]]
    iqm = c.get("base", {}).get("iqm")
    lines = [f"{name}, {len(p['seeds'])} seeds" + (f": IQM {_iv(iqm)}" if iqm else ""),
             table(rows, markdown), ""]  # fmt: skip
    if min(shown) <= 0:
        lines += [NO_RATIO, ""]
    if "gap_closed" in c:
        closed = c["gap_closed"]
        same = "The planner and the heuristic cost the same here: no gap to close"
        lines.append(f"Share of the heuristic-to-planner gap closed: {_iv(closed)}"
                     if np.isfinite(closed["point"]) else same)  # fmt: skip
    lines += [
        f"Decision: planner {sp['planner_seconds_per_decision'] * 1e3:.1f} ms, policy"
        f" {sp['agent_seconds_per_decision'] * 1e3:.2f} ms ({sp['times_faster']:.0f}x faster)",
        "",
    ]  # fmt: skip
    seed_rows = [["seed", fig, "cost", "net", "failures", "agreement", "train s", "evaluate s"]]
    seed_rows += [[str(r["seed"]), f"{r['figure']:.3f}", f"{r['cost']:.3f}", f"{r['net']:.3f}",
                   f"{r['failures']:.2f}", f"{r['agreement']:.3f}", f"{r['train_seconds']:.0f}",
                   f"{r['evaluate_seconds']:.0f}"] for r in p["seeds"]]  # fmt: skip
    lines.append(table(seed_rows, markdown))
    return "\n".join(lines)
