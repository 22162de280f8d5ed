"""Numbers that describe an atlas and a simulated dataset, for summary.json and the README."""

from __future__ import annotations

from typing import Any

import numpy as np

from brake_env.data.datasets import Dataset
from brake_env.model.atlas import Atlas


def atlas_summary(atlas: Atlas) -> dict[str, Any]:
    """Calibration figures of an atlas: failure volume, wear acceleration, temperatures."""
    wear = atlas.expected("wear_per_k_m3")
    temp = atlas.expected("temp_mean_c")
    return {
        "hash": atlas.content_hash,
        "layers": atlas.n_layers,
        "grid": {
            "speed": int(atlas.speed_mps.size),
            "mass": int(atlas.mass_kg.size),
            "slope": int(atlas.slope_rad.size),
        },
        "critical_volume_frac": atlas.critical_volume,
        "failure_volume_frac": atlas.failure_volume,
        "failure_mode": atlas.failure_mode,
        "last_layer_volume_frac": float(atlas.volumes[-1]),
        # Mean over uniform operating conditions, last layer before failure vs fresh pad.
        "wear_per_event_ratio_end_fresh": float(wear[-1] / wear[0]),
        "mean_temp_c_fresh": float(temp[0]),
        "mean_temp_c_end": float(temp[-1]),
        "mean_temp_strictly_rising_everywhere": bool(
            np.all(np.diff(atlas.fields["temp_mean_c"], axis=0) > 0)
        ),
        "stop_dist_m_range": [
            float(atlas.fields["stop_dist_m"].min()),
            float(atlas.fields["stop_dist_m"].max()),
        ],
    }


def dataset_summary(ds: Dataset, atlas: Atlas, seed: int) -> dict[str, Any]:
    """Per-run and overall figures of a dataset; timings kept apart under ``timing_s``."""
    runs: list[dict[str, Any]] = []
    ratios = []
    for run in ds.runs:
        split, run_id, t = run.split, run.run_id, run.trajectory
        last = t.layer == t.layer[-1]
        ratio = float(t.wear_frac[last].mean() / t.wear_frac[t.layer == 0].mean())
        ratios.append(ratio)
        runs.append(
            {
                "run_id": run_id,
                "split": split,
                "wear_coeff": t.wear_coeff,
                "events_to_failure": t.n_events,
                "failure_volume_frac": t.final_volume_frac,
                "wear_per_event_ratio_end_fresh": ratio,
            }
        )
    life: dict[str, dict[str, float]] = {}
    for split in sorted({r["split"] for r in runs}):
        n = np.array([r["events_to_failure"] for r in runs if r["split"] == split], dtype=float)
        life[split] = {
            "runs": int(n.size),
            "mean": float(n.mean()),
            "std": float(n.std(ddof=0)),
            "min": float(n.min()),
            "max": float(n.max()),
        }
    k = np.array([r["wear_coeff"] for r in runs])
    n = np.array([r["events_to_failure"] for r in runs], dtype=float)
    return {
        "seed": seed,
        "interpolate_layers": ds.interpolate_layers,
        "route_block_events": ds.route_block_events,
        "atlas": atlas_summary(atlas),
        "events_total": int(n.sum()),
        "life_events": life,
        # K * life is constant if life scales as 1/K; its spread shows the coupling's effect.
        "k_times_life": {
            "mean": float((k * n).mean()),
            "cv": float((k * n).std() / (k * n).mean()),
        },
        "wear_per_event_ratio_end_fresh_runs": {
            "mean": float(np.mean(ratios)),
            "min": float(np.min(ratios)),
        },
        "failure_volume_frac": {"mean": float(np.mean([r["failure_volume_frac"] for r in runs]))},
        "runs": runs,
        "timing_s": {"atlas_build": atlas.build_seconds, "simulate": ds.simulate_seconds},
    }
