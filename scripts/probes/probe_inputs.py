"""The probe's areas for the rest of issue 44 (scripts/probes/probe_trust.py runs them after its
own; docs/schema.md, "Probe of bad inputs"): units keyed to the settings that made them,
every numeric input of the Lagrangian bound, the rollout planner, the price-directed policy,
the route RUL's volumes, the fleet commands' parser, ``--atlas``, fleet-distil's study
``costs.json``, the reports' ratios, and the library's other edges (a store's settings file,
its lock, the fleet env's config, ``--out`` links, a miscounting predictor).

Each builder takes the probe's world and the probe module itself (``pt``: its
:class:`Case`, :class:`Check`, :func:`equals`, :func:`cli`, ...), so that this module
imports nothing of the script that runs it.
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import io
import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from agents.fleet.policies.lagrangian import BoundModel, Prices, bound, solve, start_counts
from agents.fleet.policies.lagrangian_search import search
from agents.fleet.policies.planning import PlanningModel
from agents.fleet.policies.priced import PricedPolicy
from agents.fleet.policies.rollout import RolloutPolicy
from agents.fleet.policies.rules import FleetRule, FleetRuleParams
from agents.fleet.policies.view import FleetLayout
from brake_env import units
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.route_rul import duty_clocks
from brake_env.env.fleet.shop import HOT
from brake_env.env.fleet.spaces import FLEET_FEATURES, N_VF
from brake_env.env.fleet.wrappers import ExpectedRULObservation, FleetRULObservation
from brake_env.output import OUTPUT_MARK
from brake_env.prognostics.duty import route_rul
from brake_env.prognostics.events import RULEstimate

NAN, INF = float("nan"), float("inf")
RULE = FleetRuleParams(must=3, window_limit=20, shop_limit=15, greedy=True, duty="rul")


def _errors(
    pt: Any, area: str, table: list[tuple[str, Callable[[], Any], tuple[str, ...]]]
) -> list[Any]:
    return [pt.Case(area, name, "error", run, None, names) for name, run, names in table]


# ------------------------------------------------------------------- keyed units
def keyed_unit_cases(w: Any, pt: Any) -> list[Any]:
    """Units made under other settings (copied, or kept under an edited settings.json), of
    the older unkeyed format, or edited with the plain checksum recomputed: each set aside
    (kept in damaged/) and redone, the answer a clean run's."""
    keys = ["pads-0000", "pads-0001", "pads-0002"]
    n = iter(range(1000))

    def result(shift: int) -> dict[str, Any]:
        return {"life": np.arange(5) + shift, "note": f"shift {shift}"}

    def filled(shift: int) -> Path:
        d = w.tmp / f"keyed-{next(n)}"
        with units.open_store(d, {"shift": shift}, keys, "probe") as st:
            for k in keys:
                st.save(k, result(shift))
        return d

    def rerun(d: Path) -> dict[str, Any]:
        with units.open_store(d, {"shift": 0}, keys, "probe") as st:
            got = {k: st.load(k) for k in keys if k in st}
            for k in keys:
                if k not in got:
                    st.save(k, result(0))
                    got[k] = st.load(k)
            return got

    def scenario(
        edit: Callable[[Path, dict[Path, bytes]], None],
    ) -> tuple[Callable[[], Any], dict[Path, bytes]]:
        files: dict[Path, bytes] = {}

        def run() -> Any:
            d = filled(0)
            edit(d, files)
            return rerun(d)

        return run, files

    def copied(d: Path, files: dict[Path, bytes]) -> None:
        other = filled(1)
        for f in sorted(other.glob("pads-*.json")):
            shutil.copy(f, d / f.name)
            shutil.copy(f.with_suffix(".npz"), d / f.with_suffix(".npz").name)
            files[d / "damaged" / f"{f.stem}.1.json"] = f.read_bytes()

    def settings_edited(d: Path, files: dict[Path, bytes]) -> None:
        other = filled(1)
        shutil.rmtree(d)
        shutil.copytree(other, d)
        s = json.loads((d / units.SETTINGS).read_text())
        (d / units.SETTINGS).write_text(json.dumps({**s, "shift": 0}))
        for f in sorted(d.glob("pads-*.json")):
            files[d / "damaged" / f"{f.stem}.1.json"] = f.read_bytes()

    def plain_recomputed(d: Path, files: dict[Path, bytes]) -> None:
        f = sorted(d.glob("pads-*.json"))[1]
        doc = json.loads(f.read_text())
        doc["result"]["note"] = "edited"
        doc["sha256"] = units._content_digest(doc)
        f.write_text(json.dumps(doc))
        files[d / "damaged" / f"{f.stem}.1.json"] = f.read_bytes()

    def unkeyed(d: Path, files: dict[Path, bytes]) -> None:
        f = sorted(d.glob("pads-*.json"))[0]
        doc = json.loads(f.read_text())
        doc["result"]["note"] = "from elsewhere"
        old = {k: doc[k] for k in ("key", "arrays_sha256", "result")}
        f.write_text(json.dumps({**old, "sha256": units._content_digest(old)}))
        files[d / "damaged" / f"{f.stem}.1.json"] = f.read_bytes()

    clean = {k: result(0) for k in keys}
    ok = pt.equals(clean, "every unit = a clean run's")
    cases = []
    for name, edit in (("units copied from a run with other settings", copied),
                       ("units kept under a hand-edited settings.json", settings_edited),
                       ("an edit with its plain checksum recomputed", plain_recomputed),
                       ("a unit of the older unkeyed format", unkeyed)):  # fmt: skip
        run, files = scenario(edit)
        cases.append(pt.Case("keyed units", name, "correct", run, ok, (), pt.unchanged(files)))
    return cases + _keyed_study_cases(w, pt)


def _keyed_study_cases(w: Any, pt: Any) -> list[Any]:
    """fleet-study folders given another study's units (``--seed 1``, ``--objective net``)
    or a settings.json edited to match: costs.json is the clean study's."""
    atlas = ["--atlas", str(w.atlas_file)]
    want = pt.costs_of(w.tmp / "fleet-lib")
    made: dict[str, Path] = {}

    def study(out: Path, *extra: str) -> int:
        with contextlib.redirect_stderr(io.StringIO()):
            return pt.brakewear(["fleet-study", *pt.TINY_STUDY, "--out", str(out), *atlas,
                                 *extra, "--quiet"])  # fmt: skip

    def other(*extra: str) -> Path:
        if extra not in made:
            made[extra] = w.tmp / f"keyed-study-{len(made)}"
            assert study(made[extra], *extra) == 0
        return made[extra] / "units"

    def copy_in(*extra: str, settings: bool = False) -> Callable[[], Any]:
        def run() -> Any:
            out = w.tmp / f"keyed-into-{'-'.join(extra)}-{settings}"
            if settings:  # the other study's whole store, its settings.json edited to match
                shutil.copytree(other(*extra).parent, out)
                path = out / "units" / units.SETTINGS
                s = json.loads(path.read_text())
                # matching the run's settings whole (the code's digest too)
                path.write_text(json.dumps({**s, "seed": 0, "code": units.code_digest()}))
            else:
                assert study(out) == 0
                for f in other(*extra).glob("*-*.json"):
                    shutil.copy(f, out / "units" / f.name)
                    if f.with_suffix(".npz").is_file():
                        shutil.copy(
                            f.with_suffix(".npz"), out / "units" / f.with_suffix(".npz").name
                        )
            return pt.cli("fleet-study", *pt.TINY_STUDY, "--out", str(out), *atlas,
                          read=lambda: pt.costs_of(out))()  # fmt: skip

        return run

    ok = pt.ran_check("costs.json = the clean study's", lambda got: pt.same(got, want))
    return [
        pt.Case("keyed units", "fleet-study: units copied from a --seed 1 study", "correct",
                copy_in("--seed", "1"), ok),
        pt.Case("keyed units", "fleet-study: units copied from an --objective net study",
                "correct", copy_in("--objective", "net"), ok),
        pt.Case("keyed units", "fleet-study: a --seed 1 store, its settings.json edited",
                "correct", copy_in("--seed", "1", settings=True), ok),
    ]  # fmt: skip


# ---------------------------------------------------------------------- the bound
def bound_cases(w: Any, pt: Any) -> list[Any]:
    cfg = FleetConfig(**pt.FLEET)
    model = BoundModel.build(cfg, w.atlas, units=4)
    z = Prices.zeros(cfg)
    start = start_counts(model, np.array([3, 5]))
    program = solve(model, z)
    ref = bound(model, program, z, start)

    def build(**kw: Any) -> Callable[[], Any]:
        return lambda: BoundModel.build(cfg, w.atlas, **kw)

    def priced(field: str, value: Any) -> Callable[[], Any]:
        def run() -> Any:
            x = getattr(z, field).copy() if value is not None else np.zeros(3)
            if value is not None:
                x[2] = value
            return solve(model, dataclasses.replace(z, **{field: x}))

        return run

    table = [
        *((f"units={u!r}", build(units=u), ("units",)) for u in (1.5, 0, -1, NAN, "4", True)),
        *((f"slack_shifts={s!r}", build(slack_shifts=s), ("slack_shifts",))
          for s in (-5, NAN, INF, "1")),
        ("a 5,000-shift bound at 20 units (~15 GiB)",
         lambda: BoundModel.build(dataclasses.replace(cfg, episode_shifts=5000), w.atlas,
                                  units=20), ("would allocate", "GiB")),
        *((f"prices.{f} NaN", priced(f, NAN), (f"prices.{f}", "nan")) for f in
          ("hot", "work", "bay", "crew")),
        *((f"prices.{f} inf", priced(f, INF), (f"prices.{f}",)) for f in ("hot", "bay")),
        *((f"prices.{f} of 3 shifts", priced(f, None), (f"prices.{f}", "shape")) for f in
          ("hot", "work", "bay", "crew")),
        ("start_counts: a state above the cap",
         lambda: start_counts(model, np.array([1, model.H + 1])), ("states",)),
        ("start_counts: a negative state", lambda: start_counts(model, np.array([-1, 2])),
         ("states",)),
        ("start_counts: a fractional state", lambda: start_counts(model, np.array([1.5, 2.0])),
         ("states",)),
        ("bound: start of another length", lambda: bound(model, program, z, np.ones(3)),
         ("start", "shape")),
        ("bound: a NaN start", lambda: bound(model, program, z, np.where(start > 0, NAN, 0.0)),
         ("start", "nan")),
        ("bound: a negative start", lambda: bound(model, program, z, start - 1.0),
         ("start",)),
        *((f"search {k}={v!r}", (lambda k=k, v=v: search(model, start, **{k: v})), (k,))
          for k, v in (("iterations", -1), ("iterations", 2.5), ("step", NAN), ("step", 0.0))),
    ]  # fmt: skip
    return [*_errors(pt, "bound inputs", table),
        pt.Case("bound inputs", "the bound at zero prices", "correct",
                lambda: bound(model, solve(model, z), z, start), pt.equals(ref, "the same bound")),
        pt.Case("bound inputs", "numpy integer units", "correct",
                lambda: BoundModel.build(cfg, w.atlas, units=np.int64(4)).H,
                pt.equals(model.H, "the same cap")),
        pt.Case("bound inputs", "start_counts of float states that are whole", "correct",
                lambda: start_counts(model, np.array([3.0, 5.0])), pt.equals(start, "")),
    ]  # fmt: skip


# -------------------------------------------------------------------- the planner
def planner_cases(w: Any, pt: Any) -> list[Any]:
    cfg = FleetConfig(**pt.FLEET)
    env = ExpectedRULObservation(BrakeWearFleetEnv(cfg, atlas=w.atlas))
    model = PlanningModel.build(cfg, w.atlas)
    base = FleetRule(FleetLayout.of(cfg), RULE)
    obs, _ = env.reset(seed=0)
    ref = RolloutPolicy(base, model, horizon=3, samples=4, seed=1).act(obs)
    lay = FleetLayout.of(cfg)

    def make(**kw: Any) -> Callable[[], Any]:
        return lambda: RolloutPolicy(base, model, **{"horizon": 3, "samples": 4, **kw})

    def with_rul(vehicle: int, value: float) -> Callable[[], Any]:
        bad = obs.copy()
        bad[lay.n_vehicles * N_VF + len(FLEET_FEATURES) + vehicle * lay.per_vehicle
            + int(lay.column("hot", "rul_mean") or 0)] = value  # fmt: skip
        return lambda: RolloutPolicy(base, model, horizon=3, samples=4).act(bad)

    big = ExpectedRULObservation(BrakeWearFleetEnv(FleetConfig(episode_shifts=6), atlas=w.atlas))
    big_obs, _ = big.reset(seed=0)
    wide = dataclasses.replace(cfg, k_std=cfg.k_mean / 4)
    table = [
        *((f"confidence={v!r}", make(confidence=v), ("confidence",)) for v in (NAN, -1.0, INF)),
        *((f"samples={v!r}", make(samples=v), ("samples",)) for v in (1.5, 0, NAN, 10**7)),
        *((f"horizon={v!r}", make(horizon=v), ("horizon",)) for v in (NAN, 0, 1.5, 10**6)),
        *((f"seed={v!r}", make(seed=v), ("seed",)) for v in (-1, 1.5)),
        *((f"service_below={v!r}", make(service_below=v), ("service_below",)) for v in (NAN, -1.0)),
        ("a million futures of 10,000 shifts", make(samples=10**6, horizon=10**4),
         ("would allocate", "GiB")),
        *((f"a NaN RUL of vehicle {v}", with_rul(v, NAN), (f"vehicle {v}", "nan"))
          for v in (0, 1)),
        ("an infinite RUL", with_rul(1, INF), ("vehicle 1", "inf")),
        ("built for 2 vehicles, a 12-vehicle observation",
         lambda: RolloutPolicy(base, model, horizon=3, samples=4).act(big_obs),
         ("observation",)),
    ]  # fmt: skip
    return [*_errors(pt, "planner inputs", table),
        pt.Case("planner inputs", "a good observation", "correct",
                lambda: RolloutPolicy(base, model, horizon=3, samples=4, seed=1).act(obs),
                pt.equals(ref, "the same action")),
        pt.Case("planner inputs", "a planning model on k_std = k_mean / 4", "correct",
                lambda: bool(np.isfinite(PlanningModel.build(wide, w.atlas).r_mild).all()),
                pt.equals(True, "finite mild-use ratios")),
    ]  # fmt: skip


# ------------------------------------------------------------- the priced policy
def priced_cases(w: Any, pt: Any) -> list[Any]:
    cfg = FleetConfig(**pt.FLEET)
    env = BrakeWearFleetEnv(cfg, atlas=w.atlas)
    model = BoundModel.build(cfg, w.atlas, units=4)
    z = Prices.zeros(cfg)
    program = solve(model, z)

    def make(e: Any = env, **kw: Any) -> Callable[[], Any]:
        return lambda: PricedPolicy(e, model, z, program, **kw)

    def act() -> Any:
        env.reset(seed=0)
        return PricedPolicy(env, model, z, program).predict(np.zeros(1))[0]

    env.reset(seed=0)
    ref = PricedPolicy(env, model, z, program).predict(np.zeros(1))[0]
    big = BrakeWearFleetEnv(FleetConfig(episode_shifts=6), atlas=w.atlas)
    table = [
        ("s > S", make(s=5, S=3), ("s must be", "S=3")),
        ("s = -1", make(s=-1), ("s must be",)),
        ("S = 2.5", make(S=2.5), ("S must be",)),
        *((f"must={v!r}", make(must=v), ("must",)) for v in (NAN, -1.0, INF)),
        *((f"margin={v!r}", make(margin=v), ("margin",)) for v in (NAN, INF)),
        *((f"shop_limit={v!r}", make(shop_limit=v), ("shop_limit",)) for v in (NAN, -1.0)),
        *((f"damping={v!r}", make(damping=v), ("damping",)) for v in (NAN, 2.0, -0.1)),
        ("rank 'x'", make(rank="x"), ("rank",)),
        ("built for 2 vehicles, a 12-vehicle env", make(big), ("another fleet config",)),
    ]
    return [
        *_errors(pt, "priced inputs", table),
        pt.Case(
            "priced inputs",
            "a good policy's first action",
            "correct",
            act,
            pt.equals(ref, "the same action"),
        ),
    ]


# --------------------------------------------------------------------- route RUL
def duty_cases(w: Any, pt: Any) -> list[Any]:
    clocks = duty_clocks(w.atlas, ("hot", "mild"))
    k = np.full(3, 2e-5)
    v = np.array([0.9, 0.7, 0.5])
    rul = clocks.base.rul(v, k)
    done = 0.5 * clocks.base.work_at_volume(v) / k  # not the expected path's ages
    full = route_rul(RULEstimate(rul, volume_frac=v), done, clocks)

    def with_volume(i: int, x: float, n: int = 3) -> Callable[[], Any]:
        vv = np.resize(v.copy(), n)
        vv[i] = x
        return lambda: route_rul(RULEstimate(rul, volume_frac=vv), done, clocks)

    def others(i: int) -> Callable[[], Any]:
        run = with_volume(i, NAN)
        return lambda: np.delete(run().mean, i, axis=0)

    table = [
        *((f"volume_frac {x!r}", with_volume(2, x), ("volume_frac of pad 2", str(x)))
          for x in (5.0, 1.2, -0.1, INF)),
        ("volumes of another length", with_volume(0, 0.5, n=4), ("4 volumes for 3",)),
    ]  # fmt: skip
    return [*_errors(pt, "route RUL", table),
        *(pt.Case("route RUL", f"pad {i}'s NaN volume: the other pads' RUL", "correct",
                  others(i), pt.equals(np.delete(full.mean, i, axis=0), "as without the NaN"))
          for i in range(3)),
        pt.Case("route RUL", "a volume of 1.001 read as fresh", "correct",
                lambda: route_rul(RULEstimate(rul, volume_frac=np.array([1.001, 0.7, 0.5])),
                                  done, clocks).volume[0], pt.equals(1.0, "fresh")),
    ]  # fmt: skip


# -------------------------------------------------------------- the fleet parser
def parser_cases(w: Any, pt: Any) -> list[Any]:
    """Numbers the fleet commands refuse in the parser: ``--out`` never created."""
    n = iter(range(1000))

    def parsed(command: str, *args: str) -> Callable[[], Any]:
        def run() -> Any:
            out = w.tmp / f"parse-{next(n)}"
            got = pt.cli(command, "--out", str(out), *args)()
            if out.exists():  # created, or marked: not refused where it enters
                return pt.Ran(0, got.stderr)
            return got

        return run

    table = [
        ("fleet-study --seed 4294967296", parsed("fleet-study", "--seed", "4294967296")),
        ("fleet-study --seed 2**70", parsed("fleet-study", "--seed", str(2**70))),
        ("fleet-study --seed -1", parsed("fleet-study", "--seed", "-1")),
        ("fleet-study --shifts 100001", parsed("fleet-study", "--shifts", "100001")),
        ("fleet-study --eval-episodes 100001", parsed("fleet-study", "--eval-episodes", "100001")),
        ("fleet-study --rollout-samples 10**7",
         parsed("fleet-study", "--rollout-samples", str(10**7))),
        ("fleet-study --rollout-horizon 100001",
         parsed("fleet-study", "--rollout-horizon", "100001")),
        ("fleet-study --imitation-lr nan", parsed("fleet-study", "--imitation-lr", "nan")),
        ("fleet-distil --seed 4294967296",
         parsed("fleet-distil", "--study", "x", "--seed", "4294967296")),
        ("fleet-distil --label-episodes 1000",
         parsed("fleet-distil", "--study", "x", "--label-episodes", "1000")),
        ("fleet-distil --label-rounds 1000",
         parsed("fleet-distil", "--study", "x", "--label-rounds", "1000")),
        ("fleet-distil --seeds 10001", parsed("fleet-distil", "--study", "x", "--seeds", "10001")),
        ("fleet-distil --imitation-lr inf",
         parsed("fleet-distil", "--study", "x", "--imitation-lr", "inf")),
        ("simulate --seed 4294967296", parsed("simulate", "--seed", "4294967296")),
    ]  # fmt: skip
    return [pt.Case("fleet parser", name, "error", run) for name, run in table]


# ----------------------------------------------------------------------- --atlas
def atlas_cases(w: Any, pt: Any) -> list[Any]:
    d = w.tmp / "atlases"
    d.mkdir(exist_ok=True)
    (d / "folder").mkdir(exist_ok=True)
    (d / "text.npz").write_text("not an atlas\n")
    np.savez(d / "nometa.npz", volumes=np.ones(3))
    np.savez(d / "pickled.npz", meta=np.array([{"format": 1}], dtype=object))
    n = iter(range(100))

    def given(path: Path) -> Callable[[], Any]:
        def run() -> Any:
            r = pt.cli("fleet-study", *pt.TINY_STUDY, "--out", str(w.tmp / f"atlas-{next(n)}"),
                       "--atlas", str(path))()  # fmt: skip
            return (
                r
                if r.code != 2 or ("--atlas" in r.stderr and str(path) in r.stderr)
                else (pt.Ran(1, r.stderr))
            )  # an error that does not name the option and file

        return run

    return [
        pt.Case("--atlas", f"--atlas {what}", "error", given(d / name))
        for what, name in (("a folder", "folder"), ("a text file", "text.npz"),
                           ("an npz without metadata", "nometa.npz"),
                           ("a pickled npz", "pickled.npz"), ("a missing file", "nope.npz"))
    ]  # fmt: skip


# ------------------------------------------------------------ fleet-distil's study
def distil_study_cases(w: Any, pt: Any) -> list[Any]:
    """Hostile study costs.json files given to fleet-distil: one error naming the file
    before anything but the output mark is in ``--out``."""
    good = json.loads((w.tmp / "fleet-lib" / "costs.json").read_text())
    n = iter(range(1000))
    hostile: dict[str, Callable[[dict[str, Any]], Any]] = {
        "config without objective": lambda s: s["config"].pop("objective"),
        "config without seed": lambda s: s["config"].pop("seed"),
        "an unknown config key": lambda s: s["config"].update(colour=1),
        "a list for config": lambda s: s.update(config=[1, 2]),
        "a string for a config number": lambda s: s["config"].update(shifts="x"),
        "NaN for a config number": lambda s: s["config"].update(trials=NAN),
        "no row of the best heuristic": lambda s: s.update(
            rows=[r for r in s["rows"] if r["policy"] != s["best_heuristic"]["oracle"]]),
        "a NaN parameter": lambda s: _best_row(s)["params"].update(
            {k: NAN for k in _best_row(s)["params"]}),
        "a string parameter": lambda s: _best_row(s)["params"].update(
            {k: "x" for k in _best_row(s)["params"]}),
        "an unknown parameter": lambda s: _best_row(s).update(params={"other": 1.0}),
        "a dict for rows": lambda s: s.update(rows={"a": 1}),
        "the best row without episodes": lambda s: _best_row(s).pop("episodes"),
        "NaN episode costs": lambda s: _best_row(s)["episodes"]["cost"].__setitem__(0, NAN),
        "too few episode costs": lambda s: _best_row(s)["episodes"].update(cost=[1.0]),
        "a number for best_heuristic": lambda s: s.update(best_heuristic=3),
        "a string bound": lambda s: s.update(bound="x"),
        "NaN bound episodes": lambda s: s.update(bound={"episodes": [NAN, 1.0]}),
    }  # fmt: skip

    def case(edit: Callable[[dict[str, Any]], Any]) -> tuple[Callable[[], Any], dict[Path, bytes]]:
        files: dict[Path, bytes] = {}

        def run() -> Any:
            d = w.tmp / f"hostile-{next(n)}"
            doc = copy.deepcopy(good)
            edit(doc)
            pt.keep(files, d / "study" / "costs.json", json.dumps(doc).encode())
            out = d / "out"
            got = pt.cli("fleet-distil", "--study", str(d / "study"), "--out", str(out),
                         "--predictor", "oracle", "--workers", "0")()  # fmt: skip
            left = sorted(p.name for p in out.iterdir()) if out.exists() else []
            if left not in ([], [OUTPUT_MARK]) or "costs.json" not in got.stderr:
                return pt.Ran(1, f"wrote {left} to --out; {got.stderr}")
            return got

        return run, files

    cases = []
    for name, edit in hostile.items():
        run, files = case(edit)
        cases.append(pt.Case("distil study", name, "error", run, None, (), pt.unchanged(files)))
    return cases


def _best_row(s: dict[str, Any]) -> dict[str, Any]:
    best = s["best_heuristic"]["oracle"]
    return next(r for r in s["rows"] if r["predictor"] == "oracle" and r["policy"] == best)


# ------------------------------------------------------------------- the reports
def report_cases(w: Any, pt: Any) -> list[Any]:
    from agents.fleet.study.run import _planner_lines
    from agents.fleet.study.summary import to_bound

    def row(net: list[float], bd: list[float]) -> dict[str, Any]:
        r = [{"episodes": {"net": net}}]
        to_bound(r, np.array(bd))
        return {k: r[0][k] for k in sorted(r[0]) if k != "episodes"}

    neg = row([0.4, 0.5, 0.6], [-0.7, -0.6, -0.7])
    iv = {"point": 7.0, "low": 6.0, "high": 8.0}
    roll = {"base": "threshold", "cost": -0.2, "base_cost": -0.1, "minus_base": iv,
            "ratio_to_base": iv, "seconds_per_shift": 0.1, "seconds": 60.0}  # fmt: skip
    line = "\n".join(_planner_lines({"rollout": {"oracle": roll}}))
    return [
        pt.Case("reports", "ratio_to_bound against a negative bound", "correct",
                lambda: row([0.4, 0.5, 0.6], [-0.7, -0.6, -0.7]),
                pt.Check("the gap, no ratio", lambda a: pt.same(a, neg) and
                         "ratio_to_bound" not in a)),
        pt.Case("reports", "ratio_to_bound of two negative figures", "correct",
                lambda: sorted(row([-0.4, -0.5], [-0.7, -0.6])),
                pt.equals(["gap_to_bound"], "the gap alone")),
        pt.Case("reports", "the rollout line with negative costs", "correct",
                lambda: "\n".join(_planner_lines({"rollout": {"oracle": roll}})),
                pt.Check("no ratio printed (the difference is)", lambda a: a == line and
                         a.count("7.000 [6") == 1, lambda a: a.replace("n/a", "7.000 [6"))),
    ]  # fmt: skip


# ----------------------------------------------------------------- other edges
def other_cases(w: Any, pt: Any) -> list[Any]:
    import gymnasium as gym

    n = iter(range(1000))

    def store_with(settings: Any = None, lock_dir: bool = False) -> Callable[[], Any]:
        def run() -> Any:
            d = w.tmp / f"edge-{next(n)}"
            d.mkdir()
            if lock_dir:
                (d / units.LOCK).mkdir()
            else:
                (d / units.SETTINGS).write_text(json.dumps(settings))
            return units.open_store(d, {"a": 1}, ["k"], "probe")

        return run

    def link(how: str) -> Callable[[], Any]:
        def run() -> Any:
            d = w.tmp / f"link-{next(n)}"
            d.mkdir()
            (d / "out").symlink_to(d / ("nowhere" if how == "dangling" else "other"))
            if how == "loop":
                (d / "other").symlink_to(d / "out")
            return pt.cli("atlas", "--out", str(d / "out"))()

        return run

    cfg = FleetConfig(**pt.FLEET)

    def miscounting(extra: int) -> Callable[[], Any]:
        def run() -> Any:
            env = FleetRULObservation(BrakeWearFleetEnv(cfg, atlas=w.atlas), _Miscount(extra))
            env.reset(seed=0)
            return env.step(np.array([HOT] * cfg.n_vehicles + [0]))  # both drive: events

        return run

    def v0(config: Any) -> Callable[[], Any]:
        def run() -> Any:
            with _quiet_warnings():
                return gym.make("BrakeWearFleet-v0", config=config, atlas=w.atlas)

        return run

    table = [
        *((f"settings.json {s!r}", store_with(s), ("settings.json is damaged",))
          for s in ([], None, "x", 5)),
        ("units/.lock a folder", store_with(lock_dir=True), ("is a folder",)),
        ("gym.make(config='small')", v0("small"), ("config must be a FleetConfig", "fleet=")),
        ("gym.make(config={...})", v0({"n_vehicles": 2}), ("config must be a FleetConfig",)),
        ("--out a dangling symbolic link", link("dangling"), ()),
        ("--out a loop of symbolic links", link("loop"), ()),
        *((f"a predictor giving {e:+d} estimates", miscounting(e), ("estimates for",))
          for e in (3, -1)),
    ]  # fmt: skip
    return _errors(pt, "other edges", table)


class _Miscount:
    name = "miscounting"

    def __init__(self, extra: int) -> None:
        self.extra = extra

    def fit(self, log: Any) -> _Miscount:
        return self

    def reset(self) -> None:
        pass

    def update(self, events: Any) -> RULEstimate:
        return RULEstimate(np.full(max(len(events) + self.extra, 0), 1e4))


@contextlib.contextmanager
def _quiet_warnings() -> Any:
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        yield


def input_cases(w: Any, pt: Any) -> list[Any]:
    return (
        keyed_unit_cases(w, pt) + bound_cases(w, pt) + planner_cases(w, pt)
        + priced_cases(w, pt) + duty_cases(w, pt) + parser_cases(w, pt) + atlas_cases(w, pt)
        + distil_study_cases(w, pt) + report_cases(w, pt) + other_cases(w, pt)
    )  # fmt: skip
