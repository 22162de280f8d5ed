"""The stages of ``brakewear demo`` after the atlas and the datasets: one after the other in
this process, or side by side in ``--workers`` processes.

The stages are independent (each reads the atlas and the datasets, writes under its own
folder and returns its result and its report section), so on two cores the heaviest runs
in one process while the others follow each other in the second: the demo's wall time is
then about the heaviest stage's, not the sum (docs/performance.md). Each stage runs its
own units in its process (no Ray): the figures are the same wherever units run
(:mod:`brake_env.runner`). A stage run side by side prints into a buffer that is shown
whole as soon as the stage is done; its wall and CPU seconds are its own process tree's.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import io
import multiprocessing
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, replace
from importlib.metadata import EntryPoint
from typing import TYPE_CHECKING, Any

from brake_env.cli.stage_clock import StageClock

if TYPE_CHECKING:
    from brake_env.cli.demo import DemoContext, DemoStage

# CPU seconds of each stage of `brakewear demo --seed 0` side by side (measured at load
# ~17 on 2 cores): the heaviest start first, so that none is left running alone at the end
# (longest processing time first). A stage not named here starts last.
STAGE_CPU_S = {"compare": 245.0, "fleet": 102.0, "diagnose": 60.0, "evaluate": 56.0}


@dataclass(frozen=True)
class StageRun:
    """What one stage gave.

    Attributes:
        name: The stage's name (its entry point's, without the order prefix).
        result: What the stage returned for later stages and the summary.
        section: Its Markdown section of ``report.md``.
        printed: What it printed, when it ran in another process ("" when printed live).
        wall, cpu: Its wall and CPU seconds (CPU of its process and every one it started).
    """

    name: str
    result: Any
    section: str
    printed: str
    wall: float
    cpu: float


def stage_name(ep: EntryPoint) -> str:
    """``30-evaluate`` -> ``evaluate``."""
    return ep.name.split("-", 1)[-1]


def run_stages(
    ctx: DemoContext, stages: Sequence[EntryPoint], workers: int, first: int, total: int
) -> list[StageRun]:
    """Every stage's run, in ``stages``' order; side by side when ``workers`` >= 2 and
    there are two or more stages. ``first`` and ``total`` number the headers printed."""
    if workers < 2 or len(stages) < 2:
        runs = []
        for i, ep in enumerate(stages, start=first):
            print(f"\n== {i}/{total} {stage_name(ep)}")
            runs.append(_run(ep.value, stage_name(ep), ctx))
            ctx.results[runs[-1].name] = runs[-1].result
            print(f"(stage: {runs[-1].wall:.1f} s wall, {runs[-1].cpu:.1f} s CPU)")
        return runs
    return _side_by_side(ctx, stages, workers, first, total)


def _side_by_side(
    ctx: DemoContext, stages: Sequence[EntryPoint], workers: int, first: int, total: int
) -> list[StageRun]:
    n = min(workers, len(stages))
    names = [stage_name(ep) for ep in stages]
    print(f"\n== {first}-{total}/{total} {', '.join(names)}: side by side in {n} processes")
    # Each stage runs its own units in its process: a Ray per stage would only compete
    # for the same cores.
    child = replace(ctx, args=argparse.Namespace(**{**vars(ctx.args), "workers": 0}), results={})
    heaviest = sorted(range(len(stages)), key=lambda i: -STAGE_CPU_S.get(names[i], 0.0))
    # spawn: a forked child would inherit the stage clock's thread and its lock mid-read
    spawn = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=n, mp_context=spawn) as pool:
        futures = {pool.submit(_run, stages[i].value, names[i], child, True): i for i in heaviest}
        runs: dict[int, StageRun] = {}
        try:
            for done in as_completed(futures):  # each shown as soon as it is done
                i, run = futures[done], done.result()
                print(f"\n== {first + i}/{total} {run.name}\n{run.printed}", end="")
                print(f"(stage: {run.wall:.1f} s wall, {run.cpu:.1f} s CPU)")
                runs[i] = run
        except BaseException:  # a stage failed: start no other, then say why
            pool.shutdown(cancel_futures=True)
            raise
    for i in range(len(stages)):
        ctx.results[runs[i].name] = runs[i].result
    return [runs[i] for i in range(len(stages))]


def _run(value: str, name: str, ctx: DemoContext, capture: bool = False) -> StageRun:
    """The stage ``module:function`` on ``ctx``, timed; what it prints kept when
    ``capture`` (it runs in a worker process)."""
    module, _, func = value.partition(":")
    stage: DemoStage = getattr(importlib.import_module(module), func)
    buffer = io.StringIO()
    out = contextlib.redirect_stdout(buffer) if capture else contextlib.nullcontext()
    with StageClock() as clock, out:
        result, section = stage(ctx)
        wall, cpu = clock.wall(), clock.cpu()
    return StageRun(name, result, section, buffer.getvalue(), wall, cpu)
