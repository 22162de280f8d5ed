"""Bad inputs a careful user tries, across fit, predict, evaluate, diagnose, saved models,
unit stores and the env, and how each ends (issue 22; docs/schema.md, "Probe of bad inputs").

    .venv/bin/python scripts/probe_trust.py [--seed 0] [--verbose]

Outcomes:

- ``clear error``: the case should fail, and it raised one of our errors (a ValueError,
  TypeError, RuntimeError or FileNotFoundError, or the command exited with code 2);
- ``warning``: the case is implausible but usable, and it ran with a PlausibilityWarning;
- ``correct``: the case is fine (or a gap in a log), and it ran with the expected answer;
- ``other exception``: anything else raised (KeyError, IndexError, AssertionError, an
  error where an answer was expected, ...);
- ``silent wrong answer``: it ran without a warning where it should have failed or warned,
  or its answer is wrong (non-finite estimates, a wrong number of them).

Unit stores (a command's ``OUT/units``): other settings, cut or changed files, a store held
by a running process or left locked by a dead one. The goal is 0 in the last two columns.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import subprocess
import sys
import tempfile
import time
import warnings
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pandas as pd

import brake_env  # noqa: F401  # registers BrakeWear-v0
from baselines.mlp import MLPConfig, MLPPredictor
from baselines.physics import PhysicsPredictor
from baselines.window import WindowPredictor
from brake_env import units
from brake_env.cli.main import main as brakewear
from brake_env.data.datasets import DatasetSpec, make_dataset, write_dataset
from brake_env.data.plausibility import PlausibilityWarning, warn_fitted, warn_implausible
from brake_env.data.schema import write_event_log
from brake_env.env.brake_wear import BrakeWearEnv
from brake_env.model.atlas import Atlas, AtlasSpec
from brake_env.model.regime import WearRegime
from brake_env.output import table, write_arrays
from brake_env.prognostics.persist import ARRAYS, HEADER, load_predictor, save_predictor
from brake_env.prognostics.protocol import NoPrognostics, Predictor, predict_log
from twin import DigitalTwin

CLEAR = (ValueError, TypeError, RuntimeError, FileNotFoundError)
OUTCOMES = ("clear error", "warning", "correct", "other exception", "silent wrong answer")
FAST = {"k_mean": 1e-5, "k_std": 1e-6, "decision_interval": 500, "episode_events": 100_000}


@dataclass
class Case:
    area: str
    name: str
    expect: str  # "error", "warning" or "correct"
    run: Callable[[], Any]
    check: Callable[[Any], bool] = lambda _: True  # the answer of a "correct" case


def outcome(case: Case) -> tuple[str, str]:
    """(outcome, detail) of running ``case``."""
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always", PlausibilityWarning)
        err = io.StringIO()
        try:
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                result = case.run()
        except SystemExit as e:  # argparse refuses an option: usage and exit code 2
            if case.expect == "error" and e.code == 2:
                return "clear error", err.getvalue().strip().splitlines()[-1][:120]
            return "other exception", f"SystemExit({e.code}): {err.getvalue()[-200:]}"
        except Exception as e:  # classifying every exception is the point
            clear = isinstance(e, CLEAR) and not isinstance(e, KeyError | IndexError)
            if case.expect == "error" and clear:
                return "clear error", f"{type(e).__name__}: {str(e)[:120]}"
            return "other exception", f"{type(e).__name__}: {str(e)[:200]}"
    warned = [w for w in seen if issubclass(w.category, PlausibilityWarning)]
    if isinstance(result, int) and not isinstance(result, bool):  # a CLI exit code
        if result == 2 and case.expect == "error":
            return "clear error", err.getvalue().strip().splitlines()[-1][:120]
        if result != 0:
            return "other exception", f"exit {result}: {err.getvalue()[-200:]}"
    if warned:
        if case.expect == "warning":
            return "warning", str(warned[0].message)[:120]
        return "silent wrong answer", f"unexpected warning: {str(warned[0].message)[:160]}"
    if case.expect == "correct" and case.check(result):
        return "correct", ""
    return "silent wrong answer", f"expected {case.expect}, ran without one"


# ----------------------------------------------------------------------------- fixtures
@dataclass
class World:
    atlas: Atlas
    atlas_file: Path
    data: Any
    fitted: dict[str, Predictor]  # run over logs
    models: dict[str, Predictor]  # saved and edited: the fitted ones and the MLP
    tmp: Path


def build_world(tmp: Path, seed: int) -> World:
    atlas = Atlas.build(AtlasSpec(n_speed=6, n_mass=3, n_slope=5))
    spec = DatasetSpec(n_train=6, n_id=3, n_ood_slow=1, n_ood_fast=1, wear=WearRegime(2e-5, 2e-6))
    data = make_dataset(atlas, spec, seed=seed)
    train = data.logs["train"]
    fitted: dict[str, Predictor] = {
        "twin": DigitalTwin(atlas).fit(train),
        "physics": PhysicsPredictor(atlas).fit(train),
        "window": WindowPredictor().fit(train),
        "none": NoPrognostics().fit(train),
    }
    models = {**fitted, "data": MLPPredictor(MLPConfig(epochs=1)).fit(train)}
    write_dataset(data, tmp / "data", ("parquet",))
    return World(atlas, atlas.save(tmp / "atlas.npz"), data, fitted, models, tmp)


def finite_estimates(n: int) -> Callable[[pd.DataFrame], bool]:
    return lambda out: len(out) == n and bool(np.isfinite(out["rul_mean"]).all())


# ------------------------------------------------------------------------------- logs
def log_cases(w: World) -> list[Case]:
    idl, train = w.data.logs["id"], w.data.logs["train"]
    bad = {
        "temperatures in kelvin": idl.assign(temp_c=idl["temp_c"] + 273.15),
        "temperatures in Fahrenheit": idl.assign(temp_c=idl["temp_c"] * 1.8 + 32),
        "temperature sensor -150 K": idl.assign(temp_c=idl["temp_c"] - 150),
        "speeds in m/s": idl.assign(speed_kmh=idl["speed_kmh"] / 3.6),
        "speeds in mph": idl.assign(speed_kmh=idl["speed_kmh"] / 1.609344),
        "mass in tonnes": idl.assign(mass_kg=idl["mass_kg"] / 1000),
        "slope in degrees": idl.assign(slope_rad=np.degrees(idl["slope_rad"])),
        "energy in kJ": idl.assign(energy_j=idl["energy_j"] / 1000),
        "speed and energy from another vehicle": idl.assign(speed_kmh=idl["speed_kmh"] * 3),
    }
    cases = [
        Case("predict", f"{name} ({p})", "warning", _predict(w, log, p))
        for name, log in bad.items()
        for p in ("twin", "window")
    ]
    one = train.iloc[:3].drop(columns=["failed"])
    short = pd.concat([one.assign(run_id=f"r{i}", event=np.arange(3)) for i in range(2000)])
    life = train.groupby("run_id", observed=True)["event"].transform("max") + 1
    cut = train[train["event"] < 0.6 * life].drop(columns=["failed"])
    cases += [
        Case("fit", "2,000 runs of 3 events as lives", "warning", _fit_check(w, short)),
        Case("fit", "pads removed at 60% of life, no failed column", "warning", _fit_check(w, cut)),
        Case(
            "fit",
            "the same, marked failed=false",
            "correct",
            _fit_check(w, cut.assign(failed=False)),
        ),
        Case("fit", "the clean training log", "correct", _fit_check(w, train)),
        Case(
            "fit",
            "twin K prior 40,000x nominal",
            "warning",
            lambda: warn_fitted({"twin": 0.079}, "fit"),
        ),
        Case("fit", "physics K NaN", "warning", lambda: warn_fitted({"physics": math.nan}, "fit")),
    ]
    return cases


def _predict(w: World, log: pd.DataFrame, name: str) -> Callable[[], pd.DataFrame]:
    def run() -> pd.DataFrame:
        warn_implausible(log, w.atlas, "predict")
        return predict_log(w.fitted[name], log)

    return run


def _fit_check(w: World, log: pd.DataFrame) -> Callable[[], Any]:
    return lambda: warn_implausible(log, w.atlas, "fit", lives=True)


# ------------------------------------------------------------------------------- gaps
def gap_cases(w: World) -> list[Case]:
    idl = w.data.logs["id"]
    rng = np.random.default_rng(0)
    first = idl[idl["run_id"] == idl["run_id"].iloc[0]]
    n = len(first)
    huge = first.assign(
        event=np.where(first["event"] >= n // 2, first["event"] + 10**8, first["event"])
    )
    logs = {
        "1% of events dropped": idl[rng.random(len(idl)) >= 0.01],
        "50% of events dropped": idl[rng.random(len(idl)) >= 0.5],
        "every other event": idl[idl["event"] % 2 == 0],
        "first half not logged": first[first["event"] >= n // 2],
        "one event, then a gap": first[(first["event"] == 0) | (first["event"] > n // 3)],
        "a gap of 1e8 events": huge,
        "a single event at 1e8": first.iloc[:1].assign(event=10**8),
    }
    return [
        Case("gaps", f"{name} ({p})", "correct", _predict(w, log, p), finite_estimates(len(log)))
        for name, log in logs.items()
        for p in w.fitted
    ]


# ------------------------------------------------------------------------- saved models
def model_cases(w: World) -> list[Case]:
    cases = []
    for name, pred in w.models.items():
        path = save_predictor(pred, w.tmp / "models" / name, w.atlas)
        other = "physics" if name != "physics" else "twin"
        edits: dict[str, tuple[str, Callable[[dict[str, Any]], None] | None, Any]] = {
            "unknown setting": ("error", lambda h: h["meta"].update(surprise=1), None),
            "a setting removed": ("error", lambda h: h["meta"].pop(sorted(h["meta"])[0]), None),
            f"predictor name edited to {other}": (
                "error",
                lambda h, o=other: h.update(predictor=o),
                None,
            ),
            "predictor name unknown": ("error", lambda h: h.update(predictor="magic"), None),
            "format version 99": ("error", lambda h: h.update(format_version=99), None),
            "atlas hash edited": ("error", lambda h: h.update(atlas_hash="0" * 64), None),
            "arrays checksum edited": ("error", lambda h: h.update(arrays_sha256="0" * 64), None),
            "header cut to 40 bytes": ("error", None, "cut"),
            "arrays deleted": ("error", None, "no-arrays"),
            "untouched": ("correct", None, None),
        }
        _, arrays = pred.get_state()
        if any(a.dtype.kind == "f" for a in arrays.values()) and name != "physics":
            edits["arrays all NaN, checksum recomputed"] = ("error", None, "nan")
        for label, (expect, edit, special) in edits.items():
            cases.append(
                Case(
                    "saved model",
                    f"{name}: {label}",
                    expect,
                    _load_edited(w, path, label, edit, special),
                    lambda p: isinstance(p, Predictor),
                )
            )
    return cases


def _load_edited(
    w: World, src: Path, label: str, edit: Callable[[dict[str, Any]], None] | None, special: Any
) -> Callable[[], Predictor]:
    def run() -> Predictor:
        dst = w.tmp / "edited" / f"{src.name}-{abs(hash(label))}"
        dst.mkdir(parents=True, exist_ok=True)
        header = json.loads((src / HEADER).read_text())
        (dst / ARRAYS).write_bytes((src / ARRAYS).read_bytes())
        if edit is not None:
            edit(header)
        if special == "nan":
            with np.load(src / ARRAYS) as z:
                arrays = {
                    k: np.full_like(z[k], np.nan) if z[k].dtype.kind == "f" else z[k]
                    for k in z.files
                }
            header["arrays_sha256"] = write_arrays(arrays, dst / ARRAYS, compress=True)
        text = json.dumps(header)
        (dst / HEADER).write_text(text[:40] if special == "cut" else text)
        if special == "no-arrays":
            (dst / ARRAYS).unlink()
        return load_predictor(dst, w.atlas)

    return run


# --------------------------------------------------------------------------------- env
def env_cases(w: World) -> list[Case]:
    def make(**kw: Any) -> Callable[[], Any]:
        return lambda: gym.make("BrakeWear-v0", atlas=w.atlas, **{**FAST, **kw})

    def step(action: Any) -> Callable[[], Any]:
        def run() -> Any:
            env = BrakeWearEnv(atlas=w.atlas, **FAST)
            env.reset(seed=0)
            return env.step(action)

        return run

    def before_reset() -> Any:
        return gym.make("BrakeWear-v0", atlas=w.atlas, **FAST).unwrapped.step(0)

    ok_step = lambda r: isinstance(r, tuple) and len(r) == 5  # noqa: E731
    cases = [
        Case("env", "render_mode='human'", "error", make(render_mode="human")),
        Case("env", "render_mode='video'", "error", make(render_mode="video")),
        Case("env", "render_mode='rgb_array_list'", "correct", make(render_mode="rgb_array_list")),
        Case("env", "unknown keyword frameskip", "error", make(frameskip=4)),
        Case("env", "misspelt decison_interval", "error", make(decison_interval=5)),
        Case("env", "decision_interval=0", "error", make(decision_interval=0)),
        Case("env", "decision_interval=2.5", "error", make(decision_interval=2.5)),
        Case("env", "regime='weird'", "error", make(regime="weird")),
        Case("env", "ood_share=1.5", "error", make(ood_share=1.5)),
        Case("env", "costs with an unknown term", "error", make(costs={"failure": 3.0})),
        Case("env", "negative damage cost", "error", make(costs={"damage": -1.0})),
        Case("env", "negative sensor noise", "error", make(noise={"temp_c": -1.0})),
        Case(
            "env",
            "atlas file that does not exist",
            "error",
            lambda: BrakeWearEnv(atlas="/nonexistent.npz"),
        ),
        Case("env", "step before reset", "error", before_reset),
    ]
    for label, action in [
        ("[0, 1]", np.array([0, 1])),
        ("[1]", np.array([1])),
        ("1.0", 1.0),
        ("float32 0", np.float32(0)),
        ("'1'", "1"),
        ("None", None),
        ("2", 2),
        ("-1", -1),
        ("0-d float array", np.array(1.0)),
    ]:
        cases.append(Case("env", f"step({label})", "error", step(action)))
    for label, action in [
        ("0", 0),
        ("1", 1),
        ("np.int64(1)", np.int64(1)),
        ("0-d int array", np.array(1)),
        ("True", True),
    ]:
        cases.append(Case("env", f"step({label})", "correct", step(action), ok_step))
    return cases


# --------------------------------------------------------------------------------- CLI
def cli_cases(w: World) -> list[Case]:
    idl, train = w.data.logs["id"], w.data.logs["train"]
    files = {
        "kelvin": write_event_log(idl.assign(temp_c=idl["temp_c"] + 273.15), w.tmp / "kelvin.csv"),
        "ms": write_event_log(idl.assign(speed_kmh=idl["speed_kmh"] / 3.6), w.tmp / "ms.csv"),
        "gaps": write_event_log(idl[idl["event"] % 3 != 1], w.tmp / "gaps.csv"),
        "short": write_event_log(
            pd.concat(
                [train.iloc[:3].assign(run_id=f"r{i}", event=np.arange(3)) for i in range(300)]
            ).drop(columns=["failed"]),
            w.tmp / "short.csv",
        ),
        "train": write_event_log(train, w.tmp / "train.csv"),
    }
    (w.tmp / "bad.csv").write_text("run_id,event\nA,0\n")
    atlas = ["--atlas", str(w.atlas_file)]
    model = str(w.tmp / "cli-model")

    def cli(*argv: str) -> Callable[[], int]:
        return lambda: brakewear([*argv, "--quiet"])

    def fit(data: str, pred: str = "twin", *extra: str) -> Callable[[], int]:
        out = str(w.tmp / f"fit-{Path(data).stem}-{pred}-{len(extra)}")
        return cli("fit", "--data", data, "--predictor", pred, "--out", out, *atlas, *extra)

    def predict(log: str, *extra: str) -> Callable[[], int]:
        out = str(w.tmp / f"pred-{Path(log).stem}-{len(extra)}")
        return cli("predict", "--model", model, "--log", log, "--out", out, *atlas, *extra)

    zero = lambda code: code == 0  # noqa: E731
    return [
        Case("fit", "CLI: clean training log", "correct", fit(str(files["train"]), "twin"), zero),
        Case(
            "fit",
            "CLI: kelvin log --strict",
            "error",
            fit(str(files["kelvin"]), "physics", "--strict"),
        ),
        Case("fit", "CLI: kelvin log", "warning", fit(str(files["kelvin"]), "physics")),
        Case("fit", "CLI: 300 runs of 3 events", "warning", fit(str(files["short"]), "physics")),
        Case("fit", "CLI: log lacking columns", "error", fit(str(w.tmp / "bad.csv"), "physics")),
        Case(
            "fit", "CLI: log that does not exist", "error", fit(str(w.tmp / "nope.csv"), "physics")
        ),
        Case("fit", "CLI: unknown predictor", "error", fit(str(files["train"]), "magic")),
        Case(
            "fit",
            "CLI: --out is a file",
            "error",
            cli(
                "fit",
                "--data",
                str(files["train"]),
                "--predictor",
                "none",
                "--out",
                str(files["gaps"]),
                *atlas,
            ),
        ),
        Case(
            "predict",
            "CLI: fit the model used below",
            "correct",
            cli(
                "fit", "--data", str(files["train"]), "--predictor", "twin", "--out", model, *atlas
            ),
            zero,
        ),
        Case(
            "predict",
            "CLI: log with every third event missing",
            "correct",
            predict(str(files["gaps"])),
            zero,
        ),
        Case("predict", "CLI: kelvin log", "warning", predict(str(files["kelvin"]))),
        Case("predict", "CLI: m/s log --strict", "error", predict(str(files["ms"]), "--strict")),
        Case(
            "predict",
            "CLI: model directory missing",
            "error",
            cli("predict", "--model", str(w.tmp / "none"), "--log", str(files["gaps"]), *atlas),
        ),
        Case(
            "evaluate",
            "CLI: no --data",
            "error",
            cli("evaluate", "--out", str(w.tmp / "e0"), *atlas),
        ),
        Case(
            "evaluate",
            "CLI: --data not a dataset",
            "error",
            cli("evaluate", "--data", str(w.tmp / "nodir"), "--out", str(w.tmp / "e1"), *atlas),
        ),
        Case(
            "evaluate",
            "CLI: unknown predictor",
            "error",
            cli("evaluate", "--data", str(w.tmp / "data"), "--predictors", "magic", *atlas),
        ),
        Case(
            "diagnose",
            "CLI: kelvin log --strict",
            "error",
            cli(
                "diagnose",
                "--real",
                str(files["kelvin"]),
                "--model",
                str(w.atlas_file),
                "--out",
                str(w.tmp / "d0"),
                "--strict",
            ),
        ),
        Case(
            "diagnose",
            "CLI: log that does not exist",
            "error",
            cli("diagnose", "--real", str(w.tmp / "nope.csv"), "--out", str(w.tmp / "d1")),
        ),
        Case(
            "diagnose",
            "CLI: log lacking columns",
            "error",
            cli("diagnose", "--real", str(w.tmp / "bad.csv"), "--out", str(w.tmp / "d2")),
        ),
    ]


# ------------------------------------------------------------------------ unit stores
def store_cases(w: World) -> list[Case]:
    """A command's unit store (brake_env.units) after the ways a run can leave it."""
    keys = ["pads-0000", "pads-0001", "pads-0002"]
    settings = {"seed": 0, "what": "probe"}
    result = {"life": np.arange(5), "note": "x"}
    n = iter(range(10_000))

    def filled() -> Path:
        d = w.tmp / f"store-{next(n)}"
        with units.open_store(d, settings, keys, "probe") as st:
            st.save(keys[0], result)
            st.save(keys[1], result)
        return d

    def reopen(d: Path, edit: Callable[[Path], object] = lambda _: None) -> Callable[[], Any]:
        def run() -> list[str]:
            edit(d)
            with units.open_store(d, settings, keys, "probe") as st:
                got = st.keys()
                for k in got:
                    np.testing.assert_array_equal(st.load(k)["life"], result["life"])
                return got

        return run

    def json_of(d: Path, i: int = 0) -> Path:
        return sorted(d.glob("pads-000*.json"))[i]

    def cut(d: Path) -> None:
        f = json_of(d)
        f.write_bytes(f.read_bytes()[:40])

    def flip_npz(d: Path) -> None:
        f = json_of(d).with_suffix(".npz")
        b = bytearray(f.read_bytes())
        b[len(b) // 2] ^= 0xFF
        f.write_bytes(bytes(b))

    def rename(d: Path) -> None:
        f = json_of(d)
        f.rename(f.with_name("pads-0002-0123456789.json"))

    def other_settings(d: Path) -> Callable[[], Any]:
        return lambda: units.open_store(d, {**settings, "seed": 1}, keys, "probe")

    def cut_settings(d: Path) -> Callable[[], Any]:
        def run() -> Any:
            (d / units.SETTINGS).write_text('{"seed": ')
            return units.open_store(d, settings, keys, "probe")

        return run

    def held_elsewhere(d: Path) -> Callable[[], Any]:
        def run() -> Any:
            code = (
                "import sys, time; from brake_env import units;"
                f" s = units.open_store({str(d)!r}, {settings!r}, {keys!r}, 'other');"
                " print('held', flush=True); time.sleep(30)"
            )
            proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
            try:
                assert proc.stdout is not None and proc.stdout.readline().strip() == "held"
                return units.open_store(d, settings, keys, "probe")
            finally:
                proc.kill()
                proc.wait()

        return run

    def dead_holder(d: Path) -> Callable[[], Any]:
        def run() -> list[str]:
            code = (
                "import os; from brake_env import units;"
                f" s = units.open_store({str(d)!r}, {settings!r}, {keys!r}, 'killed');"
                " os._exit(0)"  # dies without releasing: the lock file still names it
            )
            subprocess.run([sys.executable, "-c", code], check=True)
            return reopen(d)()

        return run

    def edit_value(d: Path) -> None:
        f = json_of(d)
        f.write_text(f.read_text().replace('"note": "x"', '"note": "y"'))  # still whole JSON

    def foreign(d: Path) -> Callable[[], Any]:
        def run() -> Any:
            d.mkdir()
            (d / "notes.json").write_text("{}")
            return units.open_store(d, settings, keys, "probe")

        return run

    two = lambda got: got == keys[:2]  # noqa: E731
    redone = lambda got: keys[0] not in got and keys[1] in got  # noqa: E731
    return [
        Case("unit store", "reopened with the same settings", "correct", reopen(filled()), two),
        Case("unit store", "other settings", "error", other_settings(filled())),
        Case("unit store", "settings.json cut", "error", cut_settings(filled())),
        Case(
            "unit store",
            "unit JSON cut to 40 bytes: redone",
            "correct",
            reopen(filled(), cut),
            redone,
        ),
        Case(
            "unit store", "unit npz changed: redone", "correct", reopen(filled(), flip_npz), redone
        ),
        Case(
            "unit store",
            "unit npz deleted: redone",
            "correct",
            reopen(filled(), lambda d: json_of(d).with_suffix(".npz").unlink()),
            redone,
        ),
        Case(
            "unit store",
            "unit file under another key: set aside",
            "correct",
            reopen(filled(), rename),
            lambda got: got == [keys[1]],
        ),
        Case(
            "unit store",
            "unit JSON number edited: redone",
            "correct",
            reopen(filled(), edit_value),
            redone,
        ),
        Case("unit store", "user's files, no settings.json", "error", foreign(w.tmp / "mine")),
        Case("unit store", "held by a running process", "error", held_elsewhere(filled())),
        Case("unit store", "lock left by a dead process", "correct", dead_holder(filled()), two),
    ]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--verbose", action="store_true", help="one line per case")
    args = ap.parse_args()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as d:
        w = build_world(Path(d), args.seed)
        cases = log_cases(w) + gap_cases(w) + model_cases(w) + env_cases(w) + cli_cases(w)
        cases += store_cases(w)
        results = []
        for c in cases:
            res, detail = outcome(c)
            results.append((c, res, detail))
            if args.verbose or res in OUTCOMES[3:]:
                print(f"{res:20s} {c.area:12s} {c.name}: {detail}", file=sys.stderr)
    counts: dict[str, Counter[str]] = {}
    for c, res, _ in results:
        counts.setdefault(c.area, Counter())[res] += 1
    rows = [["area", "cases", *OUTCOMES]]
    for area, cnt in counts.items():
        rows.append([area, str(sum(cnt.values())), *(str(cnt[o]) for o in OUTCOMES)])
    total = Counter(res for _, res, _ in results)
    rows.append(["all", str(len(results)), *(str(total[o]) for o in OUTCOMES)])
    print(table(rows))
    print(f"\n{len(results)} cases (seed {args.seed}), {time.perf_counter() - t0:.0f} s")
    return 1 if total["other exception"] or total["silent wrong answer"] else 0


if __name__ == "__main__":
    raise SystemExit(main())
