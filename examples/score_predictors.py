"""A reliability engineer's example: fit RUL predictors on event logs and score them.

Run: ``python examples/score_predictors.py [DATA_DIR]``. DATA_DIR holds ``train``, ``id``
and ``ood`` event logs (Parquet or CSV, the README's schema, with ground truth), as
``brakewear simulate`` writes them; without it a small fleet of fast-wearing pads is
simulated first. Prints the paper's Table 4 (RUL RMSE per run) and the other prognostic
metrics for the physics baseline, the digital twin and the no-information baseline.
"""

from __future__ import annotations

import sys

import pandas as pd

from brake_env.data.datasets import DatasetSpec, find_logs, make_dataset
from brake_env.data.schema import read_event_log
from brake_env.model.atlas import cached_atlas
from brake_env.model.regime import WearRegime
from brake_env.prognostics.evaluation import evaluate
from brake_env.prognostics.registry import make_predictor


def main(
    data_dir: str | None = None, predictors: tuple[str, ...] = ("none", "physics", "twin")
) -> dict[str, dict[str, float]]:
    """Mean RUL RMSE [events] per predictor and test split."""
    atlas = cached_atlas()
    if data_dir is None:  # 20x the paper's K: pads live ~6,000 events, the example runs fast
        spec = DatasetSpec(
            n_train=4, n_id=3, n_ood_slow=1, n_ood_fast=1, wear=WearRegime(4e-5, 4e-6)
        )
        logs: dict[str, pd.DataFrame] = make_dataset(atlas, spec, seed=0).logs
    else:
        logs = {split: read_event_log(p) for split, p in find_logs(data_dir).items()}
    ev = evaluate({n: make_predictor(n, atlas, seed=0) for n in predictors}, logs)
    print(ev.table())
    print()
    print(ev.summary_table())
    return {m: {s: ev.mean(m, s, "rul_rmse") for s in ev.splits} for m in ev.models}


if __name__ == "__main__":
    main(*sys.argv[1:2])
