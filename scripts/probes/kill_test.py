"""Kill ``brakewear simulate``, ``evaluate`` and ``predict`` at random points and show that
nothing later trusts a partial file (docs/schema.md: nothing lost, nothing half-written).

    .venv/bin/python scripts/probes/kill_test.py [--kills 30] [--seed 0] [--work DIR]

Each command runs in its own process group and gets SIGKILL after a random delay within its
unkilled run time (measured first, lowered when a run under less load finishes before its
kill): a quarter in the first 30% (start-up, simulation), the rest later, where the writes
are; runs repeat until each command has its share of kills. After each run:

- every file under the command's output directory with its final name must be whole
  (JSON parses as strict JSON, a PNG ends with its IEND chunk, a Parquet file reads with its
  page checksums, a CSV ends with a line end and parses, an ``.npz`` loads, text ends with
  a line end); hidden temporary files of killed writers are counted, not judged;
- after a killed ``simulate``, ``brakewear evaluate`` on the directory must either refuse it
  or find it whole: its manifest complete and every file matching its checksum, and
  ``summary.json`` absent or of the same seed.

``predict`` is skipped with a message when the command does not exist. Prints the counts
and exits 1 if any check failed.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from brake_env.output import Manifest, ManifestError  # noqa: E402

BRAKEWEAR = [sys.executable, "-m", "brake_env.cli.main"]
DATA_ARGS = ["--n-train", "3", "--n-id", "2", "--n-ood-slow", "1", "--n-ood-fast", "1"]
DATA_ARGS += ["--k-mean", "1e-5", "--k-std", "1e-6"]  # ~20k events a pad: seconds a run
REASONS = {
    "never finished": "killed while writing: manifest incomplete",
    "does not match": "a file does not match the manifest",
    "but missing": "a file listed in the manifest is missing",
}
EVAL_ARGS = ["--predictors", "physics,data", "--mlp-epochs", "2"]


def run(args: list[str], env: dict[str, str], timeout: float = 900) -> subprocess.CompletedProcess:
    return subprocess.run(
        BRAKEWEAR + args, env=env, capture_output=True, text=True, timeout=timeout, check=False
    )


def timed(args: list[str], env: dict[str, str]) -> float:
    t0 = time.perf_counter()
    r = run(args, env)
    if r.returncode != 0:
        raise SystemExit(f"reference run failed: brakewear {' '.join(args)}\n{r.stderr}")
    return time.perf_counter() - t0


def kill_after(args: list[str], env: dict[str, str], delay: float) -> tuple[str, float]:
    """Start ``brakewear args``, SIGKILL its process group after ``delay`` s; what happened
    and how long it ran."""
    t0 = time.perf_counter()
    p = subprocess.Popen(
        BRAKEWEAR + args,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    try:
        p.wait(timeout=delay)
        what = "finished before the kill" if p.returncode == 0 else f"failed rc {p.returncode}"
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        p.wait()
        what = "killed"
    return what, time.perf_counter() - t0


# ---------------------------------------------------------------------- is a file whole?
def _strict_json(path: Path) -> None:
    def bad(c: str) -> None:
        raise ValueError(f"bare {c}")

    json.loads(path.read_text(encoding="utf-8"), parse_constant=bad)


def _png(path: Path) -> None:
    b = path.read_bytes()
    if not (b.startswith(b"\x89PNG\r\n\x1a\n") and b.endswith(b"IEND\xaeB`\x82")):
        raise ValueError("not a whole PNG")


def _parquet(path: Path) -> None:
    import pyarrow.parquet as pq

    pq.ParquetFile(path, page_checksum_verification=True).read()


def _csv(path: Path) -> None:
    import pyarrow.csv as pa_csv

    if not path.read_bytes().endswith(b"\n"):
        raise ValueError("no final line end")
    pa_csv.read_csv(path)


def _npz(path: Path) -> None:
    with np.load(path, allow_pickle=False) as z:
        for k in z.files:
            z[k]  # reading checks the zip CRC


def _text(path: Path) -> None:
    if not path.read_bytes().endswith(b"\n"):
        raise ValueError("no final line end")


CHECKS: dict[str, Callable[[Path], None]] = {
    ".json": _strict_json,
    ".png": _png,
    ".parquet": _parquet,
    ".csv": _csv,
    ".npz": _npz,
    ".md": _text,
}


def partial_files(root: Path, counts: Counter[str]) -> list[str]:
    """Files with their final names that are not whole; counts what was looked at."""
    bad = []
    for p in sorted(root.rglob("*")):
        if not p.is_file():
            continue
        if p.name.startswith("."):
            counts["temporary files left by killed writers"] += 1
            continue
        check = CHECKS.get(p.suffix)
        if check is None:
            counts["files of unchecked type"] += 1
            continue
        try:
            check(p)
            counts["files checked whole"] += 1
        except Exception as e:  # any failure to read it whole
            bad.append(f"{p.relative_to(root)}: {type(e).__name__}: {e}")
    return bad


def directory_whole(data: Path) -> str | None:
    """Why ``data`` is not a whole dataset directory, or None."""
    try:
        m = Manifest.read(data)
        if m is None:
            return "no manifest"
        m.check(m.directory / n for n in m.files)
    except ManifestError as e:
        return str(e)
    summary = data / "summary.json"
    if summary.is_file() and json.loads(summary.read_text()).get("seed") != m.meta.get("seed"):
        return "summary.json of another seed"
    return None


# ---------------------------------------------------------------------- the three commands
class Harness:
    """Kills the commands repeatedly and checks what they leave."""

    def __init__(self, work: Path, env: dict[str, str], seed: int) -> None:
        self.work, self.env = work, env
        self.rng = np.random.default_rng(seed)
        self.counts: Counter[str] = Counter()
        self.failures: list[str] = []
        self.t: dict[str, float] = {}  # run time of each command unkilled [s]

    def kill(self, name: str, args: list[str], out: Path) -> None:
        """Run ``args`` and kill it at a random point, then check the files under ``out``.
        A quarter of the delays fall in the first 30% of the run time (start-up,
        simulation), the rest in the last 70%, where the writes are."""
        t = self.t[name]
        u = self.rng.uniform(0, 0.3) if self.rng.random() < 0.25 else self.rng.uniform(0.3, 1)
        what, took = kill_after(args, self.env, float(u * t))
        if what != "killed":
            self.t[name] = min(t, took)  # a run under less load: aim earlier
        self.counts[f"{name}: {what}"] += 1
        k = self.counts[f"{name} runs"]
        self.counts[f"{name} runs"] += 1
        self.failures += [f"{name} {k}: partial {b}" for b in partial_files(out, self.counts)]

    def attempts(self, name: str, n: int) -> Iterator[int]:
        """Run numbers until ``n`` kills of ``name`` (at most 4 n runs)."""
        for k in range(4 * n):
            if self.counts[f"{name}: killed"] >= n:
                return
            yield k

    def simulate(self, n: int) -> None:
        data = self.work / "data"
        for k in self.attempts("simulate", n):
            seed = str(int(self.rng.integers(1, 4)))  # a rewrite by another seed: mixing shows
            args = ["simulate", "--out", str(data), "--seed", seed, "--quiet", *DATA_ARGS]
            self.kill("simulate", args, data)
            check = ["evaluate", "--data", str(data), "--out", str(self.work / "ev-check")]
            r = run([*check, "--predictors", "physics", "--quiet"], self.env)
            whole = directory_whole(data)
            if r.returncode == 0:
                self.counts["evaluate after a killed simulate: ran, the directory whole"] += 1
                if whole is not None:
                    self.failures.append(f"simulate {k}: evaluate trusted it though {whole}")
                continue
            last = (r.stderr.strip().splitlines() or ["?"])[-1]
            why = next((w for key, w in REASONS.items() if key in last), last[:70])
            self.counts[f"evaluate after a killed simulate: refused ({why})"] += 1
            if whole is None:
                self.failures.append(f"simulate {k}: evaluate refused a whole directory: {last}")

    def evaluate(self, n: int) -> None:
        out = self.work / "ev"
        args = ["evaluate", "--data", str(self.work / "data-ok"), "--out", str(out), "--quiet"]
        for _ in self.attempts("evaluate", n):
            self.kill("evaluate", [*args, *EVAL_ARGS], out)

    def predict(self, n: int) -> None:
        out = self.work / "pred"
        args = ["predict", "--model", str(self.work / "model"), "--log"]
        args += [str(self.work / "data-ok" / "ood.parquet"), "--out", str(out), "--quiet"]
        for k in self.attempts("predict", n):
            self.kill("predict", args, out)
            r = run(args, self.env)  # a later run over what the killed one left
            self.counts[f"predict after a killed predict: exit code {r.returncode}"] += 1
            if r.returncode != 0:
                self.failures.append(f"predict {k}: the next predict failed: {r.stderr[-300:]}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--kills", type=int, default=30, help="kills in all (split 3 ways)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--work", default=None, help="working directory (default: a temporary one)")
    args = ap.parse_args()
    work = Path(args.work or tempfile.mkdtemp(prefix="brakewear-kill-"))
    work.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, "BRAKEWEAR_CACHE_DIR": str(work / "cache"), "MPLBACKEND": "Agg"}
    h = Harness(work, env, args.seed)
    has_predict = run(["predict", "--help"], env).returncode == 0
    t0 = time.perf_counter()
    # Reference runs, unkilled: the data evaluate and predict read, and the run times.
    ok = str(work / "data-ok")
    h.t["simulate"] = timed(["simulate", "--out", ok, "--quiet", *DATA_ARGS], env)
    shutil.copytree(ok, work / "data")
    ev = ["evaluate", "--data", ok, "--out", str(work / "ev"), "--quiet", *EVAL_ARGS]
    h.t["evaluate"] = timed(ev, env)
    n_each = -(-args.kills // (3 if has_predict else 2))
    times = f"simulate {h.t['simulate']:.1f} s, evaluate {h.t['evaluate']:.1f} s"
    h.simulate(n_each)
    h.evaluate(n_each)
    if has_predict:
        model = str(work / "model")
        timed(["fit", "--data", ok, "--predictor", "twin", "--out", model, "--quiet"], env)
        pred = ["predict", "--model", model, "--log", f"{ok}/ood.parquet", "--out"]
        h.t["predict"] = timed([*pred, str(work / "pred"), "--quiet"], env)
        times += f", predict {h.t['predict']:.1f} s"
        h.predict(n_each)
    else:
        print("predict: skipped (no `brakewear predict` command in this checkout)")
    kills = sum(v for k, v in h.counts.items() if k.endswith(": killed"))
    print(f"unkilled run times: {times}")
    print(f"{kills} kills, {time.perf_counter() - t0:.0f} s in all, work directory {work}")
    for k, v in sorted(h.counts.items()):
        print(f"  {k}: {v}")
    print(f"failures: {len(h.failures)}")
    for f in h.failures:
        print("  " + f)
    return 1 if h.failures else 0


if __name__ == "__main__":
    sys.exit(main())
