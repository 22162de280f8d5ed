"""``brakewear plan`` run: the fleet's state from the log and the model, the policy, the
futures, and the outputs (``plan.csv``, ``plan.json``, ``plan.png``; docs/plan.md).

The futures run on the model's physics (the atlas it was fitted on, a fed-back effect
included) and the fleet file's other fields; the fleet is placed in its window cycle by
``--shifts-to-window``, its shop by ``--stock``, ``--on-order`` and ``--down``.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from agents.fleet.benchmark.baselines import read_baselines
from agents.fleet.benchmark.score import Adapted, load_factory
from agents.fleet.benchmark.suite import read_suite
from agents.fleet.operate.estimates import VehicleEstimates, from_log, state_of
from agents.fleet.operate.futures import simulate
from agents.fleet.operate.plan import as_of, plan_summary, plan_table, plot_plan
from agents.fleet.policies.planning import PlanningModel
from agents.fleet.policies.rollout import RolloutPolicy
from agents.fleet.policies.view import FleetLayout
from agents.fleet.study.build import rule_of
from brake_env.cli.common import command_line
from brake_env.csv_safe import write_csv
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.fleet_file import read_fleet
from brake_env.output import atomic_path, table, write_json
from brake_env.prognostics.commands.predict_units import model_checksum


def parse_on_order(items: list[str], lead_time: int) -> list[int]:
    """``PADS@SHIFTS`` items as the arrivals of the next ``lead_time`` shifts."""
    transit = [0] * lead_time
    for item in items:
        pads, sep, when = item.partition("@")
        q = int(pads) if pads.isdigit() else -1
        s = int(when) if when.isdigit() else -1
        if not sep or q < 0 or not 1 <= s <= lead_time:
            raise ValueError(f"--on-order {item!r}: expected PADS@SHIFTS with PADS >= 0 and"
                             f" SHIFTS in [1, lead_time = {lead_time}]")  # fmt: skip
        transit[s - 1] += q
    return transit


def parse_down(items: list[str], vehicles: tuple[str, ...]) -> list[int]:
    """``RUN_ID:SHIFTS`` items as the shifts each vehicle is still down."""
    down = [0] * len(vehicles)
    for item in items:
        run, sep, shifts = item.rpartition(":")
        if not sep or run not in vehicles or not shifts.isdigit():
            raise ValueError(f"--down {item!r}: expected RUN_ID:SHIFTS with a run_id of the"
                             f" log ({', '.join(vehicles[:4])}, ...) and SHIFTS >= 0")  # fmt: skip
        down[vehicles.index(run)] = int(shifts)
    return down


def suite_rule(suite_name: str, predictor: str, config: FleetConfig) -> tuple[Any, str]:
    """(the suite's tuned rule for ``predictor``'s RUL on ``config``, its label)."""
    suite = read_suite(suite_name)
    shipped = (read_baselines(suite) or {}).get("baselines", {})
    name = f"{predictor}-rule"
    if name not in shipped:
        rules = [k for k, b in shipped.items() if b.get("kind") == "rule"]
        raise ValueError(f"--policy: suite {suite.name!r} ships no rule tuned on"
                         f" {predictor!r}'s RUL (it ships {', '.join(rules) or 'none'}); give"
                         " --suite or --policy MODULE:FACTORY")  # fmt: skip
    entry = shipped[name]
    rule = rule_of(config, entry["policy"], entry["params"], FleetLayout.of(config))
    return rule, f"baseline:{name} of suite {suite.name}"


def rule_factory(suite_name: str, predictor: str, config: FleetConfig) -> tuple[Any, str]:
    """(factory(env) of the suite's tuned rule for ``predictor``'s RUL, its label)."""
    rule, label = suite_rule(suite_name, predictor, config)
    return (lambda env: Adapted(rule, env)), label


def policy_factory(
    args: argparse.Namespace, predictor: str, config: FleetConfig, atlas: Any
) -> tuple[Any, str]:
    """(factory(env), label) of ``--policy``: the suite's rule, the rollout planner on it
    (the study's horizon and futures), or a scored ``MODULE:FACTORY``."""
    if args.policy == "rule":
        return rule_factory(args.suite, predictor, config)
    if args.policy == "rollout":
        rule, label = suite_rule(args.suite, predictor, config)
        planner = RolloutPolicy(rule, PlanningModel.build(config, atlas), seed=args.seed)
        return (lambda env: Adapted(planner, env)), f"rollout on {label}"
    user = load_factory(args.policy)
    return (lambda env: Adapted(user(env), env)), args.policy


def make_plan(args: argparse.Namespace) -> dict[str, Any]:
    """The plan's table, summary and printed text."""
    fleet = read_fleet(args.fleet)
    est, atlas = from_log(args.model, args.log, args.atlas, args.cache_dir)
    c = fleet.config
    to_window = int(args.shifts_to_window)
    if to_window >= c.window_period:
        raise ValueError(f"--shifts-to-window {to_window}: the fleet's window comes every"
                         f" {c.window_period} shifts (0 to {c.window_period - 1})")  # fmt: skip
    horizon = args.shifts or to_window + 1
    shift = (c.window_period - 1 - to_window) % c.window_period
    config = replace(c, episode_shifts=max(c.episode_shifts, shift + horizon + 1))
    shop = {
        "stock": c.initial_stock if args.stock is None else args.stock,
        "transit": parse_on_order(args.on_order, c.lead_time),
        "down": parse_down(args.down, est.vehicles),
    }
    state = state_of(est, config, shift, shop)
    factory, label = policy_factory(args, est.predictor, config, atlas)
    fut = simulate(config, atlas, est, state, policy=factory, horizon=horizon,
                   futures=args.futures, seed=args.seed)  # fmt: skip
    plan = plan_table(est, config, atlas, fut, shift)
    context = {
        "model": str(args.model), "model_sha256": model_checksum(args.model),
        "predictor": est.predictor, "log": str(args.log), "fleet": fleet.name,
        "fleet_digest": fleet.digest, "currency": fleet.currency, "policy": label,
        "shifts_to_window": to_window, "horizon_shifts": horizon, "seed": args.seed,
        "stock": shop["stock"], "on_order": shop["transit"],
    }  # fmt: skip
    summary = plan_summary(est, config, fut, context)
    return {"table": plan, "summary": summary, "text": plan_text(plan, summary, est)}


def plan_text(plan: Any, s: dict[str, Any], est: VehicleEstimates) -> str:
    """The one-screen plan."""
    rows = [["vehicle", "coming shift", "new pads by window", "RUL hot [shifts]",
             "RUL mild [shifts]", "P(fail before window)"]]  # fmt: skip
    for r in plan.sort_values("p_fail_before_window", ascending=False).to_dict("records"):
        rows.append([
            r["vehicle"], r["duty"], "yes" if r["replace_at_next_window"] else "",
            f"{r['rul_hot_shifts']:.1f} [{r['rul_hot_shifts_lo']:.1f},"
            f" {r['rul_hot_shifts_hi']:.1f}]",
            f"{r['rul_mild_shifts']:.1f}", f"{r['p_fail_before_window']:.3f}",
        ])  # fmt: skip
    cur, lo_hi = s["currency"], s["cost_interval"]
    return "\n".join([
        f"Plan as of {as_of(s)}, {s['predictor']} model, policy"
        f" {s['policy']}; next window in {s['shifts_to_window']} shifts:",
        table(rows),
        f"order now: {s['order_now']} pads; service now: {', '.join(s['service_now']) or 'none'}",
        coming_text(s["coming_shift"]),
        f"cost over the next {s['horizon_shifts']} shifts: {s['expected_cost']:,.0f} {cur}"
        f" expected, 90% of futures in [{lo_hi[0]:,.0f}, {lo_hi[1]:,.0f}] ({s['futures']}"
        f" futures, {s['seconds']:.1f} s)",
    ])  # fmt: skip


def coming_text(c: dict[str, int]) -> str:
    """The coming shift against the fleet's needs, as the env served it."""
    short = c["shortfall"] + c["mild_shortfall"]
    return (f"coming shift: {c['on_hot']} on the ramp, {c['on_mild']} in the drifts;"
            f" {short} short of the needs, {c['refused']} duties refused,"
            f" {c['deferred']} services deferred (bays, crew, stock)")  # fmt: skip


def write_plan(out: Path, result: dict[str, Any]) -> None:
    """``plan.csv``, ``plan.json``, ``plan.png`` under ``out`` (each written atomically)."""
    out.mkdir(parents=True, exist_ok=True)
    write_csv(result["table"], out / "plan.csv")
    summary = {**result["summary"], "vehicles": _records(result["table"])}
    write_json(summary, out / "plan.json")
    with atomic_path(out / "plan.png") as tmp:
        plot_plan(result["table"], result["summary"], tmp)


def _records(t: Any) -> list[dict[str, Any]]:
    rows = t.to_dict("records")
    for r in rows:
        for k, v in r.items():
            if isinstance(v, float) and not math.isfinite(v):
                r[k] = None
            elif isinstance(v, np.generic):
                r[k] = v.item()
    return rows


def cmd_plan(args: argparse.Namespace) -> dict[str, Any]:
    """``brakewear plan``."""
    result = make_plan(args)
    result["summary"]["command"] = command_line(args)
    write_plan(Path(args.out), result)
    if not args.quiet:
        print(result["text"])
    print(f"wrote {args.out}/plan.csv, plan.json, plan.png")
    return result
