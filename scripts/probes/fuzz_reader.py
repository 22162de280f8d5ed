"""Counts of the event-log reader's outcomes on generated malformed logs
(docs/schema.md), by format and by mutation: the figures behind the fuzz test.

    .venv/bin/python scripts/probes/fuzz_reader.py [--cases 1000] [--seed 0]

Outcomes: ``loaded-intact`` (the values equal the intended ones), ``loaded-prefix`` (a CSV
cut exactly at a line end: a valid, shorter log that no file-level check can tell from a
whole one; a dataset's manifest catches it), ``refused`` (one EventLogError naming the
file, and the column, row and CSV line where one cell is at fault). Anything else is a
failure and is listed.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

from fuzz_logs import run_all  # beside this script (its directory is on the path)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=1000, help="logs to generate")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as d:
        counts, failures = run_all(args.cases, args.seed, Path(d))
    print(f"{args.cases} generated logs (seed {args.seed}), {time.perf_counter() - t0:.1f} s")
    for fmt in ("csv", "parquet"):
        row = {k.split(" ", 1)[1]: v for k, v in counts.items() if k.startswith(fmt + " ")}
        print(f"  {fmt:8s} " + "  ".join(f"{k} {v}" for k, v in sorted(row.items())))
    print("by format and mutation:")
    for k, v in sorted(counts.items()):
        if k.startswith("outcome "):
            print(f"  {k[8:]} {v}")
    print(f"failures: {len(failures)}")
    for f in failures[:50]:
        print("  " + f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
