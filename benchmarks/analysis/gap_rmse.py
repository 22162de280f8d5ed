"""The twin's RUL RMSE on the paper's ID and OOD runs with events dropped at random, against
the full logs (issue 22; docs/results/prognostics.md, "Gaps in a log").

    .venv/bin/python benchmarks/analysis/gap_rmse.py [--seed 0] [--drops 0.01,0.1,0.5] [--trials 1]

The paper's dataset (10 training, 10 in-distribution and 10 out-of-distribution runs, the
default atlas) is simulated with ``--seed``; the twin is fitted on the full training runs.
Each test run is then read whole, and with a share of its events dropped at random (the
first and last kept, so every run keeps its length; each drop its own random stream). The
RMSE of a run is over its logged events, against the true RUL at those events; the table
gives the mean over runs (paper Table 4), the worst run, and the change from the full log.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from brake_env.data.datasets import DatasetSpec, make_dataset
from brake_env.env.atlases import default_atlas
from brake_env.output import table
from brake_env.prognostics.fleet import predict_runs, take_events
from brake_env.prognostics.metrics import rmse
from brake_env.prognostics.protocol import EventBatch, iter_runs
from twin import DigitalTwin


def dropped(runs: list[EventBatch], share: float, rng: np.random.Generator) -> list[EventBatch]:
    """Each run with ``share`` of its events left out at random, first and last kept."""
    out = []
    for ev in runs:
        keep = rng.random(len(ev)) >= share
        keep[[0, -1]] = True
        out.append(take_events(ev, np.flatnonzero(keep)))
    return out


def run_rmse(twin: DigitalTwin, runs: list[EventBatch]) -> list[float]:
    est = predict_runs(twin, runs)
    return [rmse(e.rul_mean, ev.rul_events) for e, ev in zip(est, runs, strict=True)]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=0, help="dataset seed")
    ap.add_argument("--drops", default="0.01,0.1,0.5", help="shares of events dropped")
    ap.add_argument("--trials", type=int, default=1, help="random drops per share (averaged)")
    args = ap.parse_args()
    t0 = time.perf_counter()
    atlas = default_atlas()
    data = make_dataset(atlas, DatasetSpec(), seed=args.seed)
    twin = DigitalTwin(atlas).fit(data.logs["train"])
    rows = [["split", "events dropped", "mean RMSE", "worst run", "vs full log", "events read"]]
    for split in ("id", "ood"):
        runs = [ev for _, ev in iter_runs(data.logs[split])]
        full = run_rmse(twin, runs)
        base = float(np.mean(full))
        rows.append(
            [
                split,
                "0 (full)",
                f"{base:,.0f}",
                f"{max(full):,.0f}",
                "-",
                f"{sum(map(len, runs)):,}",
            ]
        )
        for k, share in enumerate(float(s) for s in args.drops.split(",")):
            res, n = [], 0
            for t in range(args.trials):
                rng = np.random.default_rng([args.seed, k, t])
                gapped = dropped(runs, share, rng)
                res.append(run_rmse(twin, gapped))
                n += sum(map(len, gapped))
            per_run = np.mean(res, axis=0)
            m = float(per_run.mean())
            rows.append(
                [
                    split,
                    f"{share:.0%}",
                    f"{m:,.0f}",
                    f"{per_run.max():,.0f}",
                    f"{m / base - 1:+.1%}",
                    f"{n // args.trials:,}",
                ]
            )
    print(table(rows))
    print(
        f"\ntwin fitted on the paper's 10 training runs (seed {args.seed}); RMSE in events,"
        f" per run over its logged events, mean over runs; {args.trials} random drop(s) per"
        f" share; {time.perf_counter() - t0:.0f} s"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
