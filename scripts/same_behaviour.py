"""Same behaviour before and after a change (issue 28): fixed-seed rollouts of BrakeWear-v0
and BrakeWearFleet-v0 array-equal, and a small ``brakewear fleet-study`` whose
``costs.json`` is identical apart from timings (and, optionally, named new keys).

    .venv/bin/python scripts/same_behaviour.py run OUT            # on this checkout
    .venv/bin/python scripts/same_behaviour.py compare BEFORE AFTER [--ignore-row-key episodes]

Run ``run`` on each checkout (for an older commit: a worktree of it on ``PYTHONPATH`` with
this venv's Python), then ``compare`` the two folders.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np

STUDY = ["fleet-study", "--quiet", "--predictors", "none,twin,oracle", "--heuristics",
         "threshold", "(n, N)", "--trials", "3", "--trials-best", "3", "--tune-episodes", "1",
         "--eval-episodes", "4", "--shifts", "40", "--n-train-runs", "4", "--agents", "oracle",
         "--agent-seeds", "1", "--timesteps", "256", "--imitate", "1", "--curve-every", "128",
         "--workers", "0"]  # fmt: skip
SMALL = {"n_vehicles": 2, "hot_need": 1, "mild_need": 1, "window_slots": 1, "bays": 1}


def rollouts() -> dict[str, np.ndarray]:
    """Seeded random actions: BrakeWear-v0 3,000 steps, the default fleet 300 shifts, the
    2-vehicle fleet 400 (a new episode where one ends)."""
    import gymnasium as gym

    import brake_env  # noqa: F401  # registers the envs

    out = {}
    for name, kw, steps in (("single", {}, 3000), ("fleet", {}, 300), ("fleet_small", SMALL, 400)):
        env = gym.make("BrakeWear-v0" if name == "single" else "BrakeWearFleet-v0", **kw).unwrapped
        rng = np.random.default_rng(123)
        obs, _ = env.reset(seed=7)
        seen, rewards = [obs], []
        for _ in range(steps):
            if name == "single":
                action: Any = int(rng.random() < 0.02)
            else:
                n = env.config.n_vehicles
                duty = rng.choice(4, n, p=[0.5, 0.3, 0.15, 0.05])
                action = np.append(duty, rng.integers(0, 3)).astype(np.int64)
            obs, reward, terminated, truncated, _ = env.step(action)
            seen.append(obs)
            rewards.append(reward)
            if terminated or truncated:
                obs, _ = env.reset()
                seen.append(obs)
        out[f"{name}_obs"], out[f"{name}_rew"] = np.array(seen), np.array(rewards)
    return out


def run(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    np.savez(out / "rollouts.npz", **rollouts())
    cmd = [sys.executable, "-m", "brake_env.cli.main", *STUDY, "--out", str(out / "fs")]
    subprocess.run(cmd, check=True)


def _strip(x: Any) -> Any:
    """``x`` without its timings (every key with "seconds" in it)."""
    if isinstance(x, dict):
        return {k: _strip(v) for k, v in x.items() if "seconds" not in k}
    if isinstance(x, list):
        return [_strip(v) for v in x]
    return x


def compare(before: Path, after: Path, ignore: set[str]) -> bool:
    a, b = np.load(before / "rollouts.npz"), np.load(after / "rollouts.npz")
    same = True
    for k in a.files:
        eq = np.array_equal(a[k], b[k])
        same &= eq
        print(f"rollouts {k} {a[k].shape}: array_equal {eq}")
    ca, cb = (json.loads((d / "fs" / "costs.json").read_text()) for d in (before, after))
    for row in (*ca["rows"], *cb["rows"]):  # keys a row gained in `after`
        for k in ignore:
            row.pop(k, None)
    eq = _strip(ca) == _strip(cb)
    but = f" and the rows' {sorted(ignore)}" if ignore else ""
    print(f"costs.json identical apart from timings{but}: {eq}")
    return same and eq


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="what", required=True)
    r = sub.add_parser("run")
    r.add_argument("out", type=Path)
    c = sub.add_parser("compare")
    c.add_argument("before", type=Path)
    c.add_argument("after", type=Path)
    c.add_argument("--ignore-row-key", action="append", default=[], help="keys new in `after`")
    a = ap.parse_args()
    if a.what == "run":
        run(a.out)
        return 0
    return 0 if compare(a.before, a.after, set(a.ignore_row_key)) else 1


if __name__ == "__main__":
    raise SystemExit(main())
