"""``brakewear evaluate --seeds``: the evaluation once per seed, each seed a unit of work in
this process or on Ray (``--workers``, ``--ray``; docs/cluster.md), saved
under ``OUT/units/`` as it finishes so that an interrupted run (or a rerun with more seeds)
redoes only the seeds not saved yet.

Writes ``OUT/seed-S/`` for each seed as a single ``--seed`` writes ``OUT/`` (``metrics.json``,
``table.md``, the MLP's weights; the figures with ``--seed-figures``), then ``OUT/seeds.json``
(per predictor, split and headline metric: mean, sample standard deviation, min, max and
each seed's value) and ``OUT/seeds.md``, and prints the tables.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path
from typing import Any

import pandas as pd
from tqdm import tqdm

from brake_env.cli.common import load_atlas, make_runner
from brake_env.cli.simulate import dataset_spec
from brake_env.data.datasets import DatasetSpec, find_logs
from brake_env.data.schema import read_event_log
from brake_env.model.atlas import Atlas
from brake_env.output import sha256_file, write_json, write_text
from brake_env.prognostics import seeds as sd
from brake_env.prognostics.commands.outputs import (
    check_data_atlas,
    simulation_options,
    write_evaluation,
)
from brake_env.prognostics.persist import package_version
from brake_env.runner import Unit, UnitsFailed
from brake_env.units import UnitStore, open_store

RESULT_FORMAT = 1  # layout of a seed's result; a store of another layout is refused


def _data(
    args: argparse.Namespace,
) -> tuple[dict[str, pd.DataFrame] | None, dict[str, Any], DatasetSpec | None]:
    """(the shared logs or None, what the data is for the store and seeds.json, the spec
    each seed simulates or None)."""
    if not args.data:
        spec = dataset_spec(args)
        return None, {"simulated": dataclasses.asdict(spec)}, spec
    changed = simulation_options(args)
    if changed:
        opts = ", ".join("--" + k.replace("_", "-") for k in changed)
        raise ValueError(f"{opts}: the simulated dataset's options; --data gives the data")
    paths = find_logs(args.data)
    logs = {split: read_event_log(p) for split, p in paths.items()}
    info = {
        "data_dir": str(Path(args.data)),
        "sha256": {s: sha256_file(p) for s, p in paths.items()},
    }
    return logs, info, None


def cmd_evaluate_seeds(args: argparse.Namespace) -> dict[str, Any]:
    """``brakewear evaluate --seeds S ...``; returns the contents of ``seeds.json``."""
    t_start = time.perf_counter()
    seeds = sd.check_seeds(args.seeds)
    out = Path(args.out)
    logs, data, spec = _data(args)
    atlas = load_atlas(args)
    if args.data:
        check_data_atlas(Path(args.data), atlas.content_hash)
    plan = sd.SeedPlan(tuple(args.predictors), args.batch_events, args.mlp_epochs, spec)
    settings = {
        "command": "evaluate --seeds",
        "data": data,
        "atlas_hash": atlas.content_hash,
        "predictors": list(plan.predictors),
        "batch_events": plan.batch_events,
        "mlp_epochs": plan.mlp_epochs,
        "package_version": package_version(),
        "result_format": RESULT_FORMAT,
    }
    # the seeds are the units' keys, not settings
    store = open_store(out / "units", settings, [f"seed-{s}" for s in seeds], "evaluate")
    results = _run_seeds(args, atlas, logs, seeds, plan, store)
    for s in seeds:
        _write_seed(results[s], out / f"seed-{s}", atlas, args, s)
    doc: dict[str, Any] = {
        "seeds": seeds,
        "data": data,
        "atlas_hash": atlas.content_hash,
        "predictors": list(plan.predictors),
        "spread": f"mean, sample sd, min and max over the {len(seeds)} seeds",
        "metrics": sd.aggregate({s: results[s]["metrics"] for s in seeds}),
        "per_seed": {str(s): f"seed-{s}/metrics.json" for s in seeds},
        "timing_s": {
            "seeds": {str(s): results[s]["timing_s"]["total"] for s in seeds},
            "total": time.perf_counter() - t_start,
        },
    }
    write_json(doc, out / "seeds.json")
    write_text(_markdown(doc) + "\n", out / "seeds.md")
    print(f"RUL RMSE [events] over seeds {', '.join(map(str, seeds))}\n")
    print(sd.rmse_seeds_table(doc))
    print("\nmean [min, max] over the seeds\n")
    print(sd.other_seeds_table(doc))
    print(
        f"\n{len(seeds)} seeds in {doc['timing_s']['total']:.1f} s; wrote {out}/seeds.json,"
        f" seeds.md, seed-{{{','.join(map(str, seeds))}}}/"
    )
    return doc


def _run_seeds(
    args: argparse.Namespace,
    atlas: Atlas,
    logs: dict[str, pd.DataFrame] | None,
    seeds: list[int],
    plan: sd.SeedPlan,
    store: UnitStore,
) -> dict[int, dict[str, Any]]:
    """Every seed's unit result (read back from ``store`` when saved there)."""
    with (
        make_runner(args) as runner,
        tqdm(total=len(seeds), desc="seeds", unit="seed", disable=args.quiet) as bar,
    ):
        shared = (runner.share(atlas), None if logs is None else runner.share(logs))
        units = [Unit(f"seed-{s}", sd.evaluate_seed, (*shared, s, plan)) for s in seeds]
        try:
            done = runner.run(units, store, lambda _k, _r: bar.update())
        except UnitsFailed as e:
            raise ValueError(
                f"{e}\nthe other seeds are saved in {store.directory}; run the same command"
                " again to redo only the failed ones"
            ) from e
    return {s: done[f"seed-{s}"] for s in seeds}


def _write_seed(
    result: dict[str, Any], out: Path, atlas: Atlas, args: argparse.Namespace, seed: int
) -> None:
    """``out`` as a single-seed evaluate writes it, from the seed's unit result."""
    ev = sd.evaluation_of(result)
    saved = {n: sd.saved_predictor(result, n, atlas, seed) for n in result["models"]}
    data: dict[str, Any] = {"data_dir": str(Path(args.data)) if args.data else None}
    if not args.data:
        data["simulated"] = dataclasses.asdict(dataset_spec(args))
    data["seed"] = seed
    timing = result["timing_s"]
    write_evaluation(
        ev, out, saved, atlas, data, skipped={}, timing=timing, figures=args.seed_figures
    )


def _markdown(doc: dict[str, Any]) -> str:
    seeds = ", ".join(map(str, doc["seeds"]))
    return (
        f"RUL RMSE per predictor and split [braking events] over seeds {seeds}: mean, sample"
        " standard deviation, min, max and each seed's mean over runs\n\n"
        + sd.rmse_seeds_table(doc, markdown=True)
        + f"\n\nOther headline metrics (means over runs): mean [min, max] over seeds {seeds}."
        " RMSE / life, convergence event at 10% tolerance as a fraction of life (1 = never),"
        " relative accuracy and alpha-lambda at half life, prognostic horizon (fraction of"
        " life), PHM08 score, mean relative K error, interval coverage\n\n"
        + sd.other_seeds_table(doc, markdown=True)
    )
