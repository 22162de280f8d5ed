"""Benchmark of the RUL baselines and the evaluation harness on the paper's 30-run dataset.

Prints:
- MLP fit time on the 10 training runs (~1.1e6 events) with its default config
  [well under a minute on 2 cores], and its prediction throughput;
- physics-baseline prediction throughput;
- the harness's cost: ``evaluate`` with the oracle (prediction + every metric + traces)
  against ``predict_log`` with the oracle (prediction only) in the same run, as a ratio.

Run: ``.venv/bin/python benchmarks/bench_baselines.py [--json out.json]``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import pandas as pd

from baselines.mlp import MLPPredictor
from baselines.physics import PhysicsPredictor
from brake_env.data.datasets import make_dataset
from brake_env.model.atlas import cached_atlas
from brake_env.output import write_json
from brake_env.prognostics.evaluation import evaluate
from brake_env.prognostics.protocol import Oracle, predict_log


def _seconds(fn) -> float:  # type: ignore[no-untyped-def]
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def main() -> dict[str, float]:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--json", default=None, help="also write the figures to this file")
    args = p.parse_args()
    atlas = cached_atlas()
    logs = make_dataset(atlas, seed=0).logs
    test = pd.concat([logs["id"], logs["ood"]], ignore_index=True)
    n_train, n_test = len(logs["train"]), len(test)

    mlp = MLPPredictor()
    fit_s = _seconds(lambda: mlp.fit(logs["train"]))
    mlp_pred_s = _seconds(lambda: predict_log(mlp, test))
    phys = PhysicsPredictor(atlas).fit(logs["train"])
    phys_pred_s = _seconds(lambda: predict_log(phys, test))
    oracle_s = min(_seconds(lambda: predict_log(Oracle(), test)) for _ in range(3))
    harness_s = min(
        _seconds(lambda: evaluate({"oracle": Oracle()}, logs, fit=False)) for _ in range(3)
    )
    res = {
        "train_events": n_train,
        "test_events": n_test,
        "mlp_fit_s": fit_s,
        "mlp_predict_events_per_s": n_test / mlp_pred_s,
        "physics_predict_events_per_s": n_test / phys_pred_s,
        "oracle_predict_log_s": oracle_s,
        "oracle_evaluate_s": harness_s,
        "harness_over_predict_log": harness_s / oracle_s,
    }
    print(f"training events {n_train}, test events (ID + OOD) {n_test}")
    print(f"MLP fit (default config, {mlp.config.epochs} epochs): {fit_s:.1f} s")
    print(f"MLP predict: {res['mlp_predict_events_per_s']:.3g} events/s")
    print(f"physics predict: {res['physics_predict_events_per_s']:.3g} events/s")
    print(
        f"oracle: predict_log {oracle_s:.2f} s, evaluate (all metrics) {harness_s:.2f} s"
        f" -> {res['harness_over_predict_log']:.2f}x"
    )
    if args.json:
        write_json(res, Path(args.json))
    return res


if __name__ == "__main__":
    main()
