"""Simulate a few pads to failure and look at what the wear-dynamics coupling does.

Run: ``python examples/simulate_dataset.py [OUT_DIR]``. Prints lives and the end-of-life wear
acceleration, and writes the event logs and the volume figure to OUT_DIR (default out/example).
"""

from __future__ import annotations

import sys
from pathlib import Path

from brake_env.data.datasets import DatasetSpec, make_dataset, write_dataset
from brake_env.data.plots import plot_volume_trajectories
from brake_env.model.atlas import cached_atlas
from brake_env.model.regime import WearRegime


def main(out_dir: str = "out/example", k_mean: float = 2e-6, runs: int = 2) -> dict[str, int]:
    atlas = cached_atlas()  # built once (~1 s), then loaded from ~/.cache/brakewear
    spec = DatasetSpec(
        n_train=runs, n_id=runs, n_ood_slow=1, n_ood_fast=1, wear=WearRegime(k_mean, k_mean / 10)
    )
    ds = make_dataset(atlas, spec, seed=0)
    lives = {r.run_id: r.trajectory.n_events for r in ds.runs}
    for run_id, t in ((r.run_id, r.trajectory) for r in ds.runs):
        fresh = t.wear_frac[t.layer == 0].mean()
        end = t.wear_frac[t.layer == t.layer[-1]].mean()
        print(
            f"{run_id:12s} K={t.wear_coeff:.2e}  life={t.n_events:7d} events"
            f"  wear/event end vs fresh: {end / fresh:.3f}"
        )
    write_dataset(ds, out_dir, formats=("parquet",))
    plot_volume_trajectories(ds.runs, Path(out_dir) / "volume.png")
    print(
        f"end of life below {atlas.failure_volume:.1%} volume ({atlas.failure_mode});"
        f" logs and volume.png in {out_dir}"
    )
    return lives


if __name__ == "__main__":
    main(*sys.argv[1:2])
