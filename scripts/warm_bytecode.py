"""Byte-compile what the project imports, once, right after ``pip install --no-compile``.

pip byte-compiles every file it installs (torch, Ray and SciPy ship tens of thousands the
project never imports): about 50 CPU seconds of a fresh venv, on one core. Installing
without it and importing every project module here instead (and the test and MARL
libraries the suite uses), with bytecode writing on, compiles only what runs, on both
cores, and leaves it cached for every later process, even where PYTHONDONTWRITEBYTECODE is
set. A module nobody imported here is compiled in memory when first imported, as Python
always does: nothing depends on this script but speed.

    .venv/bin/python scripts/warm_bytecode.py
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("brake_env", "twin", "baselines", "agents", "sim2real")
# The heavy libraries (project modules import most of them inside the functions that use
# them), and what the tests, the demo and the benchmarks import besides.
EXTRA = ("torch", "stable_baselines3", "sb3_contrib", "ray", "scipy.stats", "scipy.optimize",
         "scipy.interpolate", "pandas", "pyarrow.parquet", "matplotlib.pyplot", "gymnasium",
         "optuna", "tqdm", "pytest", "xdist", "mypy.main", "pettingzoo.test", "supersuit",
         "rl_zoo3", "highspy", "progpy", "torchrl.envs")  # fmt: skip

IMPORT_ALL = """
import importlib, pkgutil, sys
sys.dont_write_bytecode = False
for name in sys.argv[1:]:
    try:
        mod = importlib.import_module(name)
    except ImportError:  # an optional library not installed: nothing to warm
        continue
    if name not in {PACKAGES}:  # a library: what it imports itself, not every submodule
        continue
    for info in pkgutil.walk_packages(mod.__path__, name + "."):
        importlib.import_module(info.name)
"""


def main() -> int:
    """Two processes (one per core): the project's packages, then the other libraries."""
    code = IMPORT_ALL.replace("{PACKAGES}", repr(set(PACKAGES)))
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["MPLBACKEND"] = "Agg"
    jobs = [
        subprocess.Popen([sys.executable, "-c", code, *names], cwd=ROOT, env=env)
        for names in (PACKAGES, EXTRA)
    ]
    return max(job.wait() for job in jobs)


if __name__ == "__main__":
    sys.exit(main())
