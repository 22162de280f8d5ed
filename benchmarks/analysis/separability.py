"""What tells two tied candidates apart, checked on simulated logs (issue 40, item 5).

For each true effect and seed it simulates a small history (the tests' coarse atlas, short
runs) and keeps only slow, flat braking (below ``--max-speed`` km/h and ``--max-slope``
deg), where a heat partition to the disc and a constant thermocouple offset both lower the
logged temperature by about the same amount. ``diagnose`` abstains between them; its
``attribution.separation`` recommends data (:mod:`sim2real.diagnosis.separate`). Then:

- **the range:** the same simulated runs, with the recommended number of events of the
  recommended operating-range cell added back (evenly spaced over the cell's events);
- **a control:** as many events added from the cell it ranks last;
- **the runs:** the recommended number of runs simulated, slow and flat as before;

each diagnosed again. It prints one row per case and the share of cases named right.

    .venv/bin/python benchmarks/analysis/separability.py --seeds 5
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from brake_env.data.datasets import DatasetSpec
from brake_env.model.atlas import Atlas, AtlasSpec, cached_atlas
from brake_env.model.regime import WearRegime
from sim2real.diagnosis.config import DiagnosisConfig
from sim2real.diagnosis.diagnose import diagnose
from sim2real.effects.interface import Effect
from sim2real.effects.library import HeatPartition, ThermocoupleBias
from sim2real.effects.truth import TruthSpec, simulate_truth

SMALL = AtlasSpec(n_speed=6, n_mass=3, n_slope=5)  # the tests' coarse atlas
CONFIG = DiagnosisConfig(
    fit_events_per_run=800,
    calibration_events_per_run=800,
    score_events_per_run=4000,
    grid_points=4,
    refine_evals=0,
    resamples=200,
)
CANDIDATES = [HeatPartition, ThermocoupleBias]
TRUTHS: dict[str, Effect] = {
    "heat_partition": HeatPartition(phi=0.1),
    "tc_bias": ThermocoupleBias(bias_k=-1.5),
}


def simulate(effect: Effect, runs: int, seed: int) -> pd.DataFrame:
    """``runs`` short runs to failure (K 20x the paper's: ~6000 events each)."""
    k = 4e-5
    ds = DatasetSpec(n_train=runs, n_id=0, n_ood_slow=0, n_ood_fast=0, wear=WearRegime(k, k / 10))
    return simulate_truth(SMALL, [effect], TruthSpec(ds), seed=seed)["train"]


def restrict(log: pd.DataFrame, max_speed: float, max_slope: float) -> pd.DataFrame:
    """Slow, flat braking only."""
    return log[(log["speed_kmh"] < max_speed) & (log["slope_rad"] < np.radians(max_slope))]


def in_cell(log: pd.DataFrame, cell: dict[str, Any]) -> pd.DataFrame:
    """The events of an operating-range cell (logged slope)."""
    s, m, th = log["speed_kmh"], log["mass_kg"] / 1000, np.degrees(log["slope_rad"])
    ok = s.between(*cell["speed_kmh"]) & m.between(*cell["mass_t"])
    return log[ok & th.between(*cell["slope_deg"])]


def with_events(base: pd.DataFrame, full: pd.DataFrame, cell: dict[str, Any]) -> pd.DataFrame:
    """``base`` plus the cell's recommended number of events, evenly spaced over its events."""
    pool = in_cell(full, cell).drop(index=base.index, errors="ignore")
    n = min(math.ceil(cell["events_to_log"]), len(pool))
    pick = pool.iloc[np.linspace(0, len(pool) - 1, n).astype(int)] if n else pool.iloc[:0]
    return pd.concat([base, pick]).sort_index()


def verdict(log: pd.DataFrame, atlas: Atlas, seed: int) -> dict[str, Any]:
    a = diagnose(log, atlas, CANDIDATES, CONFIG, seed=seed).summary["attribution"]
    z = a["candidates"][0].get("held_z_vs_runner_up")
    return {"verdict": a["verdict"], "z": z, "separation": a["separation"], "events": len(log)}


def case(truth: str, seed: int, args: argparse.Namespace, atlas: Atlas) -> dict[str, Any]:
    eff = TRUTHS[truth]
    full = simulate(eff, args.runs, seed)
    base = restrict(full, args.max_speed, args.max_slope)
    first = verdict(base, atlas, seed)
    out: dict[str, Any] = {"truth": truth, "seed": seed, "restricted": first}
    sep = first["separation"]
    if sep is None:
        return out
    best, worst = sep["ranges"][0], sep["ranges"][-1]
    out["range"] = {"cell": best["range"], **verdict(with_events(base, full, best), atlas, seed)}
    n_best = math.ceil(best["events_to_log"])
    ctrl = {**worst, "events_to_log": n_best}
    out["control"] = {"cell": worst["range"], **verdict(with_events(base, full, ctrl), atlas, seed)}
    n_runs = sep["runs"]["runs_needed"]
    if math.isfinite(n_runs) and n_runs <= args.max_runs:
        more = restrict(simulate(eff, int(n_runs), seed), args.max_speed, args.max_slope)
        out["runs"] = {"runs": int(n_runs), **verdict(more, atlas, seed)}
    return out


def _fmt(r: dict[str, Any] | None) -> str:
    if r is None:
        return "-"
    z = "-" if r["z"] is None else f"{r['z']:.1f}"
    return f"{r['verdict'][:14]} (z {z}, {r['events']} ev)"


def report(rows: list[dict[str, Any]]) -> None:
    print(
        "truth | seed | restricted log | recommended cell [events] | with them | control cell"
        " | runs [needed] | with them"
    )
    named = {"range": 0, "control": 0, "runs": 0}
    ties = 0
    for r in rows:
        sep = r["restricted"]["separation"]
        if sep is None:
            print(f"{r['truth']} | {r['seed']} | {_fmt(r['restricted'])} | no tie")
            continue
        ties += 1
        best = sep["ranges"][0]
        for k in named:
            named[k] += int(k in r and r[k]["verdict"] == r["truth"])
        print(
            f"{r['truth']} | {r['seed']} | {_fmt(r['restricted'])} | {best['range']}"
            f" [{math.ceil(best['events_to_log'])}] | {_fmt(r.get('range'))}"
            f" | {_fmt(r.get('control'))} | {sep['runs']['runs_needed']:.0f}"
            f" | {_fmt(r.get('runs'))}"
        )
    print(f"\ntied (abstained between the two) on the restricted logs: {ties} of {len(rows)}")
    for k, n in named.items():
        print(f"named the true effect, {k}: {n} of {ties}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=5, help="seeds per true effect")
    ap.add_argument("--seed-from", type=int, default=21)
    ap.add_argument("--runs", type=int, default=4, help="runs of the restricted log")
    ap.add_argument("--max-speed", type=float, default=9.0, help="km/h")
    ap.add_argument("--max-slope", type=float, default=3.0, help="deg")
    ap.add_argument("--max-runs", type=int, default=12, help="largest run count simulated")
    ap.add_argument("--truths", default=",".join(TRUTHS))
    ap.add_argument("--json", type=Path, default=None, help="write the cases here")
    args = ap.parse_args()
    atlas = cached_atlas(SMALL)
    t0 = time.process_time()
    rows = [
        case(t, s, args, atlas)
        for t in args.truths.split(",")
        for s in range(args.seed_from, args.seed_from + args.seeds)
    ]
    report(rows)
    print(f"CPU time {time.process_time() - t0:.0f} s")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1, default=float))


if __name__ == "__main__":
    main()
