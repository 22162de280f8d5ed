"""Benchmark of the command line's start-up, against importing numpy and pandas in the
same run (target in brackets):
- ``brakewear --help`` wall time / ``python -c "import numpy, pandas"`` [< 2];
- ``brakewear --help`` and ``brakewear atlas`` (a real run: the cached atlas, its summary
  and calibration figure) import neither torch nor Stable-Baselines3 (checked in the same
  processes' ``sys.modules``).

Each command runs ``--repeats`` times in a fresh interpreter; the median wall time counts.

Run: ``.venv/bin/python benchmarks/bench_cli.py [--repeats N] [--json out.json]``.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from brake_env.output import table, write_json

HEAVY = ("torch", "stable_baselines3")
# The brakewear console script, with a report of the heavy modules it loaded on exit.
CLI = (
    "import atexit, sys\n"
    "atexit.register(lambda: print('HEAVY', *[m for m in {heavy} if m in sys.modules]))\n"
    "from brake_env.cli.main import main\n"
    "sys.argv = ['brakewear', *{argv}]\n"
    "try:\n    main()\nexcept SystemExit:\n    pass\n"
)


def timed(code: str, repeats: int) -> tuple[float, str]:
    """Median wall time of ``python -c code`` and the last run's output."""
    times, out = [], ""
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
        times.append(time.perf_counter() - t0)
        if res.returncode != 0:
            raise RuntimeError(f"{code!r} failed:\n{res.stderr}")
        out = res.stdout
    return statistics.median(times), out


def main() -> dict[str, object]:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--repeats", type=int, default=7)
    p.add_argument("--json", type=Path, default=None)
    args = p.parse_args()
    base_s, _ = timed("import numpy, pandas", args.repeats)
    rows, result = [["command", "median s", "vs numpy+pandas", "heavy modules loaded"]], {}
    rows.append(["import numpy, pandas", f"{base_s:.3f}", "1.00", "-"])
    out_dir = tempfile.mkdtemp(prefix="bench_cli_")
    for argv in (["--help"], ["atlas", "--out", out_dir, "--quiet"]):
        s, out = timed(CLI.format(heavy=HEAVY, argv=argv), args.repeats)
        heavy = next(line for line in out.splitlines() if line.startswith("HEAVY")).split()[1:]
        name = "brakewear " + " ".join(argv[:1] if argv[0] == "atlas" else argv)
        rows.append([name, f"{s:.3f}", f"{s / base_s:.2f}", ", ".join(heavy) or "none"])
        result[name] = {"seconds": s, "ratio": s / base_s, "heavy_modules": heavy}
    result["import numpy, pandas"] = {"seconds": base_s}
    print(table(rows))
    ratio = result["brakewear --help"]["ratio"]  # type: ignore[index]
    print(f"\n--help / numpy+pandas: {ratio:.2f} [target < 2]")
    if args.json:
        write_json(result, args.json)
    return result


if __name__ == "__main__":
    main()
