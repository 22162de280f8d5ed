"""Accuracy of each predictor's RUL on the hot and the mild route on fleet episodes (issue 31,
item 3), by age: RMSE in % of the route's life and 90%-interval coverage, against the
simulated-ahead true RUL (brake_env/env/fleet/route_accuracy.py).

Targets (issue 31): the twin's hot-route RMSE within 10% of life at every age past 20% of
life; its 90% interval covering 85-95%.

Run: ``.venv/bin/python benchmarks/analysis/route_rul_accuracy.py [--episodes 2] [--shifts 730]
[--predictors physics,data,window,twin] [--csv out.csv]``. The predictors are fitted on 10
simulated training pads (seed 0), as ``brakewear evaluate`` fits them on the paper's 10.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from brake_env.env.atlases import default_atlas
from brake_env.env.fleet.route_accuracy import AccuracyConfig, accuracy_table, route_samples
from brake_env.output import table
from brake_env.prognostics.registry import fit_predictors


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=2)
    ap.add_argument("--shifts", type=int, default=730)
    ap.add_argument("--sample-every", type=int, default=10)
    ap.add_argument("--predictors", default="physics,data,window,twin")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--csv", type=Path)
    args = ap.parse_args()
    atlas = default_atlas()
    t0 = time.perf_counter()
    fitted, _ = fit_predictors(tuple(args.predictors.split(",")), atlas, args.seed, 10)
    cfg = AccuracyConfig(args.episodes, args.shifts, args.sample_every)
    samples = route_samples(atlas, fitted, cfg, seed=args.seed)
    acc = accuracy_table(samples)
    acc["order"] = acc.predictor.map({p: i for i, p in enumerate([*fitted, "oracle"])})
    ages = {a: i for i, a in enumerate(["0-20%", "20-40%", "40-60%", "60-80%", "80-100%", "all"])}
    acc["age_order"] = acc.age.astype(str).map(ages)
    acc = acc.sort_values(["order", "route", "age_order"], kind="stable")
    if args.csv:
        samples.to_csv(args.csv, index=False)
    rows = [["predictor", "route", "age (hot life used)", "n", "RMSE % life", "bias % life",
             "90% coverage"]]  # fmt: skip
    for r in acc.itertuples():
        cov = "-" if np.isnan(r.coverage) else f"{100 * r.coverage:.1f}%"
        rows.append([r.predictor, r.route, str(r.age), str(r.n), f"{r.rmse_pct_life:.2f}",
                     f"{r.bias_pct_life:+.2f}", cov])  # fmt: skip
    print(table(rows))
    twin = acc[(acc.predictor == "twin") & (acc.route == "hot")]
    if len(twin):
        late = twin[~twin.age.isin(["0-20%", "all"])]
        all_ = twin[twin.age == "all"].iloc[0]
        print(
            f"target: twin hot RMSE <= 10% of life past 20% of life: worst bin"
            f" {late.rmse_pct_life.max():.2f}%; 90% coverage in [85%, 95%]:"
            f" {100 * all_.coverage:.1f}% (past 20%: "
            f"{100 * np.average(late.coverage, weights=late.n):.1f}%)"
        )
    print(f"{args.episodes} episode(s) of {args.shifts} shifts, default fleet (12 vehicles),"
          f" every {args.sample_every} shifts; {time.perf_counter() - t0:.0f} s")  # fmt: skip


if __name__ == "__main__":
    main()
