"""Room to decide on BrakeWearFleet-v0 (issue 20), read from a fleet study: every tuned
heuristic with one predictor's RUL against the perfect-information reference, on the
study's evaluation episodes (common random numbers).

The study runs the pipeline (tuning, the reference, the evaluation episodes); this script
only reads its ``costs.json`` and prints:

1. each heuristic's cost per vehicle-shift (pads priced when fitted), on the reference
   model's terms too (order and holding costs left out, so that the reorder rules do not
   enter the comparison), and paired bootstrap intervals (BCa, 95%) over episodes of its
   gap to the reference (difference and ratio of means);
2. the room: the predictor's best heuristic (the one best on the tuning episodes, never
   chosen on the evaluation ones) against the reference, and the smallest gap among all
   heuristics (chosen on evaluation: context, not a claim);
3. the cost by term of the reference and that best heuristic;
4. the reference's predicted cost (its model's terms) against its realised cost on the
   same terms, paired over the evaluation episodes.

Run (the small fleet, every heuristic with the oracle's RUL; ~5 min on 2 cores):

    .venv/bin/brakewear fleet-study --out out/room --predictors oracle --heuristics \\
        threshold time-to-window "(n, N)" "capacity greedy" "duty rule" "(s, S)" standby \\
        "best combination" --trials 10 --trials-best 30 --tune-episodes 2 \\
        --eval-episodes 10
    .venv/bin/python benchmarks/analysis/fleet_room.py out/room/costs.json [--predictor oracle] \\
        [--markdown]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from agents.fleet.evaluation.costs import paired_interval
from agents.fleet.study.summary import REFERENCE
from brake_env.output import table


def room_rows(summary: dict[str, Any], predictor: str) -> list[dict[str, Any]]:
    """The reference's row, then each of ``predictor``'s heuristics with its gaps."""
    ref = _reference(summary)
    r, rm = (np.array(ref["episodes"][k]) for k in ("cost", "model_terms"))
    out = [_line(REFERENCE, r, rm)]
    for row in summary["rows"]:
        if row["predictor"] == predictor and row["policy"] != REFERENCE:
            x, xm = (np.array(row["episodes"][k]) for k in ("cost", "model_terms"))
            line = _line(row["policy"], x, xm)
            line["gap to ref"] = str(paired_interval(x, r, "difference"))
            line["ratio to ref"] = str(paired_interval(x, r, "ratio"))
            line["gap, model terms"] = str(paired_interval(xm, rm, "difference"))
            line.update({k: round(row[k], 2) for k in ("window_fits", "visits", "failures")})
            out.append(line)
    return out


def _line(name: str, x: np.ndarray, xm: np.ndarray) -> dict[str, Any]:
    return {"policy": name, "cost/veh-shift": f"{x.mean():.4g}", "model terms": f"{xm.mean():.4g}"}


def _reference(summary: dict[str, Any]) -> dict[str, Any]:
    refs = [row for row in summary["rows"] if row["policy"] == REFERENCE]
    if not refs:
        raise SystemExit("fleet_room: the study has no reference (run it with --size small)")
    return refs[0]


def _episodes(summary: dict[str, Any], predictor: str, policy: str, key: str) -> np.ndarray:
    row = next(r for r in summary["rows"] if (r["predictor"], r["policy"]) == (predictor, policy))
    return np.array(row["episodes"][key])


def room(summary: dict[str, Any], predictor: str) -> list[str]:
    """The room verdict, the smallest gap and the reference's forecast check, as lines."""
    ref = _reference(summary)
    r, rm = (np.array(ref["episodes"][k]) for k in ("cost", "model_terms"))
    best = summary["best_heuristic"][predictor]
    x, xm = (_episodes(summary, predictor, best, k) for k in ("cost", "model_terms"))
    diff, ratio = paired_interval(x, r, "difference"), paired_interval(x, r, "ratio")
    verdict = "a measurable gap" if diff.low > 0 else "NO measurable gap"
    lines = [
        f"Room to decide: best tuned heuristic ({best}, {predictor}'s RUL) {x.mean():.4g} vs"
        f" reference {r.mean():.4g} per vehicle-shift; gap {diff} (95% paired BCa), ratio"
        f" {ratio}: {verdict}",
        f"  on the reference model's terms (no order nor holding cost): {xm.mean():.4g} vs"
        f" {rm.mean():.4g}; gap {paired_interval(xm, rm, 'difference')},"
        f" ratio {paired_interval(xm, rm, 'ratio')}",
    ]
    gaps = {
        row["policy"]: paired_interval(np.array(row["episodes"]["cost"]), r, "difference")
        for row in summary["rows"]
        if row["predictor"] == predictor and row["policy"] != REFERENCE
    }
    low = min(gaps, key=lambda n: gaps[n].point)
    above = sum(g.low > 0 for g in gaps.values())
    lines.append(f"  smallest gap on the evaluation episodes: {low} {gaps[low]}; {above} of"
                 f" {len(gaps)} heuristics' gap intervals exclude 0")  # fmt: skip
    if "predicted" in ref["episodes"]:
        predicted = np.array(ref["episodes"]["predicted"])
        check = paired_interval(rm, predicted, "difference")
        lines.append(
            f"reference: predicted {predicted.mean():.4g}, realised {rm.mean():.4g} per"
            f" vehicle-shift on the model's terms; realised - predicted {check}"
        )
    return lines


def terms_table(summary: dict[str, Any], predictor: str, markdown: bool) -> str:
    """Mean cost per vehicle-shift of each term (pads priced when fitted) of the reference
    and the predictor's best heuristic, and their difference: where the gap comes from."""
    best = summary["best_heuristic"][predictor]
    a, b = summary["terms"][REFERENCE], summary["terms"][f"{predictor} / {best}"]
    rows = [["term", "reference", best, f"{best} - reference"]]
    rows += [[t, f"{a[t]:.3f}", f"{b[t]:.3f}", f"{b[t] - a[t]:+.3f}"]
             for t in a if abs(a[t]) > 0 or abs(b[t]) > 0]  # fmt: skip
    return table(rows, markdown)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("costs", type=Path, help="a fleet study's costs.json")
    ap.add_argument("--predictor", default="oracle", help="whose RUL the heuristics act on")
    ap.add_argument("--markdown", action="store_true")
    a = ap.parse_args()
    summary = json.loads(a.costs.read_text())
    c = summary["config"]
    if a.predictor not in c["predictors"]:
        raise SystemExit(f"fleet_room: --predictor {a.predictor!r} is not in the study's"
                         f" predictors {c['predictors']}")  # fmt: skip
    print(
        f"{c['size']} fleet, {c['shifts']} shifts; {c['trials']} Optuna trials"
        f" ({c['trials_best']} for the combination) x {c['tune_episodes']} tuning episodes"
        f" per heuristic; {c['eval_episodes']} evaluation episodes; {a.predictor}'s RUL"
    )
    rows = room_rows(summary, a.predictor)
    cols = list(rows[-1])
    print(table([cols, *([str(r.get(k, "")) for k in cols] for r in rows)], a.markdown))
    print("\n".join(room(summary, a.predictor)))
    print("cost per vehicle-shift by term (pads priced when fitted):")
    print(terms_table(summary, a.predictor, a.markdown))


if __name__ == "__main__":
    main()
