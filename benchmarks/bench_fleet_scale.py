"""Sizing benchmark: what predicting a very large fleet and a large cost study cost
(docs/sizing.md).

Scenario 1, a mine fleet: every pad gets ONE new braking event per shift and an estimate at
it. For each predictor and fleet size ``n`` (``--sizes``):

- per-slot state: the ``nbytes`` of the fleet's arrays whose first axis is the slot (found
  on the fleet and on its non-predictor, non-dataclass attributes), divided by ``n``; and,
  as a cross-check, what tracemalloc saw building the fleet, divided by ``n``;
- the CPU time of one ``Fleet.update`` of ``n`` pads with one event each (an estimate at
  every row), the median over ``--rounds`` successive shifts, and the peak memory that call
  allocated (tracemalloc, one more shift); events/s next to the simulator's in this run.

Pads carry real state: ``TEMPLATES`` pads of the study's regime are fed their whole history
up to an age drawn uniformly in their life (one fleet update), and slot ``i`` of a fleet of
``n`` starts as a copy of template ``i % TEMPLATES`` (its slot arrays' rows).

Scenario 2, the cost study: ``--pads`` pad lives of the default ``brakewear compare`` regime
through ``agents.study.pads.collect_pads`` (simulation and each predictor's fleet over the
life, estimates at the decision points), label by label; CPU seconds per pad life by stage
(``collect_pads``' own stage clock read as CPU time) and the pickled bytes of the result.

Both are extrapolated (``--fleet`` pads per shift of ``--shift-hours``; ``--study`` pad
lives on ``--cores``), and the pickled sizes of what a Ray run puts in its object store
are printed. BLAS runs one thread (set below, before numpy loads): figures are per core.

Run: ``.venv/bin/python benchmarks/bench_fleet_scale.py [--sizes 1000,10000,100000]
[--pads 48] [--json out.json]``.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse
import dataclasses
import heapq
import math
import pickle
import platform
import resource
import time
import tracemalloc
from pathlib import Path
from types import SimpleNamespace
from typing import Any
from unittest import mock

import numpy as np

from agents.study import pads as pad_study
from agents.study.config import StudyConfig
from agents.study.pads import GROUP, PadDraws, collect_pads
from brake_env.data.datasets import measure
from brake_env.env.config import EnvConfig
from brake_env.model.atlas import Atlas, cached_atlas
from brake_env.model.simulator import simulate_runs
from brake_env.output import table, write_json
from brake_env.prognostics.fleet import Fleet, take_events
from brake_env.prognostics.protocol import MEASURED, EventBatch, Predictor
from brake_env.prognostics.registry import fit_predictors

TEMPLATES = 32  # warmed pads whose state the slots of a big fleet copy
SOURCES_PER_LABEL = 4  # simulated lives per wear-regime label the events come from
CHUNK_PADS = 48  # pads per study task (agents.workers.CHUNK_PADS)
MIB = 2.0**20
OVERHEAD_MAX_PADS = 10_000  # per-call overhead from calls this small (larger ones page-fault)


@dataclasses.dataclass
class Sources:
    """Simulated lives, concatenated: rows ``offsets[i]:offsets[i] + lives[i]``."""

    events: EventBatch
    offsets: np.ndarray
    lives: np.ndarray
    sim_events_per_s: float  # simulate_runs, GROUP pads per call, per CPU second


def simulate_sources(atlas: Atlas, env: EnvConfig, seed: int) -> Sources:
    """Lives of the study's regime with measured channels; times the simulator (CPU)."""
    draws = PadDraws.stratified(env.pad_regime, SOURCES_PER_LABEL, [seed, 5])
    seeds = [np.random.SeedSequence(int(e)).spawn(2) for e in draws.entropy]
    trajectories, cpu = [], 0.0
    for g in range(0, len(draws), GROUP):
        sl = slice(g, g + GROUP)
        t0 = time.process_time()
        trajectories += simulate_runs(
            atlas, draws.wear_coeff[sl], [s[0] for s in seeds[sl]], None, env.interpolate_layers
        )
        cpu += time.process_time() - t0
    lives = np.array([t.n_events for t in trajectories], dtype=np.int64)
    cols: dict[str, list[np.ndarray]] = {c: [] for c in MEASURED}
    for t, s in zip(trajectories, seeds, strict=True):
        for c, x in measure(t, env.noise, np.random.default_rng(s[1])).items():
            cols[c].append(x)
    event = np.concatenate([np.arange(n, dtype=np.int64) for n in lives])
    events = EventBatch(event, *(np.concatenate(cols[c]) for c in MEASURED))
    offsets = np.r_[0, np.cumsum(lives)[:-1]].astype(np.int64)
    return Sources(events, offsets, lives, float(lives.sum()) / cpu)


def slot_arrays(obj: object, n: int, depth: int = 2, path: str = "") -> dict[str, np.ndarray]:
    """The arrays of ``obj`` (and of its helper objects) whose first axis is the slot."""
    out: dict[str, np.ndarray] = {}
    for k, v in vars(obj).items():
        if isinstance(v, np.ndarray) and v.ndim and v.shape[0] == n:
            out[path + k] = v
        elif (
            depth
            and hasattr(v, "__dict__")
            and not isinstance(v, Predictor | type)
            and not dataclasses.is_dataclass(v)
        ):
            out.update(slot_arrays(v, n, depth - 1, f"{path}{k}."))
    return out


def warm_templates(predictor: Predictor, src: Sources, rng: np.random.Generator) -> Any:
    """A fleet of ``TEMPLATES`` pads, each fed its life up to an age drawn uniformly in it
    (leaving room for the timed shifts); its source life and age."""
    which = np.arange(TEMPLATES) % len(src.lives)
    age = rng.integers(1, src.lives[which] - 64)
    fleet: Fleet = predictor.fleet(TEMPLATES)
    fleet.reset(np.arange(TEMPLATES))
    rows = np.concatenate([np.arange(a) + src.offsets[w] for w, a in zip(which, age, strict=True)])
    pads = np.repeat(np.arange(TEMPLATES, dtype=np.intp), age)
    fleet.update(pads, take_events(src.events, rows))
    return SimpleNamespace(fleet=fleet, which=which, age=age)


def big_fleet(predictor: Predictor, tmpl: Any, n: int) -> tuple[Fleet, int, int]:
    """A fleet of ``n`` slots, slot ``i`` a copy of template ``i % TEMPLATES``; its slot
    arrays' bytes and what tracemalloc saw building it (before the copy)."""
    tracemalloc.start()
    fleet: Fleet = predictor.fleet(n)
    built = tracemalloc.get_traced_memory()[0]
    tracemalloc.stop()
    mine, theirs = slot_arrays(fleet, n), slot_arrays(tmpl.fleet, TEMPLATES)
    if set(mine) != set(theirs):
        raise RuntimeError(f"slot arrays differ: {sorted(mine)} vs {sorted(theirs)}")
    idx = np.arange(n) % TEMPLATES
    for k, a in mine.items():
        np.take(theirs[k], idx, axis=0, out=a, mode="clip")  # "raise" would buffer a copy
    return fleet, sum(a.nbytes for a in mine.values()), built


def shift_batch(src: Sources, tmpl: Any, n: int, shift: int) -> EventBatch:
    """Each slot's next event: the event after its template's age, ``shift`` shifts on."""
    t = np.arange(n) % TEMPLATES
    return take_events(src.events, src.offsets[tmpl.which[t]] + tmpl.age[t] + shift)


def time_shifts(
    fleet: Fleet, src: Sources, tmpl: Any, n: int, args: argparse.Namespace
) -> dict[str, Any]:
    """CPU seconds of ``--rounds`` shifts (every pad one event, in calls of at most
    ``--chunk`` pads), then one more under tracemalloc for the peak memory a call allocates
    beyond the state."""
    pads = np.arange(n, dtype=np.intp)
    step = min(n, args.chunk or n)
    cpu, sys = [], []
    for r in range(args.rounds + 1):
        batch = shift_batch(src, tmpl, n, r)
        if r == args.rounds:
            tracemalloc.start()
        t0, s0 = time.process_time(), resource.getrusage(resource.RUSAGE_SELF).ru_stime
        for a in range(0, n, step):
            est = fleet.update(pads[a : a + step], batch[a : a + step])
            if not np.isfinite(est.rul_mean).all():
                raise RuntimeError(f"estimates of pads {a}..{a + step - 1} not all finite")
        cpu.append(time.process_time() - t0)
        sys.append(resource.getrusage(resource.RUSAGE_SELF).ru_stime - s0)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    times = np.array(cpu[: args.rounds])
    return {
        "call_pads": step,
        "cpu_s_median": float(np.median(times)),
        "cpu_s_min": float(times.min()),
        "sys_share": float(sum(sys[: args.rounds]) / max(times.sum(), 1e-12)),
        "update_peak_bytes": int(peak),
    }


def probe_bytes(predictor: Predictor, src: Sources, tmpl: Any) -> tuple[float, float]:
    """Bytes per pad of the state and of a call, from a fresh fleet of ``TEMPLATES`` pads
    (an overestimate of a call's: fixed costs spread over few pads), for the memory guard
    before the first size is built."""
    fleet: Fleet = predictor.fleet(TEMPLATES)
    fleet.reset(np.arange(TEMPLATES))
    batch = shift_batch(src, tmpl, TEMPLATES, 0)
    tracemalloc.start()
    fleet.update(np.arange(TEMPLATES, dtype=np.intp), batch)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    nbytes = sum(a.nbytes for a in slot_arrays(fleet, TEMPLATES).values())
    return nbytes / TEMPLATES, peak / TEMPLATES


def fleet_scale(
    name: str, predictor: Predictor, src: Sources, args: argparse.Namespace
) -> dict[str, Any]:
    """Scenario 1 for one predictor at every size that fits in ``--max-gib``."""
    tmpl = warm_templates(predictor, src, np.random.default_rng(args.seed))
    rows: dict[int, dict[str, Any]] = {}
    state, call = probe_bytes(predictor, src, tmpl)
    for n in args.sizes:
        need = state * n + call * min(n, args.chunk or n)
        if need > args.max_gib * 2**30:
            print(f"{name}: {n:,} pads skipped, ~{need / 2**30:.1f} GiB > --max-gib")
            continue
        fleet, nbytes, built = big_fleet(predictor, tmpl, n)
        r = time_shifts(fleet, src, tmpl, n, args)
        del fleet
        r.update(
            state_bytes_per_pad=nbytes / n,
            built_bytes_per_pad=built / n,
            update_peak_bytes_per_pad=r["update_peak_bytes"] / r["call_pads"],
            events_per_s=n / r["cpu_s_median"],
            ratio_to_simulator=n / r["cpu_s_median"] / src.sim_events_per_s,
        )
        state, call = r["state_bytes_per_pad"], r["update_peak_bytes_per_pad"]
        rows[n] = r
    out: dict[str, Any] = {"sizes": {str(n): r for n, r in rows.items()}}
    one = [n for n, r in rows.items() if r["call_pads"] == n][:2]  # smallest, one call each
    if len(one) == 2 and one[1] <= OVERHEAD_MAX_PADS:  # cpu = overhead + per_pad * n
        (n1, n2), (t1, t2) = one, [rows[n]["cpu_s_median"] for n in one]
        out["call_overhead_s"] = t1 - n1 * (t2 - t1) / (n2 - n1)
    return out


def extrapolate_fleet(fig: dict[str, Any], sim: float, args: argparse.Namespace) -> dict[str, Any]:
    """One shift of ``--fleet`` pads, scaled from the largest fleet measured (in its calls)."""
    sizes = fig["sizes"]
    n = max(int(k) for k in sizes)
    r = sizes[str(n)]
    cpu = args.fleet / n * r["cpu_s_median"]
    return {
        "pads": args.fleet,
        "measured_pads": n,
        "calls_of": r["call_pads"],
        "calls": math.ceil(args.fleet / r["call_pads"]),
        "cpu_s_per_shift": cpu,
        "core_fraction": cpu / (args.shift_hours * 3600.0),
        "state_gib": r["state_bytes_per_pad"] * args.fleet / 2**30,
        "update_peak_gib": r["update_peak_bytes"] / 2**30,
        "simulator_s_same_events": args.fleet / sim,
    }


def study_cost(
    atlas: Atlas, env: EnvConfig, predictors: dict[str, Predictor], args: argparse.Namespace
) -> dict[str, Any]:
    """Scenario 2: ``--pads`` lives through ``collect_pads``, label by label, CPU clocked."""
    n_labels = len(pad_study.regime_weights(env.pad_regime))
    draws = PadDraws.stratified(env.pad_regime, max(1, args.pads // n_labels), [args.seed, 2])
    cpu_clock = SimpleNamespace(perf_counter=time.process_time)  # its stage clock, as CPU
    labels: dict[str, dict[str, Any]] = {}
    for label in draws.weights:
        sub = draws.subset(np.flatnonzero(draws.label == label))
        w0, c0 = time.perf_counter(), time.process_time()
        with mock.patch.object(pad_study, "time", cpu_clock):
            ps = collect_pads(sub, atlas, env, predictors)
        cpu, wall = time.process_time() - c0, time.perf_counter() - w0
        labels[label] = {
            "pads": len(sub),
            "cpu_s": cpu,
            "wall_s": wall,
            "stage_cpu_s": dict(ps.seconds),
            "events": int(ps.life.sum()),
            "decisions": int(ps.starts[-1]),
            "result_bytes": len(pickle.dumps(ps, protocol=5)),
        }
    pads = sum(v["pads"] for v in labels.values())
    per_pad = {k: v["cpu_s"] / v["pads"] for k, v in labels.items()}
    stages = {
        s: sum(v["stage_cpu_s"][s] for v in labels.values()) / pads
        for s in next(iter(labels.values()))["stage_cpu_s"]
    }
    return {
        "pads": pads,
        "labels": labels,
        "cpu_s_per_pad_by_label": per_pad,
        "cpu_s_per_pad": sum(v["cpu_s"] for v in labels.values()) / pads,
        "stage_cpu_s_per_pad": stages,
        "events_per_pad": sum(v["events"] for v in labels.values()) / pads,
        "result_bytes_per_pad": sum(v["result_bytes"] for v in labels.values()) / pads,
    }


def extrapolate_study(fig: dict[str, Any], args: argparse.Namespace) -> dict[str, Any]:
    """``--study`` lives, equal numbers per label as the study draws them, in tasks of
    ``CHUNK_PADS`` pads in label order (``agents.workers``), each costing its pads' CPU
    time as measured; wall time on N cores by handing tasks in order to the first free
    core, cores not slowing each other (linear scaling)."""
    per_label = fig["cpu_s_per_pad_by_label"]
    n_each = [c.size for c in np.array_split(np.arange(args.study), len(per_label))]
    label_of = np.repeat(np.arange(len(per_label)), n_each)
    cost = np.array(list(per_label.values()))[label_of]
    chunks = [float(c.sum()) for c in np.array_split(cost, math.ceil(cost.size / CHUNK_PADS))]
    wall = {}
    for n_cores in args.cores:
        free = [0.0] * n_cores
        for c in chunks:
            heapq.heappush(free, heapq.heappop(free) + c)
        wall[str(n_cores)] = max(free)
    return {
        "lives": int(cost.size),
        "core_hours": float(cost.sum()) / 3600.0,
        "tasks": len(chunks),
        "task_cpu_s": [min(chunks), max(chunks)],
        "result_gib": fig["result_bytes_per_pad"] * cost.size / 2**30,
        "wall_h_by_cores": {k: v / 3600.0 for k, v in wall.items()},
    }


def object_store(atlas_loaded: int, atlas: Atlas, fitted: dict[str, Predictor]) -> dict[str, int]:
    """Pickled bytes (protocol 5) of what a Ray run would put once."""
    out = {"atlas_as_loaded": atlas_loaded, "atlas_with_lookup": len(pickle.dumps(atlas, 5))}
    for k, p in fitted.items():
        out[f"predictor_{k}"] = len(pickle.dumps(p, 5))
    out["all_predictors_one_object"] = len(pickle.dumps(fitted, 5))
    out["atlas_and_all_predictors_one_object"] = len(pickle.dumps((atlas, fitted), 5))
    return out


def fleet_tables(figs: dict[str, Any], ext: dict[str, Any], sim: float) -> str:
    rows = [
        [
            "predictor",
            "pads",
            "pads/call",
            "state B/pad",
            "built B/pad",
            "call peak B/pad",
            "CPU ms/shift",
            "us/pad",
            "marginal us/pad",
            "sys %",
            "events/s",
            "x simulator",
        ]
    ]
    for name, f in figs.items():
        prev = None
        for n, r in f["sizes"].items():
            t, n = r["cpu_s_median"], int(n)
            marginal = "" if prev is None else f"{(t - prev[1]) / (n - prev[0]) * 1e6:.3f}"
            prev = (n, t)
            rows.append(
                [
                    name,
                    f"{n:,}",
                    f"{r['call_pads']:,}",
                    f"{r['state_bytes_per_pad']:,.1f}",
                    f"{r['built_bytes_per_pad']:,.1f}",
                    f"{r['update_peak_bytes_per_pad']:,.0f}",
                    f"{t * 1e3:,.2f}",
                    f"{t / n * 1e6:.3f}",
                    marginal,
                    f"{r['sys_share'] * 100:.0f}",
                    f"{r['events_per_s']:,.0f}",
                    f"{r['ratio_to_simulator']:.4f}",
                ]
            )
        if "call_overhead_s" in f:
            rows.append(
                [
                    name,
                    "overhead",
                    "",
                    "",
                    "",
                    "",
                    f"{f['call_overhead_s'] * 1e3:.2f}",
                    "",
                    "",
                    "",
                    "",
                    "",
                ]
            )
    e: dict[str, Any] = next(iter(ext.values()), {})
    head = f"CPU s/shift of {e.get('pads', 0):,} pads"
    rows_e = [
        [
            "predictor",
            "calls x pads",
            head,
            "fraction of 1 core",
            "state GiB",
            "call peak GiB",
            "simulator s, same events",
        ]
    ]
    for name, x in ext.items():
        rows_e.append(
            [
                name,
                f"{x['calls']:,} x {x['calls_of']:,}",
                f"{x['cpu_s_per_shift']:.2f}",
                f"{x['core_fraction']:.2e}",
                f"{x['state_gib']:.3f}",
                f"{x['update_peak_gib']:.3f}",
                f"{x['simulator_s_same_events']:.3f}",
            ]
        )
    tail = f"\nsimulator: {sim:,.0f} events/s (simulate_runs, {GROUP} pads per call, CPU)"
    return table(rows) + "\n\n" + table(rows_e) + tail


def study_tables(fig: dict[str, Any], ext: dict[str, Any]) -> str:
    stages = list(fig["stage_cpu_s_per_pad"])
    rows = [["label", "pads", "events/pad", "CPU s/pad", *(f"{s} s/pad" for s in stages), "wall s"]]
    for label, v in fig["labels"].items():
        rows.append(
            [
                label,
                str(v["pads"]),
                f"{v['events'] / v['pads']:,.0f}",
                f"{v['cpu_s'] / v['pads']:.3f}",
                *(f"{v['stage_cpu_s'][s] / v['pads']:.3f}" for s in stages),
                f"{v['wall_s']:.1f}",
            ]
        )
    rows.append(
        [
            "all",
            str(fig["pads"]),
            f"{fig['events_per_pad']:,.0f}",
            f"{fig['cpu_s_per_pad']:.3f}",
            *(f"{fig['stage_cpu_s_per_pad'][s]:.3f}" for s in stages),
            "",
        ]
    )
    rows_e = [
        [
            "lives",
            "core-hours",
            "tasks",
            "task CPU s (min, max)",
            "results GiB",
            *(f"wall h, {c} cores" for c in ext["wall_h_by_cores"]),
        ]
    ]
    lo, hi = ext["task_cpu_s"]
    rows_e.append(
        [
            f"{ext['lives']:,}",
            f"{ext['core_hours']:.1f}",
            f"{ext['tasks']:,}",
            f"{lo:.0f}, {hi:.0f}",
            f"{ext['result_gib']:.2f}",
            *(f"{h:.2f}" for h in ext["wall_h_by_cores"].values()),
        ]
    )
    return table(rows) + "\n\n" + table(rows_e)


def ints(text: str) -> list[int]:
    return [int(float(x)) for x in text.split(",") if x]


def parse_args() -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=ints, default=[100, 1000, 10000, 100000], help="fleet sizes")
    ap.add_argument("--pads", type=int, default=48, help="study pad lives measured (0: none)")
    ap.add_argument("--predictors", default="twin,physics,data,window", help="scenario 1")
    ap.add_argument("--rounds", type=int, default=5, help="shifts timed per fleet size")
    ap.add_argument("--fleet", type=int, default=10**6, help="pads per shift, extrapolated")
    ap.add_argument("--shift-hours", type=float, default=8.0)
    ap.add_argument("--study", type=int, default=10**5, help="pad lives, extrapolated")
    ap.add_argument("--cores", type=ints, default=[1, 2, 8, 32, 128], help="for the study")
    ap.add_argument("--chunk", type=int, default=0, help="pads per update call (0: all)")
    ap.add_argument("--max-gib", type=float, default=6.0, help="skip fleets needing more")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", default=None, help="also write the figures to this JSON file")
    args = ap.parse_args()
    args.sizes = sorted(args.sizes)
    args.predictors = tuple(p for p in args.predictors.split(",") if p)
    if min(args.sizes) <= TEMPLATES or args.pads < 0 or args.rounds < 1 or args.chunk < 0:
        ap.error(f"sizes must be > {TEMPLATES}, --rounds >= 1, --pads and --chunk >= 0")
    return args


def main() -> dict[str, Any]:
    args = parse_args()
    atlas = cached_atlas()
    atlas_loaded = len(pickle.dumps(atlas, 5))  # before anything builds its lookup
    cfg = StudyConfig()
    env = cfg.env
    names = tuple(dict.fromkeys((*args.predictors, *(cfg.predictors if args.pads else ()))))
    fitted, fit_s = fit_predictors(names, atlas, args.seed, cfg.n_train_runs, cfg.wear)
    src = simulate_sources(atlas, env, args.seed)
    sim = src.sim_events_per_s
    fig: dict[str, Any] = {"simulator_events_per_s": sim, "fit_wall_s": fit_s}
    print(
        f"machine: {platform.processor() or platform.machine()}, numpy {np.__version__},"
        f" {os.cpu_count()} cores; BLAS threads {os.environ['OPENBLAS_NUM_THREADS']}"
    )
    print(f"fit (wall s, one-off): {', '.join(f'{k} {v:.1f}' for k, v in fit_s.items())}")
    if args.predictors:
        figs = {name: fleet_scale(name, fitted[name], src, args) for name in args.predictors}
        ext = {name: extrapolate_fleet(f, sim, args) for name, f in figs.items() if f["sizes"]}
        fig.update(fleet=figs, fleet_extrapolated=ext)
        print(
            f"\nScenario 1: one event per pad per shift; sources {len(src.lives)} lives,"
            f" {TEMPLATES} warmed templates, median of {args.rounds} shifts (CPU)\n"
        )
        print(fleet_tables(figs, ext, sim))
    if args.pads:
        study = study_cost(atlas, env, {n: fitted[n] for n in cfg.predictors}, args)
        fig.update(study=study, study_extrapolated=extrapolate_study(study, args))
        print(
            f"\nScenario 2: cost-study pad lives ({cfg.env.regime} regime, decision interval"
            f" {cfg.decision_interval}), CPU\n"
        )
        print(study_tables(study, fig["study_extrapolated"]))
    fig["object_store_bytes"] = store = object_store(atlas_loaded, atlas, fitted)
    print("\nObject store (pickled MiB, protocol 5):")
    print(table([["object", "MiB"], *([k, f"{v / MIB:.2f}"] for k, v in store.items())]))
    fig["peak_rss_gib"] = rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
    print(f"\nprocess peak RSS: {rss:.2f} GiB")
    fig["args"] = vars(args)
    if args.json:
        write_json(fig, Path(args.json))
    return fig


if __name__ == "__main__":
    main()
