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
