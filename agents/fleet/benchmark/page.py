"""The leaderboard of ``docs/benchmark.md``, written from the shipped baselines and the scored
entries (:mod:`agents.fleet.benchmark.entries`) by ``brakewear fleet-leaderboard``: per
suite, each baseline's and entry's net cost on the test split with
its 95% bootstrap interval over episodes, its paired ratio to the bound, its paired
difference from the suite's best, the predictors' rules paired (the twin against the window
model), the compute and the command that made them.

Only the text between the page's two markers is the command's; the rest of the page is
written by hand, and a page without the markers is refused (the command replaces nothing it
did not write).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from scipy.stats import bootstrap

from agents.fleet.benchmark.baselines import read_baselines
from agents.fleet.benchmark.entries import read_entries
from agents.fleet.benchmark.suite import read_suite, shipped_suites
from agents.fleet.evaluation.costs import paired_interval

BEGIN = "<!-- leaderboard: written by `brakewear fleet-leaderboard`; edits here are lost -->"
END = "<!-- /leaderboard -->"


def leaderboard() -> str:
    """The leaderboard's Markdown: every shipped suite, its baselines and scored entries."""
    parts = []
    for name in shipped_suites():
        suite = read_suite(name)
        shipped, entries = read_baselines(suite), read_entries(suite)
        if shipped is None and not entries:
            parts.append(f"### `{name}`\n\nNo baselines shipped yet (`brakewear fleet-baselines"
                         f" --suite {name}`).\n")  # fmt: skip
            continue
        parts.append(suite_section(name, suite.description, shipped, entries))
    return "\n".join(parts)


def suite_section(
    name: str, description: str, shipped: dict[str, Any] | None,
    entries: dict[str, dict[str, Any]] | None = None,
) -> str:  # fmt: skip
    """One suite's table (baselines and scored entries, best first) and notes."""
    entries = entries or {}
    b = dict(shipped["baselines"]) if shipped is not None else {}
    clash = sorted(set(b) & set(entries))
    if clash:
        raise ValueError(f"suite {name!r}: entries {clash} have a baseline's name; rename"
                         " their files")  # fmt: skip
    rows = {**b, **{k: {**e, "kind": f"{e['kind']} (entry)"} for k, e in entries.items()}}
    order = sorted(rows, key=lambda k: rows[k]["net"])
    best = np.asarray(rows[order[0]]["episodes"]["net"])
    bound = shipped.get("bound") if shipped is not None else None
    lines = [f"### `{name}`", "", description + ".", "",
             "| policy | kind | net cost (95%) | minus the best (paired) | ratio to the bound |",
             "| --- | --- | --- | --- | --- |"]  # fmt: skip
    for k in order:
        x = np.asarray(rows[k]["episodes"]["net"])
        minus = "" if k == order[0] else _iv(paired_interval(x, best, "difference"))
        kind, ratio = rows[k]["kind"], _ratio(x, bound)
        lines.append(f"| `{k}` | {kind} | {_mean_iv(x)} | {minus} | {ratio} |")
    if bound is not None:
        low = np.asarray(bound["episodes"])
        one = "1" if low.mean() > 0 else ""
        lines.append(f"| bound | Lagrangian ({bound['iterations']} price vectors) |"
                     f" {_mean_iv(low)} | | {one} |")  # fmt: skip
    seeds = shipped["seeds"] if shipped is not None else rows[order[0]]["episodes"]["seed"]
    lines += ["", f"{len(seeds)} test episodes from seed {seeds[0]}; net cost per"
              " vehicle-shift in USD."]  # fmt: skip
    lines += _made(shipped) + _entry_notes(entries)
    if "twin-rule" in b and "window-rule" in b:
        twin, window = (np.asarray(b[k]["episodes"]["net"]) for k in ("twin-rule", "window-rule"))
        d = paired_interval(twin, window, "difference")
        verdict = ("the twin is worth more" if d.high < 0
                   else "the window model is worth more" if d.low > 0
                   else "no difference shown")  # fmt: skip
        lines += ["", f"Twin's rule minus the window model's: {_iv(d)} ({verdict})."]
    return "\n".join(lines) + "\n"


def _made(shipped: dict[str, Any] | None) -> list[str]:
    """How the baselines were made: the file's command, and those remade on their own
    (``fleet-baselines --only``) with theirs."""
    if shipped is None:
        return ["", "No baselines shipped yet (`brakewear fleet-baselines`)."]
    secs = shipped.get("seconds")
    made = f" in {secs / 3600:.2f} h of wall time (2 cores, shared)" if secs else ""
    out = ["", f"Baselines made{made}: `{shipped['command']}`"]
    remade: dict[str, list[str]] = {}
    for k, v in [*shipped["baselines"].items(), ("bound", shipped.get("bound") or {})]:
        if v.get("command"):
            run = f"`{v['distil_command']}`, then " if v.get("distil_command") else ""
            remade.setdefault(run + f"`{v['command']}`", []).append(f"`{k}`")
    if remade:
        out.append("")
    for command, names in remade.items():
        out.append(f"- {', '.join(names)} remade since: {command}")
    return out


def _entry_notes(entries: dict[str, dict[str, Any]]) -> list[str]:
    """Each scored entry's compute and commands."""
    out = []
    for k, e in entries.items():
        c = e["compute"]
        steps = "no training" if c["training_steps"] is None else f"{c['training_steps']:,}"
        steps += "" if c["training_steps"] is None else " training steps"
        cmds = "; ".join(f"`{s}`" for s in c["commands"])
        out.append(f"- `{k}` (scored entry): {steps}, {c['cpu_hours']:.2f} CPU-hours: {cmds}")
    return ["", "Scored entries (`agents/fleet/benchmark/entries/`):", "", *out] if out else []


def write_page(path: str | Path) -> Path:
    """Replace the leaderboard between the page's markers.

    Raises:
        ValueError: The page is missing or lacks the markers (nothing is written).
    """
    p = Path(path)
    text = p.read_text(encoding="utf-8") if p.is_file() else ""
    if BEGIN not in text or END not in text or text.index(BEGIN) > text.index(END):
        raise ValueError(f"--page {p}: no leaderboard markers ({BEGIN!r} ... {END!r}); the"
                         " command writes only between them")  # fmt: skip
    head, rest = text.split(BEGIN, 1)
    tail = rest.split(END, 1)[1]
    p.write_text(f"{head}{BEGIN}\n\n{leaderboard()}\n{END}{tail}", encoding="utf-8")
    return p


def _iv(iv: Any) -> str:
    return f"{iv.point:+.3f} [{iv.low:+.3f}, {iv.high:+.3f}]"


def _mean_iv(x: Any) -> str:
    ci = bootstrap((x,), np.mean, confidence_level=0.95, n_resamples=4000,
                   rng=np.random.default_rng(0)).confidence_interval  # fmt: skip
    return f"{x.mean():.3f} [{ci.low:.3f}, {ci.high:.3f}]"


def _ratio(x: Any, bound: dict[str, Any] | None) -> str:
    if bound is None:
        return ""
    y = np.asarray(bound["episodes"])
    if y.mean() <= 0:
        return "(bound not positive)"
    r = paired_interval(x, y, "ratio")
    return f"{r.point:.3f} [{r.low:.3f}, {r.high:.3f}]"
