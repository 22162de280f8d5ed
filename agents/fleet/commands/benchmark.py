"""``brakewear fleet-score`` (a policy scored on a suite's test split against the shipped
baselines and the bound) and ``brakewear fleet-baselines`` (a suite's baselines made by a
fleet study of its test split, tuned on its dev side)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from brake_env.cli.common import add_runner_args, command_line, int_at_least, int_range, out_dir
from brake_env.output import table, write_json

_BUDGET = ("predictors", "heuristics", "trials", "trials_best", "bound_iterations",
           "rollout_predictors")  # fmt: skip


def register(sub: argparse._SubParsersAction[Any]) -> None:
    """Add ``fleet-score`` and ``fleet-baselines`` to the ``brakewear`` parser."""
    fmt = argparse.ArgumentDefaultsHelpFormatter
    s = sub.add_parser(
        "fleet-score", formatter_class=fmt,
        help="score a policy on a suite's sealed test split against the shipped baselines and"
        " the bound (docs/benchmark.md)",
    )  # fmt: skip
    _suite_args(s, "out/fleet-score")
    who = s.add_mutually_exclusive_group(required=True)
    who.add_argument(
        "--policy", metavar="MODULE:FACTORY|baseline:NAME",
        help="FACTORY(env) returns an object with SB3's predict (masks given to a"
        " MaskablePPO) or a callable obs -> action; baseline:NAME re-scores a shipped rule",
    )  # fmt: skip
    who.add_argument(
        "--predictor", metavar="MODULE:FACTORY",
        help="a new RUL predictor, FACTORY(atlas, seed) -> unfitted predictor: fitted on the"
        " suite's pads, the shipped rules' family tuned on its RUL, scored on the test split",
    )  # fmt: skip
    s.add_argument("--trials", type=int_at_least(1), default=None,
                   help="--predictor's Optuna trials (default: the shipped rules')")  # fmt: skip
    s.add_argument(
        "--episodes-from", type=int_range(0, 2**31), default=None, metavar="N",
        help="move the test split to seeds N.. (fresh episodes; the shipped baselines then"
        " pair with nothing: re-score them as baseline:NAME)",
    )  # fmt: skip
    s.add_argument(
        "--episodes", type=int_at_least(2), default=None, help="the test split's first N only"
    )
    s.add_argument(
        "--baselines", default=None, metavar="FILE",
        help="a baselines.json of fleet-baselines instead of the suite's shipped one",
    )  # fmt: skip
    s.set_defaults(func="agents.fleet.commands.benchmark:cmd_fleet_score")
    b = sub.add_parser(
        "fleet-baselines", formatter_class=fmt,
        help="a suite's baselines: every predictor's best rule tuned on the dev side, the"
        " bound and the price-directed policy, run on the test split; baselines.json",
    )  # fmt: skip
    _suite_args(b, "out/fleet-baselines")
    b.add_argument("--predictors", default="oracle,twin,window,data,physics",
                   help="comma-separated")  # fmt: skip
    b.add_argument("--trials-best", type=int_at_least(1), default=45, help="the rule's Optuna")
    b.add_argument("--bound-iterations", type=int_at_least(0), default=200)
    b.add_argument("--rollout", default="", help="predictors given the rollout planner")
    b.add_argument(
        "--planner-seed", type=int_at_least(0), default=None, metavar="N",
        help="the rollout planner's seed (default: the suite's seed, which also seeds the fits)",
    )  # fmt: skip
    _only_args(b)
    add_runner_args(b, workers=2)
    b.set_defaults(func="agents.fleet.commands.benchmark:cmd_fleet_baselines")
    lb = sub.add_parser(
        "fleet-leaderboard", formatter_class=fmt,
        help="rewrite the leaderboard of docs/benchmark.md from the shipped baselines",
    )  # fmt: skip
    lb.add_argument("--page", default="docs/benchmark.md", help="the page (between its markers)")
    lb.set_defaults(func="agents.fleet.commands.benchmark:cmd_fleet_leaderboard")


def _only_args(b: argparse.ArgumentParser) -> None:
    """fleet-baselines' partial regeneration."""
    b.add_argument(
        "--only", default=None, metavar="NAMES",
        help="remake only these baselines (e.g. bound,priced or twin-rule) and merge them into"
        " --into, keeping the others; each records its command",
    )  # fmt: skip
    b.add_argument(
        "--into", default=None, metavar="FILE",
        help="--only's file to merge into (default: the suite's shipped baselines file)",
    )  # fmt: skip
    b.add_argument(
        "--distil-from", default=None, metavar="DIR",
        help="--only PREDICTOR-distilled: a finished fleet-distil's --out, run on a study of"
        " this suite's test split (e.g. fleet-baselines --only PREDICTOR-rollout's --out)",
    )  # fmt: skip


def _suite_args(p: argparse.ArgumentParser, out: str) -> None:
    """The suite and where to write; no seed, preset or atlas: the suite fixes them (its
    protocol's seed, its fleet's preset)."""
    from agents.fleet.benchmark.suite import shipped_suites

    p.add_argument(
        "--suite", default="default", metavar="NAME|FILE",
        help=f"a shipped suite ({', '.join(shipped_suites())}) or a suite file",
    )  # fmt: skip
    p.add_argument("--out", type=out_dir, default=out, help="output directory")
    p.add_argument(
        "--cache-dir", type=out_dir, default=None,
        help="atlas cache (default $BRAKEWEAR_CACHE_DIR or ~/.cache/brakewear)",
    )  # fmt: skip
    p.add_argument("--quiet", action="store_true", help="no progress bars")


def suite_atlas(suite: Any, args: argparse.Namespace) -> Any:
    """The atlas of the suite's fleet's preset, from the cache."""
    from brake_env.cli.common import load_atlas

    return load_atlas(args, preset=suite.fleet_file.config.preset)


def cmd_fleet_score(args: argparse.Namespace) -> dict[str, Any]:
    from tqdm import tqdm

    from agents.fleet.benchmark.baselines import BASELINES_DIR, read_baselines
    from agents.fleet.benchmark.predictor import score_predictor
    from agents.fleet.benchmark.score import score
    from agents.fleet.benchmark.suite import read_suite

    suite = read_suite(args.suite)
    n = args.episodes or suite.test_episodes
    shipped = read_baselines(suite, args.baselines)
    if args.predictor is not None:
        result = score_predictor(suite, args.predictor, suite_atlas(suite, args),
                                 shipped=shipped, episodes_from=args.episodes_from,
                                 episodes=args.episodes, trials=args.trials)  # fmt: skip
    else:
        with tqdm(total=n, desc=f"fleet-score {suite.name}", unit="episode",
                  disable=args.quiet) as bar:  # fmt: skip
            result = score(suite, args.policy, suite_atlas(suite, args), progress=bar,
                           episodes_from=args.episodes_from, episodes=args.episodes,
                           baselines=shipped, baselines_dir=Path(args.baselines).parent
                           if args.baselines else BASELINES_DIR)  # fmt: skip
    result["command"] = command_line(args)
    out = Path(args.out)
    write_json(result, out / "score.json")
    print(score_table(result))
    print(f"wrote {out / 'score.json'}")
    return result


def score_table(r: dict[str, Any]) -> str:
    """The one-screen table of a score."""
    cur = f" per vehicle-shift, suite {r['suite']}, {len(r['episodes']['seed'])} test episodes"
    rows = [["policy", "net", "policy minus it (95%)"], [r["policy"], f"{r['net']:.3f}", ""]]
    for name, b in sorted(r["baselines"].items(), key=lambda kv: kv[1]["net"]):
        m = b["minus"]
        rows.append(
            [name, f"{b['net']:.3f}", f"{m['mean']:+.3f} [{m['low']:+.3f}, {m['high']:+.3f}]"]
        )
    if r["bound"] is not None:
        rows.append(["bound", f"{r['bound']['net']:.3f}", ""])
    lines = [f"Net cost{cur} (observing {r['observe']}'s RUL):", table(rows)]
    if r["ratio_to_bound"] is not None:
        q = r["ratio_to_bound"]
        lines.append(f"ratio to the bound: {q['mean']:.3f} [{q['low']:.3f}, {q['high']:.3f}]")
    if r["not_paired"]:
        lines.append("not paired (other episodes): " + ", ".join(r["not_paired"]))
    return "\n".join(lines)


def cmd_fleet_baselines(args: argparse.Namespace) -> dict[str, Any]:
    from agents.fleet.benchmark.baselines import from_summary
    from agents.fleet.benchmark.suite import read_suite
    from agents.fleet.commands.cli import study_and_report
    from brake_env.cli.common import make_runner

    suite = read_suite(args.suite)
    if args.only is not None:
        return _only(suite, args)
    config = suite.study_config(
        "test", predictors=tuple(p for p in args.predictors.split(",") if p),
        heuristics=("best combination",), trials_best=args.trials_best,
        bound_iterations=args.bound_iterations,
        rollout_predictors=tuple(p for p in args.rollout.split(",") if p),
        rollout_seed=args.planner_seed,
    )  # fmt: skip
    out = Path(args.out)
    with make_runner(args) as runner:
        summary = study_and_report(config, suite_atlas(suite, args), out, runner,
                                   quiet=args.quiet)  # fmt: skip
    made = from_summary(suite, summary, command_line(args))
    write_json(made, out / "baselines.json")
    print(f"wrote {out / 'baselines.json'} ({len(made['baselines'])} baselines"
          f"{', the bound' if 'bound' in made else ''})")  # fmt: skip
    return made


def _only(suite: Any, args: argparse.Namespace) -> dict[str, Any]:
    """``--only``: the named baselines remade (the bound and the priced policy by the bound
    unit alone, rules by a study of their predictors) and merged into ``--into``."""
    from agents.fleet.benchmark.baselines import (
        DISTILLED,
        bound_baselines,
        from_summary,
        merge,
        read_baselines,
        shipped_path,
        split_only,
    )  # fmt: skip
    from agents.fleet.commands.cli import study_and_report
    from brake_env.cli.common import make_runner

    names, preds = split_only(args.only)
    into = Path(args.into) if args.into else shipped_path(suite)
    shipped = read_baselines(suite, into)  # refuses a file of another suite digest
    if shipped is None:
        raise ValueError(f"--only: no baselines file {into} to merge into (run the suite whole)")
    if distilled := {n for n in names if n.endswith(DISTILLED)}:
        return _only_distilled(suite, args, names, distilled, shipped, into)
    bound = args.bound_iterations if names & {"bound", "priced"} else 0
    rollout = tuple(p for p in preds if f"{p}-rollout" in names)
    config = suite.study_config("test", predictors=preds or ("oracle",),
                                heuristics=("best combination",), trials_best=args.trials_best,
                                bound_iterations=bound, rollout_predictors=rollout,
                                rollout_seed=args.planner_seed)  # fmt: skip
    command = command_line(args)
    out, atlas = Path(args.out), suite_atlas(suite, args)
    if preds or "reference" in names:
        with make_runner(args) as runner:
            summary = study_and_report(config, atlas, out, runner, quiet=args.quiet)
        made = from_summary(suite, summary, command)
    else:
        made = bound_baselines(suite, config, atlas) if bound else {
            "suite": suite.name, "suite_digest": suite.digest, "baselines": {}}  # fmt: skip
    merged = merge(shipped, made, names, command)
    write_json(made, out / "made.json")
    write_json(merged, into)
    print(f"merged {', '.join(sorted(names))} into {into} (made: {out / 'made.json'})")
    return merged


def _only_distilled(
    suite: Any, args: argparse.Namespace, names: set[str], distilled: set[str],
    shipped: dict[str, Any], into: Path,
) -> dict[str, Any]:  # fmt: skip
    """``--only PREDICTOR-distilled --distil-from DIR``: read, not rerun, and merged."""
    from agents.fleet.benchmark.baselines import merge
    from agents.fleet.benchmark.distilled import distilled_baseline, ship_nets

    if names != distilled or len(distilled) != 1 or not args.distil_from:
        raise ValueError(f"--only {args.only}: a distilled policy is merged alone, from the"
                         " fleet-distil run named by --distil-from DIR")  # fmt: skip
    run = Path(args.distil_from)
    path = run / "distil.json"
    try:
        distil = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as e:
        raise ValueError(f"--distil-from {args.distil_from}: cannot read {path} ({e})") from None
    made = distilled_baseline(suite, distil)
    if set(made["baselines"]) != distilled:
        raise ValueError(f"--distil-from {args.distil_from}: it distilled"
                         f" {list(made['baselines'])}, not {sorted(distilled)}")  # fmt: skip
    (name,) = distilled
    merged = merge(shipped, made, names, command_line(args))  # checks the episodes first
    ship_nets(merged["baselines"][name], run, distil, into, name)
    write_json(merged, into)
    print(f"merged {', '.join(sorted(names))} into {into}")
    return merged


def cmd_fleet_leaderboard(args: argparse.Namespace) -> None:
    from agents.fleet.benchmark.page import write_page

    print(f"wrote the leaderboard of {write_page(args.page)}")
