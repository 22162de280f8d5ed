"""The ``make demo`` stage of sim2real (entry point ``brakewear.demo`` ``50-diagnose``): one
withheld-effect diagnosis."""

from __future__ import annotations

import time
from typing import Any

from brake_env.cli.demo import DemoContext
from brake_env.data.datasets import DatasetSpec
from brake_env.data.schema import write_event_log
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime
from sim2real.diagnosis.diagnose import diagnose
from sim2real.diagnosis.rul import rul_scorer
from sim2real.effects.interface import Effect
from sim2real.effects.library import parse_effect, registry
from sim2real.effects.truth import TruthSpec, simulate_truth
from sim2real.validation.report import write_outputs

# The demo's budget: this many short truth runs (fast wear, K 2e-5) are diagnosed, against
# these candidate effects (None: the whole library).
DEMO_RUNS = 6
DEMO_CANDIDATES: tuple[str, ...] | None = None


def demo_stage(ctx: DemoContext) -> tuple[dict[str, Any], str]:
    """One withheld-effect case: truth logs with speed-dependent friction, diagnosed."""
    out = ctx.out / "sim2real"
    atlas = Atlas.load(ctx.atlas_file)
    effect = parse_effect("speed_friction:a=0.2")
    ds = DatasetSpec(
        n_train=DEMO_RUNS, n_id=0, n_ood_slow=0, n_ood_fast=0, wear=WearRegime(2e-5, 2e-6)
    )
    t0 = time.perf_counter()
    logs = simulate_truth(atlas.spec, [effect], TruthSpec(ds), seed=ctx.args.seed)
    write_event_log(logs["train"], out / "real.parquet")
    candidates = None if DEMO_CANDIDATES is None else [registry()[n] for n in DEMO_CANDIDATES]
    res = diagnose(logs["train"], atlas, candidates, seed=ctx.args.seed, rul=rul_scorer(atlas))
    seconds = time.perf_counter() - t0
    text = write_outputs(res, out, {"seconds": seconds, "withheld_effect": effect.key})
    print(f"withheld effect: {effect.key}\n{text}\n({seconds:.1f} s)")
    md = (
        f"## Sim-to-real gap diagnosis (withheld effect: `{effect.key}`)\n\n"
        f"{DEMO_RUNS} short truth runs ({len(logs['train'])} events), {seconds:.0f} s."
        f" Verdict: **{res.verdict}**.{_against_truth(res.summary, effect)}\n\n```\n{text}\n```\n\n"
        "![residual maps](sim2real/figures/residual_maps.png)\n"
        "![before/after](sim2real/figures/before_after.png)\n"
    )
    return res.summary, md


def _against_truth(summary: dict[str, Any], effect: Effect) -> str:
    """The fitted parameter against the withheld truth, said plainly when its interval misses
    it (few calibration runs: the interval is their disagreement, not the model's error)."""
    fit = summary["attribution"]["parameter"]
    if summary["attribution"]["winner"] is None or fit is None:
        return ""
    if not summary["attribution"]["winner"].startswith(effect.name + ":"):
        return f" The withheld effect is `{effect.name}`; the winner is another."
    truth = effect.values[fit["name"]]
    lo, hi = fit["interval"]
    said = (
        f" Fitted {fit['name']} = {fit['value']:.4g}, {fit['level']:.0%} interval"
        f" [{lo:.4g}, {hi:.4g}] (bootstrap over {fit['calibration_runs']} calibration runs);"
        f" the truth is {truth:g}"
    )
    if lo <= truth <= hi:
        return said + ", inside it."
    return (
        said + f": **the interval does not include the truth.** With"
        f" {fit['calibration_runs']} calibration runs the interval says only how much those"
        " runs disagree on the value, not how far the replay model's estimate may be from"
        " the truth; it is too narrow at this budget."
    )
