"""The default fleet's bracket (issue 30), read from a fleet study's ``costs.json``: what
the gap between the best policy measured and the Lagrangian bound is made of, and whether
the bound's price search has converged.

1. The best policy of the study (lowest mean net cost among its rows) against the bound,
   per vehicle-shift on the same episodes: the gap, split into the spares' order and
   holding costs, which the bound idealises away (spares always in stock, free: a
   relaxation that any policy pays for), and the rest. Paired bootstrap intervals.
2. With ``--iterations N``: the study's bound search rerun for N price steps (the same
   model, starts and search as the study's bound unit,
   :func:`agents.fleet.study.planners.study_bound`), the best bound after k steps: whether
   a longer search would raise the bound. With ``--orders`` too, the search is that of the
   bound tightened by the orders' share (each service pays at least ``order / max_order``
   beyond the initial stock; ``BoundModel.build(orders=True)``), and the bracket of part 1
   is printed again against it.

Run: ``.venv/bin/python benchmarks/analysis/fleet_bound_gap.py out/default-net-twin/costs.json
[--iterations 250] [--orders]``
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from agents.fleet.evaluation.costs import paired_interval
from agents.fleet.settings import FleetStudyConfig
from brake_env.output import table


def best_row(study: dict[str, Any]) -> dict[str, Any]:
    """The study's row with the lowest mean net cost (a bound is not a policy)."""
    rows = [r for r in study["rows"] if "episodes" in r and "model_terms" in r["episodes"]]
    if not rows:
        raise SystemExit("fleet_bound_gap: the study has no rows with episodes' model terms")
    return min(rows, key=lambda r: float(np.mean(r["episodes"]["net"])))


def split(study: dict[str, Any]) -> list[list[str]]:
    """The best policy's gap to the bound, whole and by part, with paired intervals."""
    if "bound" not in study:
        raise SystemExit("fleet_bound_gap: the study ran no bound (--bound-iterations)")
    row = best_row(study)
    ep = row["episodes"]
    net, cost, model = (np.asarray(ep[k], dtype=float) for k in ("net", "cost", "model_terms"))
    low = np.asarray(study["bound"]["episodes"], dtype=float)
    if low.shape != net.shape:
        raise SystemExit(f"fleet_bound_gap: {len(low)} bound episodes, {len(net)} of the policy")
    spares = cost - model  # order + holding: terms the bound does not have
    zero = np.zeros_like(net)

    def cell(a: np.ndarray, b: np.ndarray) -> str:
        i = paired_interval(a, b)
        return f"{i.point:.3f} [{i.low:.3f}, {i.high:.3f}]"

    name = f"{row['predictor']}/{row['policy']}"
    return [
        ["figure (net, per vehicle-shift)", "value, 95%"],
        [f"best policy: {name}", f"{net.mean():.3f}"],
        ["Lagrangian bound", f"{low.mean():.3f}"],
        ["gap: policy minus bound", cell(net, low)],
        ["  of it, the policy's spares' order and holding", cell(spares, zero)],
        ["  the rest", cell(net - spares, low)],
        ["ratio policy / bound", f"{paired_interval(net, low, 'ratio').point:.3f}"],
    ]  # fmt: skip


def convergence(
    study: dict[str, Any], iterations: int, orders: bool = False
) -> tuple[list[list[str]], list[float]]:
    """The best bound after k price steps of a search ``iterations`` long (mean start), and
    each episode's bound at the best prices."""
    from agents.fleet.study.planners import study_bound
    from brake_env.env.atlases import default_atlas

    config = FleetStudyConfig.from_dict(study["config"])
    t0 = time.perf_counter()
    result, bounds = study_bound(config, default_atlas(), iterations, orders)
    seconds = time.perf_counter() - t0
    per = config.fleet.n_vehicles * config.fleet.episode_shifts
    best = np.maximum.accumulate(np.asarray(result.history)) / per
    steps = sorted({k for k in (0, 20, 40, 60, 100, 150, 200, 300, 500) if k < len(best)}
                   | {len(best) - 1})  # fmt: skip
    rows = [["price steps", "best bound so far (mean start)"]]
    rows += [[str(k), f"{best[k]:.4f}"] for k in steps]
    rows.append(["episodes' mean at the best prices", f"{np.mean(bounds):.4f}"])
    rows.append(["seconds", f"{seconds:.0f}"])
    return rows, bounds


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("costs", help="a fleet study's costs.json (with a bound)")
    ap.add_argument("--iterations", type=int, default=0,
                    help="rerun the bound's price search this long (0: do not)")  # fmt: skip
    ap.add_argument(
        "--orders",
        action="store_true",
        help="rerun the bound tightened by the orders' share (with --iterations)",
    )
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args()
    study = json.loads(Path(args.costs).read_text(encoding="utf-8"))
    print(table(split(study), args.markdown))
    if args.iterations > 0:
        rows, bounds = convergence(study, args.iterations, args.orders)
        print()
        print(table(rows, args.markdown))
        if args.orders:
            print("\nagainst the bound tightened by the orders' share:")
            print(table(split({**study, "bound": {"episodes": bounds}}), args.markdown))


if __name__ == "__main__":
    main()
