"""A fleet history as a real one holds it: some pads run to failure, the others removed
before failure with their remaining volume measured in the workshop, and no truth columns
(docs/cli.md, "backtest").

    .venv/bin/brakewear simulate --seed 7 --n-train 16 --n-id 0 --n-ood-slow 0 \\
        --n-ood-fast 0 --out /tmp/bt/sim
    .venv/bin/python scripts/censored_history.py --data /tmp/bt/sim --censored 10 \\
        --seed 7 --out /tmp/bt/history.parquet

Reads the train log of a ``brakewear simulate`` directory (or a log file), picks
``--censored`` of its runs at random (``--seed``), cuts them with
:func:`brake_env.data.censor.censor_log` (a cut at 50-90% of the life, the volume measured at
removal with 2% noise), keeps the others whole with ``failed`` on their last event, drops
``volume_frac``, ``wear_coeff`` and ``rul_events`` everywhere and writes Parquet.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from brake_env.data.censor import TRUTH_DROPPED, censor_log
from brake_env.data.schema import FAILED, MEASURED_VOLUME, read_event_log, write_event_log
from brake_env.prognostics.commands.fit_predict import training_log_path


def censored_history(log: pd.DataFrame, n_censored: int, seed: int) -> pd.DataFrame:
    """``log`` (run-to-failure, with truth) with ``n_censored`` runs, drawn with ``seed``,
    removed before failure and measured; every truth column dropped."""
    runs = list(pd.unique(log["run_id"]))
    if not 0 <= n_censored <= len(runs):
        raise ValueError(f"--censored must be in [0, {len(runs)}], got {n_censored}")
    picker, cutter = (np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(2))
    cut = set(picker.choice(np.asarray(runs, dtype=object), n_censored, replace=False))
    is_cut = log["run_id"].isin(cut).to_numpy()
    whole = log[~is_cut].drop(columns=list(TRUTH_DROPPED)).assign(**{MEASURED_VOLUME: np.nan})
    if FAILED not in whole:  # a run-to-failure log without the column: each run's last event
        whole[FAILED] = ~whole["run_id"].duplicated(keep="last").to_numpy()
    censored = censor_log(log[is_cut], cutter)
    out = pd.concat([whole, censored], ignore_index=True)
    order = pd.Categorical(out["run_id"], categories=runs)
    return out.iloc[np.lexsort((out["event"].to_numpy(), order.codes))].reset_index(drop=True)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True, help="a brakewear simulate directory or a log file")
    ap.add_argument("--censored", type=int, default=10, help="runs removed before failure")
    ap.add_argument("--seed", type=int, default=0, help="which runs, where cut, the noise")
    ap.add_argument("--out", required=True, help="the history, a .parquet (or .csv) file")
    args = ap.parse_args()
    log = read_event_log(training_log_path(args.data))
    hist = censored_history(log, args.censored, args.seed)
    write_event_log(hist, Path(args.out))
    n_runs = hist["run_id"].nunique()
    print(f"wrote {args.out}: {n_runs} pads ({args.censored} censored), {len(hist):,} events")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
