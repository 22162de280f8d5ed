"""Scored entries: results submitted to the leaderboard, shown beside the shipped baselines.

An entry is one file, ``agents/fleet/benchmark/entries/<suite>/<name>.json`` (``<name>`` is
its row on the leaderboard): the ``score.json`` that ``brakewear fleet-score`` wrote for it on
the suite's whole test split, unchanged, with two keys added::

    "kind": "learned",                  # what it is: learned, index, planner, rule, ...
    "compute": {
        "training_steps": 2000000,      # env steps of training; null if nothing was trained
        "cpu_hours": 3.5,               # CPU time of training and scoring, in hours
        "commands": ["python examples/fleet_marl.py ...",
                     "brakewear fleet-score --suite default --policy ... --out ..."]
    }

The commands are those that trained and scored it, in order. The leaderboard pairs an
entry with the baselines and the bound from its per-episode ``episodes.net`` (the
comparisons inside its ``score.json`` are as they were when it was scored). An entry scored
on another suite digest (the suite's protocol or fleet changed since), on other episodes or
with another name's file is refused, naming the file (:func:`read_entries`).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from agents.fleet.benchmark.suite import Suite

ENTRIES_DIR = Path(__file__).with_name("entries")
_COMPUTE = ("training_steps", "cpu_hours", "commands")


def entries_dir(suite: Suite) -> Path:
    return ENTRIES_DIR / suite.name


def read_entries(suite: Suite, folder: str | Path | None = None) -> dict[str, dict[str, Any]]:
    """A suite's entries by name (the file's stem), from its folder (default the shipped one).

    Raises:
        ValueError: An entry that is not JSON or not of the format, or of another suite,
            digest or test split (named with its file).
    """
    d = Path(folder) if folder is not None else entries_dir(suite)
    return {p.stem: read_entry(p, suite) for p in sorted(d.glob("*.json"))}


def read_entry(path: str | Path, suite: Suite) -> dict[str, Any]:
    """One entry file, checked against ``suite`` (see :func:`check_entry`)."""
    p = Path(path)
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError) as e:
        raise ValueError(f"entry {p}: not a JSON file ({e})") from None
    return check_entry(data, suite, str(p))


def check_entry(data: Any, suite: Suite, where: str = "entry") -> dict[str, Any]:
    """``data`` if it is an entry of ``suite``'s test split in the module's format.

    Raises:
        ValueError: The first thing wrong, named with ``where``.
    """
    if not isinstance(data, dict):
        raise ValueError(f"{where}: not a JSON object")
    missing = [k for k in ("policy", "suite", "suite_digest", "net", "episodes", "kind",
                           "compute") if k not in data]  # fmt: skip
    if missing:
        raise ValueError(f"{where}: missing key(s) {missing} (an entry is fleet-score's"
                         " score.json plus 'kind' and 'compute')")  # fmt: skip
    if data["suite"] != suite.name or data["suite_digest"] != suite.digest:
        raise ValueError(f"{where}: scored on suite {data['suite']!r} digest"
                         f" {data['suite_digest']}, and suite {suite.name!r} is {suite.digest}"
                         " (its protocol or fleet changed, or the wrong folder: re-score"
                         " it)")  # fmt: skip
    if not isinstance(data["kind"], str) or not data["kind"].strip():
        raise ValueError(f"{where}: 'kind' must be a non-empty string, got {data['kind']!r}")
    _check_episodes(data, suite, where)
    _check_compute(data["compute"], where)
    return data


def _check_episodes(data: dict[str, Any], suite: Suite, where: str) -> None:
    """The whole test split, and a mean that is its episodes'."""
    ep = data["episodes"]
    if not isinstance(ep, dict) or "seed" not in ep or "net" not in ep:
        raise ValueError(f"{where}: 'episodes' must hold 'seed' and 'net' lists")
    seeds = suite.seeds("test")
    if list(ep["seed"]) != seeds:
        raise ValueError(f"{where}: episodes.seed must be the suite's whole test split"
                         f" ({seeds[0]}..{seeds[-1]}, {len(seeds)} episodes)")  # fmt: skip
    net = ep["net"]
    if len(net) != len(seeds) or not all(_number(v) for v in net):
        raise ValueError(f"{where}: episodes.net must be {len(seeds)} finite numbers")
    mean = sum(net) / len(net)
    if not _number(data["net"]) or not math.isclose(data["net"], mean, rel_tol=1e-9):
        raise ValueError(f"{where}: 'net' {data['net']!r} is not the mean of episodes.net"
                         f" ({mean!r})")  # fmt: skip


def _check_compute(c: Any, where: str) -> None:
    if not isinstance(c, dict) or sorted(c) != sorted(_COMPUTE):
        got = sorted(c) if isinstance(c, dict) else c
        raise ValueError(f"{where}: 'compute' must hold exactly {list(_COMPUTE)}, got {got!r}")
    steps = c["training_steps"]
    if steps is not None and (isinstance(steps, bool) or not isinstance(steps, int) or steps < 0):
        raise ValueError(f"{where}: compute.training_steps must be an integer >= 0 or null,"
                         f" got {steps!r}")  # fmt: skip
    if not _number(c["cpu_hours"]) or c["cpu_hours"] < 0:
        raise ValueError(f"{where}: compute.cpu_hours must be a number >= 0, got"
                         f" {c['cpu_hours']!r}")  # fmt: skip
    cmds = c["commands"]
    if not isinstance(cmds, list) or not cmds or not all(isinstance(s, str) and s for s in cmds):
        raise ValueError(f"{where}: compute.commands must be a non-empty list of the commands"
                         f" that trained and scored it, got {cmds!r}")  # fmt: skip


def _number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def make_entry(
    score: dict[str, Any], kind: str, *, training_steps: int | None, cpu_hours: float,
    commands: list[str],
) -> dict[str, Any]:  # fmt: skip
    """A ``score.json``'s content made an entry (checked when read against its suite)."""
    compute = {"training_steps": training_steps, "cpu_hours": cpu_hours, "commands": commands}
    return {**score, "kind": kind, "compute": compute}
