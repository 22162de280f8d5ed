"""The fed-back twin's RUL error over several cuts of the same pads in service.

The issue-40 target compares the fed-back twin's RMSE on one cut of the 12 ``id`` pads
(each cut at a uniform 15-90% of its life) with the nominal twin's median over 20 nominal
logs. On 12 pads the RMSE swings with where the pads are cut (a young pad's RUL error is
large), so this fits the twin once per effect given and scores it on ``--cuts`` cuts (cut
seed 0 is the one ``docs/results/sim2real.md`` measured), printing each cut's RMSE and 90%
interval coverage and their median and mean.

    brakewear simulate --seed 4243 --effect heat_partition:phi=0.25 --n-train 12 --n-id 12 \\
        --n-ood-slow 0 --n-ood-fast 0 --out out/issue40-log
    .venv/bin/python benchmarks/analysis/fed_back_cuts.py --log out/issue40-log --cuts 8 \\
        --effects heat_partition:phi=0.245812 heat_partition:phi=0.25
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np
from twin_misfit import cut_log, score  # a sibling script (its folder is on sys.path)

from brake_env.data.schema import read_event_log
from brake_env.model.atlas import AtlasSpec, cached_atlas
from brake_env.model.params import BrakeModel
from twin.twin import DigitalTwin


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--log", type=Path, required=True, help="a simulate output folder")
    ap.add_argument("--cuts", type=int, default=8, help="cut seeds 0..N-1")
    ap.add_argument("--effects", nargs="+", required=True, help="NAME:P=V fed back")
    args = ap.parse_args()
    train = read_event_log(args.log / "train.parquet")
    ids = read_event_log(args.log / "id.parquet")
    cuts = [cut_log(ids, np.random.default_rng(s)) for s in range(args.cuts)]
    spec = AtlasSpec(model=BrakeModel.preset("hot-duty"))
    for effect in args.effects:
        t0 = time.process_time()
        twin = DigitalTwin(cached_atlas(dataclasses.replace(spec, effects=(effect,))))
        twin.fit(train)
        res = [score(twin, c) for c in cuts]
        rmse = np.array([r["rmse"] for r in res])
        cov = np.array([r["coverage"] for r in res])
        print(f"{effect}: RMSE per cut {', '.join(f'{x:,.0f}' for x in rmse)}")
        print(f"  coverage per cut {', '.join(f'{x:.2f}' for x in cov)}")
        print(
            f"  median RMSE {np.median(rmse):,.0f}, mean coverage {cov.mean():.3f}"
            f" ({time.process_time() - t0:.0f} s CPU)"
        )


if __name__ == "__main__":
    main()
