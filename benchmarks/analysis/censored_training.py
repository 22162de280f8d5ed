"""The twin trained on pads removed before failure against pads run to failure.

For each dataset seed, ``make_dataset(cached_atlas(), DatasetSpec(), seed)`` gives the
paper's 10 training, 10 ID and 10 OOD pads. The twin is fitted on its training pads

- run to failure (the paper's setting);
- censored with volume: each pad removed at a random 50-90% of its life, its remaining
  volume measured at removal with 2% noise (``brake_env.data.censor.censor_log``);
- censored without volume: the same cuts, nothing measured (the twin refuses: the lengths
  only bound the lives from below);
- censored without volume, 3 of the 10 pads run to failure;
- naive: the censored-with-volume pads read as if they had failed at removal (no ``failed``
  column), what a fit that takes run lengths for lives does;

and scored on the same ID and OOD pads (mean over runs of the per-run RUL RMSE, as
``brakewear evaluate``). Prints one table per seed and the ratio of each row to
run-to-failure [target: censored with volume <= 1.2x].

Run: ``.venv/bin/python benchmarks/analysis/censored_training.py [--seeds 0 1] [--json out.json]``.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np
import pandas as pd

from brake_env.data.censor import TRUTH_DROPPED, censor_log
from brake_env.data.datasets import DatasetSpec, make_dataset
from brake_env.data.schema import FAILED, MEASURED_VOLUME
from brake_env.model.atlas import cached_atlas
from brake_env.output import table, write_json
from brake_env.prognostics.evaluation import evaluate
from twin import DigitalTwin

N_FAILED_IN_MIX = 3


def training_logs(train: pd.DataFrame, rng: np.random.Generator) -> dict[str, pd.DataFrame]:
    """The training fleets of the comparison, all cut at the same points."""
    state = rng.bit_generator.state
    with_volume = censor_log(train, rng, volume_noise=0.02)
    rng.bit_generator.state = state  # the same cuts without the measurements
    blind = censor_log(train, rng, volume_noise=None)
    first = list(pd.unique(train["run_id"]))[:N_FAILED_IN_MIX]
    full = train[train["run_id"].isin(first)].drop(columns=list(TRUTH_DROPPED))
    mix = pd.concat(
        [full.assign(**{MEASURED_VOLUME: np.nan}), blind[~blind["run_id"].isin(first)]],
        ignore_index=True,
    )
    return {
        "run to failure": train,
        "censored, volume at removal": with_volume,
        "censored, no volume": blind,
        f"censored, no volume, {N_FAILED_IN_MIX} run to failure": mix,
        "naive: removal taken as failure": with_volume.drop(columns=[FAILED, MEASURED_VOLUME]),
    }


def one_seed(seed: int, censor_seed: int) -> list[dict[str, Any]]:
    atlas = cached_atlas()
    ds = make_dataset(atlas, DatasetSpec(), seed)
    true_log_k = np.log(ds.logs["train"].groupby("run_id", observed=True)["wear_coeff"].first())
    logs = training_logs(ds.logs["train"], np.random.default_rng(censor_seed))
    rows, twins = [], {}
    for name, log in logs.items():
        kept = len(log) / len(ds.logs["train"])
        row: dict[str, Any] = {"seed": seed, "training": name, "events_kept": kept}
        try:
            twin = DigitalTwin(atlas).fit(log)
        except ValueError as e:
            row["refused"] = str(e)
            rows.append(row)
            continue
        cal = twin.calibration
        assert cal is not None
        row["prior_k_median"] = cal.k_median
        row["prior_log_k_error"] = cal.k_log_mean - float(true_log_k.mean())
        twins[name] = twin
        rows.append(row)
    t0 = time.perf_counter()
    ev = evaluate(twins, {s: ds.logs[s] for s in ("id", "ood")}, fit=False)
    print(f"seed {seed}: scored {len(twins)} twins in {time.perf_counter() - t0:.0f} s")
    for row in rows:
        if row["training"] in twins:
            for split in ("id", "ood"):
                row[f"{split}_rmse"] = ev.mean(row["training"], split, "rul_rmse")
    return rows


def print_table(rows: list[dict[str, Any]]) -> None:
    base = {r["seed"]: r for r in rows if r["training"] == "run to failure"}
    head = ["seed", "training pads", "events kept", "prior K", "ID RMSE", "x", "OOD RMSE", "x"]
    out = [head]
    for r in rows:
        b = base[r["seed"]]
        if "refused" in r:
            cells = ["refused (too few lives or volumes)", "", "", "", ""]
        else:
            cells = [f"{r['prior_k_median']:.3e}"]
            for split in ("id", "ood"):
                v = r[f"{split}_rmse"]
                cells += [f"{v:,.0f}", f"{v / b[f'{split}_rmse']:.2f}"]
        out.append([str(r["seed"]), r["training"], f"{r['events_kept']:.0%}", *cells])
    print(table(out))
    print(table(out, markdown=True))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0])
    ap.add_argument("--censor-seed", type=int, default=0, help="seed of the cut points")
    ap.add_argument("--json", default=None, help="also write the rows to this JSON file")
    args = ap.parse_args()
    rows = [r for s in args.seeds for r in one_seed(s, args.censor_seed)]
    print_table(rows)
    refused = next((r["refused"] for r in rows if "refused" in r), None)
    if refused:
        print(f"\nrefusal: {refused}")
    base = {r["seed"]: r for r in rows if r["training"] == "run to failure"}
    ratio = {
        split: max(
            r[f"{split}_rmse"] / base[r["seed"]][f"{split}_rmse"]
            for r in rows
            if r["training"] == "censored, volume at removal"
        )
        for split in ("id", "ood")
    }
    print(
        f"\ncensored with volume / run to failure, worst seed: ID {ratio['id']:.2f},"
        f" OOD {ratio['ood']:.2f} [target <= 1.2]"
    )
    if args.json:
        write_json({"rows": rows, "max_ratio": ratio}, args.json)


if __name__ == "__main__":
    main()
