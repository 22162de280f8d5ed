"""Synthetic event logs whose true RUL is known in closed form."""

from __future__ import annotations

import numpy as np
import pandas as pd


def synthetic_log(
    lives: list[int], seed: int = 0, prefix: str = "run", with_truth: bool = True
) -> pd.DataFrame:
    """Runs of the given lives, each to failure. Channels are noise except ``temp_c``, which
    reads the run's life (a perfect condition sensor), so RUL = temp_c - 1 - event exactly."""
    rng = np.random.default_rng(seed)
    parts = []
    for i, life in enumerate(lives):
        k = np.arange(life)
        parts.append(
            pd.DataFrame(
                {
                    "run_id": f"{prefix}-{i:02d}",
                    "event": k,
                    "speed_kmh": rng.uniform(4, 15, life),
                    "mass_kg": rng.uniform(42e3, 54e3, life),
                    "slope_rad": rng.uniform(0, 0.17, life),
                    "energy_j": rng.uniform(3e4, 5e5, life),
                    "temp_c": np.full(life, float(life)),
                    "stop_dist_m": rng.uniform(1, 9, life),
                    "failed": k == life - 1,
                    **({"rul_events": life - 1 - k} if with_truth else {}),
                }
            )
        )
    return pd.concat(parts, ignore_index=True)


def wear_log(
    lives: list[int], seed: int = 0, prefix: str = "run", with_truth: bool = True
) -> pd.DataFrame:
    """Runs to failure whose temperature rises with the fraction of life used, on top of
    the operating conditions and 5 K of noise: a condition signal a window model can read."""
    log = synthetic_log(lives, seed, prefix, with_truth)
    rng = np.random.default_rng(seed + 1000)
    life = log.groupby("run_id", sort=False)["event"].transform("max").to_numpy() + 1.0
    frac = (log["event"].to_numpy() + 1.0) / life
    log["temp_c"] = (
        420.0
        + 90.0 * frac
        + 12.0 * (log["speed_kmh"] - 9.5)
        + 40.0 * (log["slope_rad"] - 0.085) / 0.085
        + rng.normal(0.0, 5.0, len(log))
    )
    return log


def cut_runs(log: pd.DataFrame, frac: float, drop_truth: bool = True) -> pd.DataFrame:
    """Each run cut at ``frac`` of its life (removed before failure, ``failed`` false)."""
    life = log.groupby("run_id", sort=False)["event"].transform("max") + 1
    out = log[log["event"] < np.floor(frac * life)].copy()
    out["failed"] = False
    return out.drop(columns=["rul_events"], errors="ignore") if drop_truth else out
