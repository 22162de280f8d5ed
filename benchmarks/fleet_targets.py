"""The fleet study's targets (issue 21; docs/results/fleet.md, "The fleet study"), read from a
``costs.json`` that ``brakewear fleet-study`` wrote: each target with its measured figure and
interval, met or missed. The study reports results; the targets are ours, so they live here.

1. MaskablePPO with the twin's RUL beats the best tuned heuristic with the twin's RUL by at
   least 10% of its cost (IQM over at least 10 training seeds), the 95% interval of the
   difference excluding 0, each seed trained in under 15 min.
2. Every policy's gap to the perfect-information reference (small fleet), with intervals.
3. The twin's best policy beats every other predictor's best, each interval of the
   difference excluding 0.

The Ray target (2 workers >= 1.7x one process) is measured by ``benchmarks/bench_ray.py
--only fleet``.

Run: ``.venv/bin/python benchmarks/fleet_targets.py out/fleet-study/costs.json``
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

from brake_env.output import table

SAVING = 0.10  # of the heuristic's cost
MIN_SEEDS = 10
MAX_TRAIN_S = 15 * 60


def _iv(d: dict[str, float], digits: int = 3) -> str:
    return f"{d['point']:.{digits}f} [{d['low']:.{digits}f}, {d['high']:.{digits}f}]"


def _verdict(ok: bool) -> str:
    return "met" if ok else "MISSED"


def rows(s: dict[str, Any]) -> list[list[str]]:
    out = [["target", "measured", ""]]
    for p, a in s["agents"].items():
        if a.get("kind", "central") != "central":  # the target is the centralised agent's
            out.append([f"shared PPO ({a['predictor']}'s RUL) against the tuned {a['heuristic']}",
                        f"IQM ratio {_iv(a['ratio_to_heuristic'])}, difference"
                        f" {_iv(a['minus_heuristic'], 2)}; {a['seeds']} seeds",
                        "reported"])  # fmt: skip
            continue
        r, d = a["ratio_to_heuristic"], a["minus_heuristic"]
        ok = (r["point"] <= 1 - SAVING and d["high"] < 0 and a["seeds"] >= MIN_SEEDS
              and max(a["train_seconds"]) < MAX_TRAIN_S)  # fmt: skip
        out.append([
            f"MaskablePPO ({p}'s RUL) <= {1 - SAVING:.2f}x the tuned {a['heuristic']},"
            f" difference < 0, >= {MIN_SEEDS} seeds, each < {MAX_TRAIN_S // 60} min",
            f"IQM ratio {_iv(r)}, difference {_iv(d, 2)}; {a['seeds']} seeds,"
            f" longest {max(a['train_seconds']) / 60:.1f} min",
            _verdict(ok),
        ])  # fmt: skip
    for row in s["rows"]:
        if "ratio_to_reference" in row:
            out.append([f"gap to the reference: {row['predictor']} / {row['policy']}",
                        f"ratio {_iv(row['ratio_to_reference'])}, difference"
                        f" {_iv(row['gap_to_reference'], 2)}", "reported"])  # fmt: skip
    for a in s["agents"].values():
        if "ratio_to_reference" in a:
            name = "MaskablePPO" if a.get("kind", "central") == "central" else "shared PPO"
            out.append([f"gap to the reference: {a['predictor']} / {name} (IQM)",
                        f"ratio {_iv(a['ratio_to_reference'])}", "reported"])  # fmt: skip
    rk = s["ranking"]
    if rk["head"] == "twin" and rk["head_minus"]:
        for p, v in rk["head_minus"].items():
            d = v["difference"]
            out.append([f"twin's best policy cheaper than {p}'s best",
                        f"difference {_iv(d, 2)}, ratio {_iv(v['ratio'])}",
                        _verdict(d["high"] < 0)])  # fmt: skip
    return out


def main() -> None:
    if len(sys.argv) != 2:
        raise SystemExit(__doc__.strip().splitlines()[-1])
    s = json.loads(Path(sys.argv[1]).read_text())
    c = s["config"]
    print(f"{sys.argv[1]}: {c['size']} fleet, {c['shifts']} shifts, {c['eval_episodes']}"
          f" evaluation episodes; best heuristic per predictor {s['best_heuristic']}")  # fmt: skip
    print(table(rows(s)))


if __name__ == "__main__":
    main()
