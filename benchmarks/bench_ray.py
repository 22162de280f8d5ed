"""The same validate-gap, compare and fleet-study subsets in this process and on a local
Ray with 1 and 2 workers, in one run (targets in brackets; docs/cluster.md).

Each configuration runs the real command in a fresh process (``brakewear validate-gap`` /
``brakewear compare`` with ``--workers 0|1|2``), so the wall time includes everything a
user waits for: imports, starting Ray, starting its workers, moving the atlas and the
fitted predictors through the object store. The outputs are checked equal to the
in-process ones (timing fields aside) before any speed-up is printed.

- 2 workers against this process [>= 1.7x faster];
- 1 worker against this process [no more than 10% slower, i.e. >= 0.91x].

Where the time goes, for commands that keep their units with their times: the units' own
work summed (``units' work``; more on Ray than in this process means slower units in Ray
workers) and the share of the workers' time it fills (``busy``; the rest is start-up, what
is not a unit, e.g. fitting the predictors, and workers idle while others finish).

Run: ``.venv/bin/python benchmarks/bench_ray.py [--json out.json]
[--only validate|compare|fleet]`` (about 12 minutes on 2 cores for the first two; the fleet
study about 8 more).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from brake_env.output import table, write_json

WORKERS = (0, 1, 2)
# Eight cases (three effects at mid magnitude, two seeds each, and two controls) of similar
# durations, so two workers share them evenly.
VALIDATE = [
    "validate-gap", "--only", "speed_friction", "tc_bias", "newton_cooling", "control",
    "--seeds", "2", "--controls", "2", "--out-of-library", "0", "--runs", "4", "--no-rul",
]  # fmt: skip
# The cost study without agents (each training run is one unit of its own): 300 tuning
# and 600 held-out pads in chunks of 48, on the paper's predictors, with pads wearing 5x
# faster than the default so that the in-process run takes minutes.
COMPARE = [
    "compare", "--tune-pads", "100", "--eval-pads", "200", "--timesteps", "1",
    "--predictors", "none,physics,data,twin,oracle", "--agents", "", "--resamples", "1000",
    "--k-mean", "1e-5",
]  # fmt: skip
# The fleet study without agents: six predictors x two heuristics tuned and evaluated (12
# units) and the reference, on 180-shift episodes, after the predictors are fitted (units).
FLEET = [
    "fleet-study", "--predictors", "none,physics,data,twin,window,oracle", "--heuristics",
    "threshold", "(n, N)", "--trials", "4", "--tune-episodes", "2", "--eval-episodes", "12",
    "--shifts", "180",
]  # fmt: skip
TIMING_KEYS = {"seconds", "seconds_simulate", "seconds_diagnose", "timing_s", "settings"}


def _strip(tree: Any) -> Any:
    """A result without its wall times and run settings (they differ by design)."""
    if isinstance(tree, dict):
        return {k: _strip(v) for k, v in tree.items() if k not in TIMING_KEYS}
    if isinstance(tree, list):
        return [_strip(v) for v in tree]
    return tree


def run(argv: list[str], out: Path, workers: int, cache: str) -> float:
    """Wall time [s] of ``brakewear argv --out out --workers workers`` in a fresh process."""
    shutil.rmtree(out, ignore_errors=True)
    cmd = [sys.executable, "-m", "brake_env.cli.main", *argv, "--out", str(out), "--quiet",
           "--seed", "0", "--workers", str(workers)]  # fmt: skip
    env = {**os.environ, "BRAKEWEAR_CACHE_DIR": cache, "MPLBACKEND": "Agg"}
    t0 = time.perf_counter()
    done = subprocess.run(cmd, env=env, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if done.returncode:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{done.stderr[-3000:]}")
    return seconds


def unit_seconds(out: Path) -> float | None:
    """The stored units' own wall time summed (each unit's ``seconds``: a number, or a dict
    of its parts), or None if the command keeps no units with their times."""
    total, found = 0.0, False
    for f in sorted((out / "units").glob("*.json")):
        spent = json.loads(f.read_text()).get("result", {})
        spent = spent.get("seconds") if isinstance(spent, dict) else None
        if isinstance(spent, dict):
            spent = sum(v for v in spent.values() if isinstance(v, (int, float)))
        if isinstance(spent, (int, float)):
            total, found = total + float(spent), True
    return total if found else None


def study(
    name: str, argv: list[str], result: str, root: Path, cache: str
) -> tuple[list[list[str]], dict[str, Any]]:
    """Rows of the table and the JSON record of one command at every worker count."""
    seconds: dict[int, float] = {}
    outputs: dict[int, Any] = {}
    work: dict[int, float | None] = {}
    for w in WORKERS:
        out = root / f"{name}-{w}"
        seconds[w] = run(argv, out, w, cache)
        outputs[w] = _strip(json.loads((out / result).read_text()))
        work[w] = unit_seconds(out)
        print(f"{name}, workers {w}: {seconds[w]:.1f} s", file=sys.stderr)
    same = all(outputs[w] == outputs[0] for w in WORKERS)
    if not same:
        raise SystemExit(f"{name}: {result} differs between workers {WORKERS}")
    targets: dict[int, tuple[str, Callable[[float], bool]]] = {
        1: (">= 0.91x (<= 10% slower)", lambda s: s >= 1 / 1.1),
        2: (">= 1.7x", lambda s: s >= 1.7),
    }
    rows = []
    record = {"seconds": seconds, "same_results": same, "speedup": {}, "unit_seconds": work}
    for w in WORKERS:
        speedup = seconds[0] / seconds[w]
        record["speedup"][w] = speedup
        label = "in this process" if w == 0 else f"local Ray, {w} worker{'s' * (w > 1)}"
        want, ok = targets.get(w, ("baseline", lambda _: True))
        verdict = "" if w == 0 else ("met" if ok(speedup) else "MISSED")
        # where the time goes: the units' own work, and the share of the workers' time it fills
        units = "" if work[w] is None else f"{work[w]:.1f} s"
        busy = "" if work[w] is None else f"{work[w] / (max(w, 1) * seconds[w]):.0%}"
        rows.append([name, label, f"{seconds[w]:.1f} s", f"{speedup:.2f}x", want, verdict,
                     units, busy])  # fmt: skip
    return rows, record


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", default=None, help="also write the figures here")
    ap.add_argument("--only", choices=["validate", "compare", "fleet"], default=None)
    args = ap.parse_args()
    cache = os.environ.get("BRAKEWEAR_CACHE_DIR") or tempfile.mkdtemp(prefix="bench-ray-cache")
    subprocess.run(
        [sys.executable, "-m", "brake_env.cli.main", "atlas", "--quiet"],
        env={**os.environ, "BRAKEWEAR_CACHE_DIR": cache},
        check=False,
        capture_output=True,
    )  # fmt: skip  (built once, not timed)
    root = Path(tempfile.mkdtemp(prefix="bench-ray-"))
    header = [["study", "where", "wall", "x in-process", "target", "", "units' work",
                "busy"]]  # fmt: skip
    rows, record = [], {"cpus": os.cpu_count()}
    for name, argv, result in (("validate-gap", VALIDATE, "validation.json"),
                               ("compare", COMPARE, "costs.json"),
                               ("fleet-study", FLEET, "costs.json")):  # fmt: skip
        if args.only and not name.startswith(args.only):
            continue
        r, rec = study(name, argv, result, root, cache)
        rows += r
        record[name] = rec
    print(table(header + rows))
    print("outputs equal to the in-process ones at every worker count (timing aside)")
    if args.json:
        write_json(record, args.json)
    shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
