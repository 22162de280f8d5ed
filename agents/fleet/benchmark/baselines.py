"""Shipped baselines: per suite, each baseline's settings and per-test-episode costs, read by
``fleet-score`` (never rerun there), written by ``brakewear fleet-baselines`` from a fleet
study of the suite's test split.

A baseline is named ``PREDICTOR-rule`` (the best rule tuned on the dev side with that
predictor's RUL: its heuristic chosen by the tuning episodes, its parameters), ``priced``
(the price-directed policy, on the truth), ``PREDICTOR-rollout`` (the rollout planner on that
rule) or ``reference`` (the perfect-information reference, 2 vehicles only); ``bound`` is the
Lagrangian bound on each test episode. The rules, rollouts, the priced policy and the
reference can be rebuilt from their settings and re-scored exactly (:func:`rebuild`), and so
can a distilled policy whose agents are shipped beside the file
(:mod:`agents.fleet.benchmark.distilled`).

Some baselines can be remade alone (``fleet-baselines --only bound,priced``) and merged into
the shipped file (:func:`merge`): each remade one records its own ``command`` (the file's
top-level ``command`` stays for the rest). ``bound`` and ``priced`` are made together (the
price-directed policy acts on the bound's prices) by the study's bound unit alone
(:func:`bound_baselines`), without tuning any rule.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Any

from agents.fleet.benchmark.distilled import DISTILLED, rebuild_distilled
from agents.fleet.benchmark.suite import Suite
from agents.fleet.policies.view import FleetLayout
from agents.fleet.settings import FleetStudyConfig
from agents.fleet.study.build import episodes_of, rebuild_rule, rul_env
from agents.fleet.study.planners import (
    PRICED,
    bound_unit,
    planner_fields,
    priced_policy,
    study_planner,
)
from agents.fleet.study.summary import REFERENCE
from agents.fleet.study.units import reference_policy, rule_spares, study_fit
from brake_env.model.atlas import Atlas
from brake_env.prognostics.registry import ORACLE

BASELINES_DIR = Path(__file__).with_name("baselines")
ENV_ID = "BrakeWearFleet-v2"
ID_REGIME_ENV_IDS = ("BrakeWearFleet-v1", ENV_ID)
"""Env ids whose figures stand on an ``id``-regime fleet: v1 and v2 give the same episodes
there (only other regimes' net credit changed in v2)."""


def baseline_name(row: dict[str, Any], best: dict[str, str]) -> tuple[str, str] | None:
    """(name, kind) of a study row that is a baseline, or None (a rule that is not its
    predictor's best)."""
    p, policy = row["predictor"], row["policy"]
    if policy == REFERENCE:
        return "reference", "reference"
    if policy == PRICED:
        return "priced", "priced"
    if "params" in row:
        return (f"{p}-rule", "rule") if best.get(p) == policy else None
    return f"{p}-rollout", "rollout"


def from_summary(suite: Suite, summary: dict[str, Any], command: str) -> dict[str, Any]:
    """The baselines of a suite's test-split study (``costs.json``'s summary)."""
    out: dict[str, Any] = {
        "suite": suite.name, "suite_digest": suite.digest, "env_id": ENV_ID,
        "objective": suite.objective, "command": command, "config": summary["config"],
        "seeds": summary["rows"][0]["episodes"]["seed"], "baselines": {},
        "seconds": summary.get("seconds"),
    }  # fmt: skip
    for row in summary["rows"]:
        named = baseline_name(row, summary["best_heuristic"])
        if named is None:
            continue
        name, kind = named
        ep = row["episodes"]
        b = {"kind": kind, "predictor": row["predictor"], "policy": row["policy"],
             "net": row["net_cost"], "cost": row["cost"],
             "episodes": {"seed": ep["seed"], "net": ep["net"], "cost": ep["cost"]}}  # fmt: skip
        if "params" in row:
            b["params"] = row["params"]
        out["baselines"][name] = {**b, **rebuilt_from(summary, kind, row["predictor"])}
    if "bound" in summary:
        bound = summary["bound"]
        out["bound"] = {"net": bound["cost"], "episodes": bound["episodes"],
                        "iterations": bound["iterations"]}  # fmt: skip
    return out


def rebuilt_from(summary: dict[str, Any], kind: str, predictor: str) -> dict[str, Any]:
    """What :func:`rebuild` needs of a baseline besides its kind: a rollout's base rule and
    planner, the price-directed policy's price steps (its prices are the bound's search)."""
    cfg = summary["config"]
    if kind == "rollout":
        return {"base": _best_rule(summary, predictor),
                "planner": {"horizon": cfg["rollout_horizon"], "samples": cfg["rollout_samples"],
                            "seed": cfg["seed"] if cfg.get("rollout_seed") is None
                            else cfg["rollout_seed"]}}  # fmt: skip
    if kind == "priced":  # the search's steps (its history also holds the zero prices)
        return {"steps": int(cfg["bound_iterations"])}
    if kind == "reference":  # its spares are the oracle's best rule's (s, S)
        return {"tail": int(cfg["tail"]), "spares_of": _best_rule(summary, ORACLE)}
    return {}


def _best_rule(summary: dict[str, Any], predictor: str) -> dict[str, Any] | None:
    """A predictor's best rule in a study's summary (its name and parameters), or None."""
    best = summary["best_heuristic"].get(predictor)
    rule = next((r for r in summary["rows"]
                 if r["predictor"] == predictor and r["policy"] == best), None)  # fmt: skip
    return None if rule is None else {"policy": best, "params": rule["params"]}


def shipped_path(suite: Suite) -> Path:
    return BASELINES_DIR / f"{suite.name}.json"


def read_baselines(suite: Suite, path: str | Path | None = None) -> dict[str, Any] | None:
    """A suite's baselines (the shipped file, or ``path``); None when none are shipped.

    Raises:
        ValueError: The file is of another suite or protocol (its digest), or unreadable.
    """
    p = Path(path) if path is not None else shipped_path(suite)
    if not p.is_file():
        if path is not None:
            raise ValueError(f"--baselines {p}: no such file")
        return None
    try:
        d = json.loads(p.read_text(encoding="utf-8"))
        digest = d["suite_digest"]
        d["baselines"].items()
    except (ValueError, KeyError, TypeError, AttributeError) as e:
        raise ValueError(f"baselines {p}: not a baselines file ({e!r})") from None
    if digest != suite.digest:
        raise ValueError(f"baselines {p}: made for suite digest {digest}, and suite"
                         f" {suite.name!r} is {suite.digest} (its protocol or fleet changed;"
                         " rerun brakewear fleet-baselines)")  # fmt: skip
    env_id = d.get("env_id")
    ok = ID_REGIME_ENV_IDS if suite.fleet_file.config.regime == "id" else (ENV_ID,)
    if env_id not in ok:
        raise ValueError(f"baselines {p}: measured on {env_id}, and suite {suite.name!r} is"
                         f" scored on {ENV_ID} (its net differs there; rerun brakewear"
                         " fleet-baselines)")  # fmt: skip
    return dict(d)


def rebuild(
    suite: Suite, entry: dict[str, Any], atlas: Atlas, config: FleetStudyConfig,
    directory: Path = BASELINES_DIR,
) -> tuple[Any, Any]:  # fmt: skip
    """(the env, the policy) of a shipped baseline, as its study ran it on ``config``'s
    episodes: a rule (the suite's fit of its predictor, none for the oracle, and the rule
    from its parameters), a rollout (its base rule and planner settings) or the
    price-directed policy (on the truth, at the prices of the bound's search from the whole
    test split's starts: :func:`~agents.fleet.study.planners.priced_policy`) or a distilled
    policy (every training seed's agent, from its nets file in ``directory``: the baselines
    file's).

    Raises:
        ValueError: A kind that is not rebuilt, or a baseline made before its settings (or
            agents) were recorded.
    """
    kind, p = entry.get("kind"), str(entry.get("predictor"))
    if kind == "distilled":
        return rebuild_distilled(config, entry, atlas, directory)
    if kind == "reference":
        return _reference(config, entry, atlas)
    if kind == "priced":
        if "steps" not in entry:
            raise ValueError("baseline priced: made before its price steps were recorded;"
                             " its shipped episodes are read")  # fmt: skip
        full = suite.study_config("test", bound_iterations=int(entry["steps"]))
        return priced_policy(full, atlas)
    if kind not in ("rule", "rollout"):
        raise ValueError(f"baseline of kind {kind!r}: only rules, rollouts, the priced"
                         " policy, the reference and distilled policies are re-scored; its"
                         " shipped episodes are read")  # fmt: skip
    fitted = None if p == ORACLE else study_fit(config, p, atlas, atlas)
    if kind == "rule":
        return rul_env(config, atlas, p, fitted), rebuild_rule(config, entry["policy"],
                                                               entry["params"])  # fmt: skip
    if "base" not in entry:
        raise ValueError(f"baseline {p}-rollout: made before its base rule and planner were"
                         " recorded; its shipped episodes are read")  # fmt: skip
    fields = planner_fields(p)
    base, planner = entry["base"], entry["planner"]
    rule = rebuild_rule(config, base["policy"], base["params"],
                        FleetLayout.of(config.fleet, fields=fields))  # fmt: skip
    run = replace(config, rollout_horizon=int(planner["horizon"]),
                  rollout_samples=int(planner["samples"]),
                  rollout_seed=int(planner["seed"]))  # fmt: skip
    return rul_env(config, atlas, p, fitted, fields), study_planner(run, atlas, rule)


def _reference(config: FleetStudyConfig, entry: dict[str, Any], atlas: Atlas) -> tuple[Any, Any]:
    """The perfect-information reference as its study ran it: the exact program with its
    ``tail``, spares by the (s, S) of the rule in ``spares_of`` (the rules' default if
    none), on the truth (:func:`~agents.fleet.study.units.reference_unit`)."""
    if "tail" not in entry:
        raise ValueError("baseline reference: made before its tail and spares were recorded;"
                         " its shipped episodes are read")  # fmt: skip
    sp = entry["spares_of"] or {}
    s, S = rule_spares(config, sp.get("policy"), sp.get("params"))
    return reference_policy(replace(config, tail=int(entry["tail"])), atlas, s, S)


BOUND = "bound"


def split_only(only: str) -> tuple[set[str], tuple[str, ...]]:
    """``--only``'s names, and the predictors whose rules (or rollouts) it names (a
    distilled policy is read from a finished ``fleet-distil``: ``--distil-from``).

    Raises:
        ValueError: A name that is not a baseline's (named).
    """
    names = {n.strip() for n in only.split(",") if n.strip()}
    bad = sorted(n for n in names if n not in (BOUND, "priced", "reference")
                 and not n.endswith(("-rule", "-rollout", DISTILLED)))  # fmt: skip
    if bad or not names:
        raise ValueError(f"--only {only!r}: {bad or 'nothing'} not baseline names (bound,"
                         " priced, reference, PREDICTOR-rule, PREDICTOR-rollout,"
                         " PREDICTOR-distilled)")  # fmt: skip
    preds = tuple(sorted({n.rsplit("-", 1)[0] for n in names if n.endswith(("-rule", "-rollout"))}))
    return names, preds


def bound_baselines(suite: Suite, config: FleetStudyConfig, atlas: Atlas) -> dict[str, Any]:
    """``bound`` and ``priced`` of a suite's test split alone (the study's bound unit), in
    the baselines file's format (:func:`from_summary`'s)."""
    u = bound_unit(config, atlas)
    eps = episodes_of(u["priced"])
    net, cost = [e.net for e in eps], [e.per_vehicle_shift for e in eps]
    priced = {"kind": "priced", "predictor": ORACLE, "policy": PRICED,
              "net": sum(net) / len(net), "cost": sum(cost) / len(cost),
              "episodes": {"seed": [e.seed for e in eps], "net": net, "cost": cost},
              "steps": config.bound_iterations}  # fmt: skip
    bound = [float(b) for b in u["bound"]]
    return {"suite": suite.name, "suite_digest": suite.digest, "baselines": {"priced": priced},
            "bound": {"net": sum(bound) / len(bound), "episodes": bound,
                      "iterations": int(u["iterations"])},
            "seconds": sum(u["seconds"].values())}  # fmt: skip


def merge(
    shipped: dict[str, Any], made: dict[str, Any], names: set[str], command: str
) -> dict[str, Any]:
    """``shipped`` with the baselines ``names`` (and ``bound``) replaced by ``made``'s, each
    with its ``command`` and ``seconds``; the rest kept as they were.

    Raises:
        ValueError: The two are of other suite digests or test seeds, or ``made`` lacks a
            named baseline.
    """
    if made["suite_digest"] != shipped["suite_digest"]:
        raise ValueError(f"--only: the file to merge into is of suite digest"
                         f" {shipped['suite_digest']}, and suite {made['suite']!r} is"
                         f" {made['suite_digest']} (rerun the whole suite)")  # fmt: skip
    have = set(made["baselines"]) | ({BOUND} if "bound" in made else set())
    if sorted(names - have):
        raise ValueError(f"--only: {sorted(names - have)} were not made (the suite's fleet"
                         " may not have them, e.g. no bound outside the 'id' regime)")  # fmt: skip
    out = {**shipped, "baselines": dict(shipped["baselines"])}
    stamp = {"command": command, "seconds": made.get("seconds")}
    for n in sorted(names - {BOUND}):
        b = made["baselines"][n]
        if b["episodes"]["seed"] != shipped["seeds"]:
            raise ValueError(f"--only: {n} was made on other test episodes than the file's")
        out["baselines"][n] = {**b, **stamp}
    if BOUND in names:
        out["bound"] = {**made["bound"], **stamp}
    return out
