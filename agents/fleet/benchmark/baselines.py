"""Shipped baselines: per suite, each baseline's settings and per-test-episode costs, read by
``fleet-score`` (never rerun there), written by ``brakewear fleet-baselines`` from a fleet
study of the suite's test split.

A baseline is named ``PREDICTOR-rule`` (the best rule tuned on the dev side with that
predictor's RUL: its heuristic chosen by the tuning episodes, its parameters), ``priced``
(the price-directed policy, on the truth), ``PREDICTOR-rollout`` (the rollout planner on that
rule) or ``reference`` (the perfect-information reference, 2 vehicles only); ``bound`` is the
Lagrangian bound on each test episode. The rules can be rebuilt from their settings and
re-scored exactly (:func:`rebuild`); the others are read.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from agents.fleet.benchmark.suite import Suite
from agents.fleet.settings import FleetStudyConfig
from agents.fleet.study.build import rebuild_rule, rul_env
from agents.fleet.study.planners import PRICED
from agents.fleet.study.summary import REFERENCE
from agents.fleet.study.units import study_fit
from brake_env.model.atlas import Atlas
from brake_env.prognostics.registry import ORACLE

BASELINES_DIR = Path(__file__).with_name("baselines")
ENV_ID = "BrakeWearFleet-v1"


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
        out["baselines"][name] = b
    if "bound" in summary:
        bound = summary["bound"]
        out["bound"] = {"net": bound["cost"], "episodes": bound["episodes"],
                        "iterations": bound["iterations"]}  # fmt: skip
    return out


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
    return dict(d)


def rebuild(
    suite: Suite, entry: dict[str, Any], atlas: Atlas, config: FleetStudyConfig
) -> tuple[Any, Any]:
    """(the env, the policy) of a shipped rule baseline, as its study ran it: the suite's
    fit of its predictor (none for the oracle) and the rule from its parameters.

    Raises:
        ValueError: Not a rule (only rules are rebuilt; the others are read).
    """
    if entry.get("kind") != "rule":
        raise ValueError(f"baseline of kind {entry.get('kind')!r}: only rules are re-scored;"
                         " its shipped episodes are read")  # fmt: skip
    p, h = entry["predictor"], entry["policy"]
    fitted = None if p == ORACLE else study_fit(config, p, atlas, atlas)
    return rul_env(config, atlas, p, fitted), rebuild_rule(config, h, entry["params"])
