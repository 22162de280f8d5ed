"""How noisy is each fleet figure from episode to episode? For every row of a fleet study's
``costs.json``: the mean, standard deviation, least and greatest over the evaluation
episodes of the headline cost and of the net cost (less the pad life left at the end), and
how many episodes a tuning run would need for a standard error of 0.05 on each. It is the
evidence for tuning on the net cost at the default fleet (``fleet-study --objective net``):
a tuning objective whose episodes swing more needs more of them to rank two rules.

Run: ``.venv/bin/python benchmarks/analysis/fleet_episode_noise.py out/fleet-study/costs.json``
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from brake_env.output import table

SE = 0.05  # per vehicle-shift: the standard error a tuning objective should reach


def rows(s: dict[str, Any]) -> list[list[str]]:
    out = [["predictor / policy", "figure", "mean", "sd", "min", "max", f"episodes for SE {SE}"]]
    for r in s["rows"]:
        for name, key in (("cost", "cost"), ("net", "net")):
            x = np.asarray(r["episodes"].get(key, []), dtype=float)
            if x.size < 2:
                continue
            sd = float(x.std(ddof=1))
            out.append([f"{r['predictor']} / {r['policy']}", name, f"{x.mean():.3f}",
                        f"{sd:.3f}", f"{x.min():.2f}", f"{x.max():.2f}",
                        f"{int(np.ceil((sd / SE) ** 2))}"])  # fmt: skip
    return out


def main() -> None:
    if len(sys.argv) != 2:
        raise SystemExit(__doc__.strip().splitlines()[-1])
    s = json.loads(Path(sys.argv[1]).read_text())
    c = s["config"]
    print(f"{sys.argv[1]}: {c['size']} fleet, {c['eval_episodes']} evaluation episodes")
    print(table(rows(s)))


if __name__ == "__main__":
    main()
