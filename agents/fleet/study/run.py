"""``brakewear fleet-study``: every policy x predictor on BrakeWearFleet-v0 on the same
evaluation episodes (docs/results/fleet.md, "The fleet study").

Runs the units (:mod:`agents.fleet.study.units`), summarises them
(:mod:`agents.fleet.study.summary`) into ``costs.json``, prints the tables, and draws the
figures: one evaluation episode of the twin's (or the first agent predictor's) best
policy, the agents' learning curves and the cost by term.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from agents.fleet.settings import FleetStudyConfig
from agents.fleet.study.build import episodes_of, rebuild_rule, rul_env, truth_atlas, truth_spec
from agents.fleet.study.fits import check_models
from agents.fleet.study.money import money_lines
from agents.fleet.study.summary import REFERENCE, summarise
from agents.fleet.study.units import run_units, study_fit
from brake_env.model.atlas import Atlas
from brake_env.output import table, write_json
from brake_env.runner import Runner


def run_fleet_study(
    config: FleetStudyConfig,
    atlas: Atlas,
    out: Path,
    runner: Runner,
    *,
    progress: Any = None,
    resume: bool = True,
    n_resamples: int = 4000,
    truth: Atlas | None = None,
) -> dict[str, Any]:
    """Run, summarise and write ``out/costs.json`` and ``out/figures``; the summary.

    ``atlas`` is the physics the predictors are made on; with ``config.effects`` the fleet
    wears on ``truth``, the atlas with the effects (default: built or read from the default
    atlas cache, :func:`~agents.fleet.study.build.truth_atlas`).

    Raises:
        ValueError: ``truth`` is not ``atlas`` with the study's effects, an effect is
            unknown or one an atlas cannot hold, or a user's model (``config.models``) was
            fitted on neither atlas.
    """
    t0 = time.perf_counter()
    truth = _truth(config, atlas, truth)
    check_models(config, atlas, truth)  # a user's model on other physics: before any unit
    units = run_units(config, atlas, out, runner, progress, resume, truth=truth)
    summary = summarise(config, units, n_resamples)
    if config.effects:
        summary["effect"].update(atlas=atlas.content_hash, truth_atlas=truth.content_hash)
    summary["seconds"] = time.perf_counter() - t0
    figures = _figures(config, (atlas, truth), units, summary, out)
    summary["figures"] = [str(p.relative_to(out)) for p in figures]
    write_json(summary, out / "costs.json")
    return summary


def _truth(config: FleetStudyConfig, atlas: Atlas, truth: Atlas | None) -> Atlas:
    """The fleet's atlas: ``atlas`` without effects, else ``truth`` (checked) or built."""
    if not config.effects:
        if truth is not None and truth.content_hash != atlas.content_hash:
            raise ValueError("run_fleet_study: a truth atlas other than the atlas, and no effects")
        return atlas
    if truth is None:
        return truth_atlas(config, atlas)
    want = truth_spec(config, atlas)
    if truth.content_hash != want.content_hash():
        raise ValueError(
            f"run_fleet_study: the truth atlas is not the atlas with the effects"
            f" {list(want.effects)} (its effects: {list(truth.spec.effects)})"
        )
    return truth


def _figures(
    config: FleetStudyConfig, atlases: tuple[Atlas, Atlas], units: dict[str, Any],
    summary: dict[str, Any], out: Path,
) -> list[Path]:  # fmt: skip
    from agents.fleet.study.plots import plot_curves, plot_episode, plot_terms, trace_episode

    figures = [plot_terms(summary["terms"], out / "figures" / "cost_by_term.png")]
    if summary["agents"]:
        figures.append(plot_curves(summary["agents"], out / "figures" / "learning_curves.png"))
    p = "twin" if "twin" in config.predictors else config.predictors[0]
    h = summary["best_heuristic"][p]
    atlas, truth = atlases
    fitted = study_fit(config, p, atlas, truth)
    env = rul_env(config, truth, p, fitted)
    rule = rebuild_rule(config, h, units[config.heuristic_key(p, h)]["params"])
    seed = config.eval_seeds()[0]
    trace = trace_episode(env, rule, seed)
    cost = episodes_of(units[config.heuristic_key(p, h)]["episodes"])[0].per_vehicle_shift
    title = f"{h} tuned on the {p}'s RUL, evaluation episode {seed}: {cost:.1f} per vehicle-shift"
    figures.append(plot_episode(trace, title, out / "figures" / f"episode_{p}.png"))
    return figures


def report(summary: dict[str, Any], markdown: bool = False) -> str:
    """The study's tables as text: policies, the predictors' ranking, the agents."""
    c = summary["config"]
    cur = _currency(summary)
    lines = [
        f"Fleet study: {c['size']} fleet ({c['fleet']['n_vehicles']} vehicles), {c['shifts']}"
        f" shifts an episode; {c['eval_episodes']} evaluation episodes (the same for every"
        f" policy); heuristics tuned with {c['trials']} Optuna trials ({c['trials_best']} for"
        f" the combination) on {c['tune_episodes']} tuning episodes each. Cost in {cur} per"
        " vehicle-shift, pads priced when fitted; intervals 95%, paired over episodes."
    ]
    bound = summary.get("bound")
    gap = ["net cost", "gap to bound (net)"] if bound else []
    head = ["predictor", "policy", f"cost ({cur})", "tuning cost", "ratio to reference", *gap,
            "fits", "failures"]  # fmt: skip
    rows = [head]
    best = summary["best_heuristic"]
    for r in summary["rows"]:
        mark = " *" if best.get(r["predictor"]) == r["policy"] else ""
        fits = r["window_fits"] + r["shop_fits"] + r["visits"] + r["corrective_fits"]
        tuning = "" if r["tuning_cost"] is None else f"{r['tuning_cost']:.2f}"
        ratio = _ivs(r.get("ratio_to_reference"))
        to_bound = [f"{r['net_cost']:.2f}", _ivs(r.get("gap_to_bound"))] if bound else []
        rows.append([r["predictor"], r["policy"] + mark, f"{r['cost']:.2f}", tuning, ratio,
                     *to_bound, f"{fits:.1f}", f"{r['failures']:.2f}"])  # fmt: skip
    for a in summary["agents"].values():
        rows.append([a["predictor"], f"{_agent_name(a)} (IQM of {a['seeds']} seeds)",
                     _ivs(a["iqm"], 2), "", _ivs(a.get("ratio_to_reference")), "", ""])  # fmt: skip
    lines += [table(rows, markdown), "* the predictor's best heuristic (on the tuning episodes)"]
    lines += _planner_lines(summary) + _effect_lines(summary, markdown)
    lines += money_lines(summary, table, markdown)
    rk = summary["ranking"]
    lines.append(f"\nPredictors by their best heuristic's cost ({cur} per vehicle-shift): "
                 + ", ".join(f"{p} {rk['cost'][p]:.2f}" for p in rk["order"]))  # fmt: skip
    if rk["head_minus"]:  # one predictor alone has nothing to be compared with
        rows = [["predictor", f"{rk['head']} minus it", f"{rk['head']} / it"]]
        head = rk["cost"][rk["head"]]
        rows += [[p, _ivs(v["difference"]), _ratio(v["ratio"], head, rk["cost"][p])]
                 for p, v in rk["head_minus"].items()]  # fmt: skip
        lines.append(table(rows, markdown))
    for a in summary["agents"].values():
        lines.append(
            f"\n{_agent_name(a)} with the {a['predictor']}'s RUL, {a['seeds']} training seeds"
            f" (cloned from: {a['teacher']}): IQM {_ivs(a['iqm'])}; minus the tuned"
            f" {a['heuristic']}"
            f" ({a['heuristic_cost']:.2f}): {_ivs(a['minus_heuristic'])}, ratio"
            f" {_ratio(a['ratio_to_heuristic'], a['iqm']['point'], a['heuristic_cost'])};"
            f" {a['seeds_beating_heuristic']} of {a['seeds']}"
            f" seeds below it; training {min(a['train_seconds']):.0f}-"
            f"{max(a['train_seconds']):.0f} s a seed{_agreement(a)}"
        )
    return ("\n\n" if markdown else "\n").join(lines)  # Markdown: a table needs a blank line


def _planner_lines(summary: dict[str, Any]) -> list[str]:
    """The bound and the rollout planners against their bases."""
    lines = []
    b = summary.get("bound")
    if b:
        lines.append(
            f"\nLagrangian lower bound (any policy, any information) on the cost net of the pad"
            f" life left at the end: {b['cost']:.3f} {_currency(summary)} per vehicle-shift on"
            " these episodes"
            f" ({min(b['episodes']):.3f}-{max(b['episodes']):.3f};"
            f" {b['iterations']} price vectors, {b['seconds']['bound']:.0f} s; at zero prices"
            f" {b['zero_prices']:.3f}). Gaps to it are paired over episodes."
        )
    for p, r in summary.get("rollout", {}).items():
        lines.append(
            f"Rollout on the {p}'s {r['base']}: {r['cost']:.3f} against its base's"
            f" {r['base_cost']:.3f}, difference {_ivs(r['minus_base'])}, ratio"
            f" {_ratio(r['ratio_to_base'], r['cost'], r['base_cost'])};"
            f" {r['seconds_per_shift']:.2f} s a decision"
            f" ({r['seconds'] / 60:.1f} min of evaluation in all)"
        )
    return lines


def _effect_lines(summary: dict[str, Any], markdown: bool) -> list[str]:
    """With effects: what the fleet wore with, and the predictors' best heuristics paired."""
    e = summary.get("effect")
    if not e:
        return []
    atlas = f" (atlas {e['truth_atlas'][:16]})" if "truth_atlas" in e else ""
    rows = [["best heuristics", "net cost difference", "cost difference"]]
    rows += [[k, _ivs(v["net"]), _ivs(v["cost"])] for k, v in e["pairs"].items()]
    return [
        f"\nThe fleet's pads wear with the unmodelled effect(s) {', '.join(e['effects'])}"
        f"{atlas}, as do the predictors' training pads; each predictor is made on the nominal"
        " physics, NAME+effect on the physics with the effects (the diagnosis fed back); the"
        " oracle reads the truth. Paired over the evaluation episodes:",
        table(rows, markdown),
    ]


def _currency(summary: dict[str, Any]) -> str:
    """The fleet file's currency (a study written before the money: its unnamed units)."""
    return str(summary["money"]["currency"]) if "money" in summary else "currency units"


def _agreement(a: dict[str, Any]) -> str:
    """The clones' agreement with the teacher on its own data, if they were cloned."""
    got = [x for x in a.get("clone_agreement", []) if x is not None]
    if not got:
        return ""
    return f"; clones agree with the teacher on {min(got):.1%}-{max(got):.1%} of its decisions"


def _agent_name(a: dict[str, Any]) -> str:
    return "MaskablePPO" if a["kind"] == "central" else "parameter-shared MaskablePPO"


def _ivs(d: dict[str, float] | None, digits: int = 3) -> str:
    if not d:
        return ""
    return f"{d['point']:.{digits}f} [{d['low']:.{digits}f}, {d['high']:.{digits}f}]"


def _ratio(d: dict[str, float] | None, *figures: float) -> str:
    """A ratio's interval, or why none is printed: a figure it divides is not positive (a
    net cost can be negative; a ratio of such figures ranks them backwards)."""
    return _ivs(d) if min(figures) > 0 else "n/a (a cost not positive: see the difference)"


__all__ = ["REFERENCE", "report", "run_fleet_study"]
