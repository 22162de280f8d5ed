"""The demo's stages side by side in worker processes give what they give one after the
other: the same results, sections and printed text, the results in stage order."""

from __future__ import annotations

import argparse
import os
import time
from importlib.metadata import EntryPoint
from pathlib import Path
from typing import Any

import pytest

from brake_env.cli.demo import DemoContext
from brake_env.cli.demo_stages import run_stages

HERE = "tests.brake_env.cli.test_demo_stages"


def spin_stage(ctx: DemoContext) -> tuple[dict[str, Any], str]:
    """A stage that uses some CPU, prints, and says which process ran it and with which
    workers."""
    t0 = time.process_time()
    total = sum(i * i for i in range(200_000))
    print(f"spun {total}")
    used = time.process_time() - t0
    return {"pid": os.getpid(), "workers": ctx.args.workers, "total": total, "cpu": used}, "## A"


def echo_stage(ctx: DemoContext) -> tuple[dict[str, Any], str]:
    print(f"echo {ctx.args.seed}")
    return {"pid": os.getpid(), "workers": ctx.args.workers, "seed": ctx.args.seed}, "## B"


def _stages() -> list[EntryPoint]:
    group = "brakewear.demo"
    return [
        EntryPoint("10-spin", f"{HERE}:spin_stage", group),
        EntryPoint("20-echo", f"{HERE}:echo_stage", group),
    ]


def _ctx(tmp_path: Path, workers: int) -> DemoContext:
    args = argparse.Namespace(seed=3, workers=workers, quiet=True)
    return DemoContext(args, tmp_path, tmp_path / "atlas.npz", tmp_path / "data")


def test_side_by_side_gives_what_one_after_the_other_gives(tmp_path: Path, capsys) -> None:
    alone = run_stages(_ctx(tmp_path, 0), _stages(), 0, 3, 4)
    printed_alone = capsys.readouterr().out
    ctx = _ctx(tmp_path, 2)
    beside = run_stages(ctx, _stages(), 2, 3, 4)
    printed_beside = capsys.readouterr().out
    assert [r.name for r in beside] == ["spin", "echo"]
    assert [r.section for r in beside] == ["## A", "## B"]
    # each ran in a worker process, and was told to run its units there (no Ray)
    assert {r.result["pid"] for r in beside}.isdisjoint({os.getpid()})
    assert [r.result["workers"] for r in beside] == [0, 0]
    assert beside[0].result["total"] == alone[0].result["total"]
    assert beside[1].result["seed"] == alone[1].result["seed"] == 3
    assert ctx.results["echo"]["seed"] == 3
    # what each printed comes out whole, under its header, as soon as it is done
    assert [r.printed for r in beside] == [f"spun {alone[0].result['total']}\n", "echo 3\n"]
    assert "== 3/4 spin\nspun" in printed_beside and "== 4/4 echo\necho 3\n" in printed_beside
    assert "spun" in printed_alone and alone[0].printed == ""
    # a stage's CPU is its own process's: at least what it measured inside itself
    assert beside[0].cpu >= beside[0].result["cpu"] * 0.9


def failing_stage(ctx: DemoContext) -> tuple[dict[str, Any], str]:
    raise ValueError("column 'temp_c' missing in row 7")


def test_a_stage_that_fails_side_by_side_raises_its_own_error(tmp_path: Path) -> None:
    stages = [*_stages()[:1], EntryPoint("20-fail", f"{HERE}:failing_stage", "brakewear.demo")]
    with pytest.raises(ValueError, match="column 'temp_c' missing in row 7"):
        run_stages(_ctx(tmp_path, 2), stages, 2, 3, 4)
