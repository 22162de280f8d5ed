"""Two fleet policies paired over the same evaluation episodes, from one or two studies'
``costs.json`` (for example a rollout planner of one run against the tuned heuristic of
another): the difference and ratio of their headline and net costs, with paired bootstrap
intervals. The episodes must be the same seeds (same ``--size``, ``--shifts`` and env
code): the script refuses otherwise.

Run: ``.venv/bin/python benchmarks/analysis/fleet_paired_difference.py A/costs.json
"oracle/rollout on best combination" B/costs.json "oracle/best combination"``
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from agents.fleet.evaluation.costs import paired_interval
from brake_env.output import table


def episodes(path: str, name: str) -> tuple[dict[str, Any], dict[str, Any]]:
    """The row ``predictor/policy`` of a study's ``costs.json``, and the study's config."""
    s = json.loads(Path(path).read_text())
    predictor, _, policy = name.partition("/")
    for r in s["rows"]:
        if (r["predictor"], r["policy"]) == (predictor, policy):
            return r["episodes"], s["config"]
    have = [f"{r['predictor']}/{r['policy']}" for r in s["rows"]]
    raise SystemExit(f"fleet_paired_difference: no row {name!r} in {path}; rows are {have}")


def compare(a: tuple[str, str], b: tuple[str, str]) -> list[list[str]]:
    (ea, ca), (eb, cb) = episodes(*a), episodes(*b)
    for key in ("size", "shifts"):
        if ca[key] != cb[key]:
            raise SystemExit(f"fleet_paired_difference: {key} differs: {ca[key]} and {cb[key]}")
    if ea["seed"] != eb["seed"]:
        seeds = f"seeds {ea['seed']} and {eb['seed']}"
        raise SystemExit(f"fleet_paired_difference: the episodes differ: {seeds}")
    out = [["figure", f"{a[1]}", f"{b[1]}", "difference, 95%", "ratio, 95%"]]
    for figure in ("cost", "net"):
        x, y = np.asarray(ea[figure]), np.asarray(eb[figure])
        d, r = paired_interval(x, y, "difference"), paired_interval(x, y, "ratio")
        out.append([figure, f"{x.mean():.3f}", f"{y.mean():.3f}", str(d), str(r)])
    return out


def main() -> None:
    if len(sys.argv) != 5:
        raise SystemExit(" ".join(__doc__.strip().split("Run: ")[-1].split()))
    a, b = (sys.argv[1], sys.argv[2]), (sys.argv[3], sys.argv[4])
    print(f"{a[1]} ({a[0]}) against {b[1]} ({b[0]}), paired over the same episodes")
    print(table(compare(a, b)))


if __name__ == "__main__":
    main()
