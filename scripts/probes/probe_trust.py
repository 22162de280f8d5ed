"""Bad inputs a careful user tries, and how each ends, every answer compared with a known one
(issues 22 and 29; docs/schema.md, "Probe of bad inputs").

    .venv/bin/python scripts/probes/probe_trust.py [--seed 0] [--verbose]

Areas: fit, predict and gaps in a log (the library and ``brakewear`` itself), saved
models, BrakeWear-v0 and its RUL wrapper, BrakeWearFleet-v0 (its small fleet), its
PettingZoo version and its RUL wrappers, ``brakewear fleet-study`` on a tiny budget, output
folders shared by two commands, and unit stores.

Each :class:`Case` calls the real entry point (``fit`` is really fitted, the env really
stepped, the command really run) and says what should happen:

- ``error``: a clear error: a ValueError, TypeError, RuntimeError or FileNotFoundError
  (or exit code 2 with its one-line message) whose message matches the case's ``names``
  (for a bad RL action: the env or agent, the vehicle and the value given);
- ``warning``: a PlausibilityWarning, *and* the answer after it passes the case's check;
- ``correct``: no warning, and the answer passes the case's check.

A :class:`Check` compares the answer with a KNOWN one: the RUL of a log with gaps within a
stated distance of the full log's at the same events; a reloaded model's estimates
bit-identical to the saved one's; an env step equal to a reference rollout (same seed, same
actions, arrays equal); a command's output file equal to the library call's result. Each
check has ``wrong(answer)``, a deliberately wrong answer of the same shape; the probe feeds
it to the check after every passing case and counts the checks shown able to fail
(tests/scripts/test_probe_trust.py does the same for a few cases of each kind).

Outcomes: ``clear error``, ``warning``, ``correct`` (as expected), ``other exception``
(anything else raised, or an error whose message does not name what it should),
``silent wrong answer`` (it ran where it should have failed or warned, or its answer fails
its check) and ``data loss`` (whatever else happened, a file the case must leave as it was,
a user's or one set aside, is gone or changed: ``Case.lost``). The goal is 0 in the last
three columns; the script exits 1 otherwise.

Areas added for issue 44 (:func:`trust_cases`): files a unit store must never move or
delete (a user's file named like a unit, copies set aside in ``damaged/``), output marks
(written when a command starts, held while it runs, unreadable ones refused), and hostile
pad ids in CSV cells and figure labels; and in scripts/probes/probe_inputs.py: units keyed to the
settings that made them (copied from a ``--seed 1`` or ``--objective net`` study, under an
edited settings.json), every numeric input of the Lagrangian bound, the rollout planner and
the price-directed policy, the route RUL's volumes, the fleet commands' parser, ``--atlas``,
fleet-distil's study ``costs.json``, the reports' ratios, and the library's other edges.
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import csv
import functools
import io
import json
import re
import subprocess
import sys
import tempfile
import time
import warnings
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pandas as pd

import brake_env  # noqa: F401  # registers BrakeWear-v0 and BrakeWearFleet-v0
from baselines.mlp import MLPConfig, MLPPredictor
from baselines.physics import PhysicsPredictor
from baselines.window import WindowPredictor
from brake_env import units
from brake_env.cli.main import main as brakewear
from brake_env.csv_safe import plain_text, write_csv
from brake_env.data.datasets import DatasetSpec, make_dataset, write_dataset
from brake_env.data.plausibility import PlausibilityWarning, warn_fitted, warn_implausible
from brake_env.data.schema import read_event_log, write_event_log
from brake_env.env.brake_wear import BrakeWearEnv
from brake_env.env.fleet.config import SMALL_FLEET
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.parallel import STORE, BrakeWearFleetParallelEnv
from brake_env.env.fleet.route_rul import duty_clocks, equivalent_batch
from brake_env.env.fleet.wrappers import ExpectedRULObservation, FleetRULObservation
from brake_env.env.wrappers import RULObservation
from brake_env.model.atlas import Atlas, AtlasSpec
from brake_env.model.regime import WearRegime
from brake_env.output import OUTPUT_MARK, table, write_arrays
from brake_env.prognostics.duty import route_rul
from brake_env.prognostics.fleet import select
from brake_env.prognostics.persist import ARRAYS, HEADER, load_predictor, save_predictor
from brake_env.prognostics.protocol import NoPrognostics, Predictor, iter_runs, predict_log
from brake_env.prognostics.registry import make_predictor
from twin import DigitalTwin

try:  # the areas of issue 44's second part (a module of their own: this one is long)
    from scripts.probes.probe_inputs import input_cases
except ImportError:  # run as a script: scripts/probes/ is on the path, the root may not be
    from probe_inputs import input_cases  # type: ignore[no-redef]

CLEAR = (ValueError, TypeError, RuntimeError, FileNotFoundError)
OUTCOMES = (
    "clear error", "warning", "correct", "other exception", "silent wrong answer", "data loss",
)  # fmt: skip
FAST = {"k_mean": 1e-5, "k_std": 1e-6, "decision_interval": 500, "episode_events": 100_000}
# The small fleet, with short shifts and episodes so a rollout takes milliseconds.
FLEET = {**SMALL_FLEET, "events_per_shift": 100, "episode_shifts": 6}
GAP_TOL = 0.02  # gap-filled RUL vs the full log's: a share of the pad's life (see gap_cases)


# ------------------------------------------------------------------------------ checks
@dataclass(frozen=True)
class Check:
    """How a case's answer is judged: ``test(answer)`` against a known answer; ``wrong``
    makes a deliberately wrong answer of the same shape, which ``test`` must reject."""

    kind: str
    test: Callable[[Any], bool]
    wrong: Callable[[Any], Any] = field(default=lambda a: perturb(a))


@dataclass
class Case:
    area: str
    name: str
    expect: str  # "error", "warning" or "correct"
    run: Callable[[], Any]
    check: Check | None = None  # the answer of a "warning" or "correct" case
    names: tuple[str, ...] = ()  # regexes an "error" case's message must match
    # After the run, whatever the outcome: the files it must have left as they were that
    # are gone or changed (any: a "data loss").
    lost: Callable[[], list[str]] | None = None


@dataclass(frozen=True)
class Ran:
    """What a ``brakewear`` command did: its exit code, stderr and its output read back."""

    code: int
    stderr: str
    output: Any = None


def perturb(x: Any) -> Any:
    """A copy of ``x`` with one value changed (the first number found, depth first)."""
    if isinstance(x, Ran):
        return replace(x, output=perturb(x.output))
    if isinstance(x, pd.DataFrame):
        y = x.copy()
        col = "rul_mean" if "rul_mean" in y else y.select_dtypes("number").columns[0]
        y.loc[y.index[0], col] = y[col].iloc[0] * 1.5 + 1e6
        return y
    if isinstance(x, np.ndarray) and x.size and x.dtype.kind in "fiub":
        y = x.astype(np.float64 if x.dtype.kind == "b" else x.dtype, copy=True)
        y.flat[0] = y.flat[0] + 1 if x.dtype.kind != "f" else y.flat[0] * 1.5 + 1e6
        return y
    if isinstance(x, bool):
        return not x
    if isinstance(x, int | float | np.number):
        return x * 1.5 + 1e6
    if isinstance(x, str):
        return x + "?"
    if isinstance(x, dict):
        for k, v in x.items():
            y = perturb(v)
            if not same(y, v):
                return {**x, k: y}
        return {**x, "?": 1}
    if isinstance(x, list | tuple):
        for i, v in enumerate(x):
            y = perturb(v)
            if not same(y, v):
                return type(x)([*x[:i], y, *x[i + 1 :]])
        return type(x)([*x, "?"])
    raise TypeError(f"no wrong answer for {type(x).__name__}")


def same(a: Any, b: Any, rtol: float = 0.0) -> bool:
    """Deep equality: arrays and frames equal (NaN equal to NaN), to ``rtol`` if given."""
    if isinstance(a, pd.DataFrame) or isinstance(b, pd.DataFrame):
        if not (isinstance(a, pd.DataFrame) and isinstance(b, pd.DataFrame)):
            return False
        if list(a.columns) != list(b.columns) or len(a) != len(b):
            return False
        return all(same(a[c].to_numpy(), b[c].to_numpy(), rtol) for c in a.columns)
    if isinstance(a, dict) or isinstance(b, dict):
        return (
            isinstance(a, dict) and isinstance(b, dict) and a.keys() == b.keys()
            and all(same(a[k], b[k], rtol) for k in a)
        )  # fmt: skip
    if isinstance(a, list | tuple) and isinstance(b, list | tuple):
        return len(a) == len(b) and all(same(x, y, rtol) for x, y in zip(a, b, strict=True))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        x, y = np.asarray(a), np.asarray(b)
        if x.shape != y.shape:
            return False
        if x.dtype.kind in "fc" or y.dtype.kind in "fc":
            return bool(np.allclose(x, y, rtol=rtol, atol=0.0, equal_nan=True))
        return bool(np.array_equal(x, y))
    if isinstance(a, float | np.floating) and isinstance(b, float | np.floating):
        return bool(np.isclose(a, b, rtol=rtol, atol=0.0, equal_nan=True))
    return type(a) is type(b) and bool(a == b)


def equals(ref: Any, kind: str, rtol: float = 0.0) -> Check:
    """The answer equals ``ref`` (bit for bit unless ``rtol``)."""
    return Check(kind, lambda a: same(a, ref, rtol))


def outcome(case: Case) -> tuple[str, str, Any]:
    """(outcome, detail, answer) of running ``case`` (answer None where it raised); a
    "data loss" whatever else happened when a file it must keep is gone or changed."""
    res, detail, answer = _outcome(case)
    gone = case.lost() if case.lost is not None else []
    if gone:
        return "data loss", f"lost or changed: {', '.join(gone)[:200]} ({res})", answer
    return res, detail, answer


def _outcome(case: Case) -> tuple[str, str, Any]:
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always", PlausibilityWarning)
        err = io.StringIO()
        try:
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                result = case.run()
        except SystemExit as e:  # argparse refuses an option: usage and exit code 2
            if case.expect == "error" and e.code == 2:
                return "clear error", err.getvalue().strip().splitlines()[-1][:120], None
            return "other exception", f"SystemExit({e.code}): {err.getvalue()[-200:]}", None
        except Exception as e:  # classifying every exception is the point
            msg = f"{type(e).__name__}: {str(e)[:200]}"
            clear = isinstance(e, CLEAR) and not isinstance(e, KeyError | IndexError)
            if case.expect == "error" and clear:
                missing = [n for n in case.names if not re.search(n, str(e), re.IGNORECASE)]
                if missing:
                    return "other exception", f"{msg} (does not name {missing})", None
                return "clear error", msg[:160], None
            return "other exception", msg, None
    warned = [w for w in seen if issubclass(w.category, PlausibilityWarning)]
    if isinstance(result, Ran):
        if result.code == 2 and case.expect == "error":
            return "clear error", result.stderr.strip().splitlines()[-1][:120], result
        if result.code != 0:
            return "other exception", f"exit {result.code}: {result.stderr[-200:]}", result
    if case.expect == "error":
        return "silent wrong answer", "expected an error, ran without one", result
    if warned and case.expect == "correct":
        return "silent wrong answer", f"unexpected warning: {str(warned[0].message)[:160]}", result
    if not warned and case.expect == "warning":
        return "silent wrong answer", "expected a warning, ran without one", result
    assert case.check is not None, f"{case.name}: a {case.expect} case needs a check"
    if not case.check.test(result):
        return "silent wrong answer", f"answer fails its check ({case.check.kind})", result
    return ("warning", str(warned[0].message)[:120], result) if warned else ("correct", "", result)


def shown_to_fail(case: Case, answer: Any) -> bool:
    """Whether the case's check rejects a deliberately wrong version of a passing answer."""
    assert case.check is not None
    return not case.check.test(case.check.wrong(answer))


# ----------------------------------------------------------------------------- fixtures
@dataclass
class World:
    atlas: Atlas
    atlas_file: Path
    data: Any
    fitted: dict[str, Predictor]  # run over logs
    models: dict[str, Predictor]  # saved and edited: the fitted ones and the MLP
    tmp: Path
    full: dict[str, pd.DataFrame] = field(default_factory=dict)  # predict_log on the ID log


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
    w = World(atlas, atlas.save(tmp / "atlas.npz"), data, fitted, models, tmp)
    w.full = {p: predict_log(pred, data.logs["id"]) for p, pred in fitted.items()}
    return w


def direct(pred: Predictor, log: pd.DataFrame) -> pd.DataFrame:
    """``predict_log``'s answer the long way: the predictor reset at each run and given
    its events in one update (no fleet, no plausibility check): the known answer."""
    parts = []
    for run_id, events in iter_runs(log):
        pred.reset()
        frame = pred.update(events).to_frame()
        frame.insert(0, "event", events.event)
        frame.insert(0, "run_id", run_id)
        parts.append(frame)
    return pd.concat(parts, ignore_index=True)


def same_estimates(ref: pd.DataFrame, kind: str, rtol: float = 1e-9) -> Check:
    """Same runs and events as ``ref``, the estimate columns equal to ``rtol``."""

    def test(out: Any) -> bool:
        if not isinstance(out, pd.DataFrame) or len(out) != len(ref):
            return False
        if not (out["run_id"].astype(str).to_numpy() == ref["run_id"].astype(str).to_numpy()).all():
            return False
        cols = [c for c in ref.columns if c not in ("run_id",)]
        return set(cols) <= set(out.columns) and all(
            same(out[c].to_numpy(np.float64), ref[c].to_numpy(np.float64), rtol) for c in cols
        )

    return Check(kind, test)


def same_state(make_ref: Callable[[], Predictor], kind: str) -> Check:
    """A fitted predictor whose learned state (settings and arrays) equals that of the
    reference ``make_ref()`` (made when first needed: building a case costs nothing)."""
    ref = functools.cache(make_ref)
    return Check(kind, lambda p: same(list(p.get_state()), list(ref().get_state())), _changed)


def own_estimates(w: World, name: str, log: pd.DataFrame) -> Check:
    """The estimates of ``w.fitted[name]`` run the long way on ``log`` (:func:`direct`,
    computed when first needed)."""
    ref = functools.cache(lambda: same_estimates(direct(w.fitted[name], log), ""))
    return Check("estimates = the predictor's own", lambda out: ref().test(out))


def _changed(pred: Predictor) -> Any:
    """A wrongly fitted version of ``pred``: its learned state and K each one value off."""
    return _Wrong(pred)


class _Wrong:
    """``pred`` with every answer a fit check reads changed (state, K, mean life)."""

    def __init__(self, pred: Predictor) -> None:
        self.pred = pred
        life = getattr(pred, "mean_life_events", None)
        self.mean_life_events = None if life is None else life + 1.0

    def get_state(self) -> Any:
        return perturb(list(self.pred.get_state()))

    def fitted_wear_coeff(self) -> float | None:
        k = self.pred.fitted_wear_coeff()
        return None if k is None else 2 * k


# ------------------------------------------------------------------------------- logs
def log_cases(w: World) -> list[Case]:
    """Implausible logs given to predict (warned, and the estimates after the warning are
    the predictor's own: run the long way), and training logs given to fit (really
    fitted; the answer against a known one)."""
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
    # Each case is one predictor on one log: the warning is the log's, the answer the
    # predictor's (checked against the same predictor run the long way on the same log).
    cases = [
        Case("predict", f"{name} ({p})", "warning", _predict(w, log, p),
             own_estimates(w, p, log))
        for name, log in bad.items()
        for p in ("twin", "window")
    ]  # fmt: skip
    cases.append(
        Case("predict", "the clean ID log (twin)", "correct", _predict(w, idl, "twin"),
             own_estimates(w, "twin", idl))
    )  # fmt: skip
    one = train.iloc[:3].drop(columns=["failed"])
    short = pd.concat([one.assign(run_id=f"r{i}", event=np.arange(3)) for i in range(2000)])
    life = train.groupby("run_id", observed=True)["event"].transform("max") + 1
    cut = train[train["event"] < 0.6 * life].drop(columns=["failed"])
    lives = train.groupby("run_id", observed=True)["event"].max() + 1
    k_true = float(train.groupby("run_id", observed=True)["wear_coeff"].first().mean())
    makers: dict[str, Callable[[], Predictor]] = {
        "twin": lambda: DigitalTwin(w.atlas),
        "physics": lambda: PhysicsPredictor(w.atlas),
        "window": WindowPredictor,
        "none": NoPrognostics,
    }

    def k_near(share: float) -> Check:
        return Check(
            f"fitted K within {share:.0%} of the pads' true mean K",
            lambda p: abs(p.fitted_wear_coeff() / k_true - 1) <= share,
            _changed,
        )

    def again(name: str, log: pd.DataFrame) -> Check:
        return same_state(
            lambda: makers[name]().fit(log), "fitted state = a second fit of the same log"
        )

    cases += [
        Case("fit", "clean training log (twin)", "correct", _fit(w, train, makers["twin"]),
             k_near(0.25)),
        Case("fit", "clean training log (physics)", "correct", _fit(w, train, makers["physics"]),
             k_near(0.25)),
        Case("fit", "clean training log (none)", "correct", _fit(w, train, makers["none"]),
             Check("mean life = the runs' mean life",
                   lambda p: p.mean_life_events == float(lives.mean()), _changed)),
        Case("fit", "clean training log (window)", "correct", _fit(w, train, makers["window"]),
             again("window", train)),
        Case("fit", "2,000 runs of 3 events as lives (twin)", "warning",
             _fit(w, short, makers["twin"]), again("twin", short)),
        Case("fit", "2,000 runs of 3 events as lives (physics)", "warning",
             _fit(w, short, makers["physics"]), again("physics", short)),
        Case("fit", "2,000 runs of 3 events as lives (window)", "error",
             _fit(w, short, makers["window"]), names=("window",)),
        Case("fit", "pads removed at 60%, no failed column (twin)", "warning",
             _fit(w, cut, makers["twin"]), again("twin", cut)),
        Case("fit", "pads removed at 60%, no failed column (none)", "warning",
             _fit(w, cut, makers["none"]), again("none", cut)),
        Case("fit", "the same marked failed=false (twin: no failed run)", "error",
             _fit(w, cut.assign(failed=False), makers["twin"]), names=("twin", "failure")),
        Case("fit", "the same marked failed=false (none: no failed run)", "error",
             _fit(w, cut.assign(failed=False), makers["none"]), names=("none", "failure")),
        Case("fit", "the same marked failed=false (physics)", "correct",
             _fit(w, cut.assign(failed=False), makers["physics"]), k_near(0.25)),
    ]  # fmt: skip
    return cases


def _predict(w: World, log: pd.DataFrame, name: str) -> Callable[[], pd.DataFrame]:
    def run() -> pd.DataFrame:
        warn_implausible(log, w.atlas, "predict")
        return predict_log(w.fitted[name], log)

    return run


def _fit(w: World, log: pd.DataFrame, make: Callable[[], Predictor]) -> Callable[[], Predictor]:
    """What ``brakewear fit`` does in the library: the log checked, fitted, K checked."""

    def run() -> Predictor:
        warn_implausible(log, w.atlas, "fit", lives=True)
        pred = make().fit(log)
        warn_fitted({pred.name: pred.fitted_wear_coeff()}, "fit")
        return pred

    return run


# ------------------------------------------------------------------------------- gaps
def gap_cases(w: World) -> list[Case]:
    """Logs with events missing, against the full log at the same events: the twin and
    the window within GAP_TOL of the pad's life (median over the logged events and at the
    run's last event; measured: at most 0.4% and 1.5%), physics and none equal (their
    estimate depends on the event index alone); a pad logged 1e8 events on is worn out
    (RUL 0), except for none (the training mean life, whatever the log says)."""
    idl = w.data.logs["id"]
    rng = np.random.default_rng(0)
    first = idl[idl["run_id"] == idl["run_id"].iloc[0]]
    n = len(first)
    life = idl.groupby("run_id", observed=True)["event"].max() + 1
    logs = {
        "1% of events dropped": idl[rng.random(len(idl)) >= 0.01],
        "50% of events dropped": idl[rng.random(len(idl)) >= 0.5],
        "every other event": idl[idl["event"] % 2 == 0],
        "first half not logged": first[first["event"] >= n // 2],
        "one event, then a gap": first[(first["event"] == 0) | (first["event"] > n // 3)],
    }
    cases = []
    for name, log in logs.items():
        for p in w.fitted:
            check = (
                near_full(w.full[p], life, f"within {GAP_TOL:.0%} of life of the full log's")
                if p in ("twin", "window")
                else Check("= the full log's at the same events", _at_events(w.full[p], 1e-9))
            )
            cases.append(Case("gaps", f"{name} ({p})", "correct", _predict(w, log, p), check))
    huge = first.assign(event=np.where(first["event"] >= n // 2, first["event"] + 10**8,
                                       first["event"]))  # fmt: skip
    single = first.iloc[:1].assign(event=10**8)
    mean_life = float(w.fitted["none"].mean_life_events)  # type: ignore[attr-defined]
    for p in w.fitted:
        worn = 0.0 if p != "none" else mean_life
        before = w.full[p].iloc[: n // 2]
        cases.append(
            Case(
                "gaps",
                f"a gap of 1e8 events ({p})",
                "correct",
                _predict(w, huge, p),
                Check(
                    "the full log's before the gap, then worn out",
                    lambda out, b=before, x=worn: (
                        same(out["rul_mean"].to_numpy()[: len(b)], b["rul_mean"].to_numpy(), 1e-9)
                        and bool((out["rul_mean"].to_numpy()[len(b) :] == x).all())
                    ),
                ),
            )
        )
        cases.append(
            Case(
                "gaps",
                f"a single event at 1e8 ({p})",
                "correct",
                _predict(w, single, p),
                Check(
                    "worn out",
                    lambda out, x=worn: len(out) == 1 and float(out["rul_mean"].iloc[0]) == x,
                ),
            )
        )
    return cases


def _at_events(full: pd.DataFrame, rtol: float) -> Callable[[Any], bool]:
    def test(out: Any) -> bool:
        m = full.merge(out, on=["run_id", "event"], suffixes=("_f", "_g"))
        return len(m) == len(out) and same(
            m["rul_mean_g"].to_numpy(), m["rul_mean_f"].to_numpy(), rtol
        )

    return test


def near_full(full: pd.DataFrame, life: pd.Series, kind: str) -> Check:
    def test(out: Any) -> bool:
        m = full.merge(out, on=["run_id", "event"], suffixes=("_f", "_g"))
        if len(m) != len(out) or not np.isfinite(m["rul_mean_g"]).all():
            return False
        rel = (m["rul_mean_g"] - m["rul_mean_f"]).abs() / m["run_id"].map(life).astype(float)
        last = rel.groupby(m["run_id"], observed=True).last()
        return bool(rel.median() <= GAP_TOL and (last <= GAP_TOL).all())

    return Check(kind, test, _worse)


def _worse(out: pd.DataFrame) -> pd.DataFrame:
    """Every estimate a pad's life too high: what a gap handled wrongly could give."""
    return out.assign(rul_mean=out["rul_mean"] + 1e5)


# ------------------------------------------------------------------------- saved models
def model_cases(w: World) -> list[Case]:
    idl = w.data.logs["id"]
    cases = []
    for name, pred in w.models.items():
        path = save_predictor(pred, w.tmp / "models" / name, w.atlas)
        ref = predict_log(pred, idl)
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
            load = _load_edited(w, path, label, edit, special)
            cases.append(
                Case("saved model", f"{name}: {label}", expect,
                     lambda ld=load: predict_log(ld(), idl),
                     equals(ref, "reloaded estimates bit-identical to the saved model's"))
            )  # fmt: skip
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
def rollout(env: gym.Env[Any, Any], actions: list[Any], seed: int = 0) -> list[Any]:
    """The reset and each step's (obs, reward, terminated, truncated), of ``env``."""
    obs, _ = env.reset(seed=seed)
    out: list[Any] = [obs]
    for a in actions:
        o, r, term, trunc, _ = env.step(a)
        out.append((o, float(r), bool(term), bool(trunc)))
    return out


def bad_actions(vehicle: str) -> list[tuple[str, Any, tuple[str, ...]]]:
    """(label, the action's bad value, what a clear message names) for a bad RL action."""
    return [
        ("0.7", 0.7, (vehicle, r"0\.7")),
        ("2.9", 2.9, (vehicle, r"2\.9")),
        ("'1'", "1", (vehicle, "'1'")),
        ("None", None, (vehicle, "None")),
        ("NaN", float("nan"), (vehicle, "nan")),
        ("4 (no such duty)", 4, (vehicle, "4")),
        ("-1", -1, (vehicle, "-1")),
    ]


def env_cases(w: World) -> list[Case]:
    def make(**kw: Any) -> Callable[[], Any]:
        return lambda: rollout(gym.make("BrakeWear-v0", atlas=w.atlas, **{**FAST, **kw}), [0, 1])

    ref = rollout(BrakeWearEnv(atlas=w.atlas, **FAST), [0, 1])
    same_rollout = equals(ref, "= the reference rollout (seed 0, actions 0, 1)")

    def step(action: Any) -> Callable[[], Any]:
        return lambda: rollout(BrakeWearEnv(atlas=w.atlas, **FAST), [0, action])

    def before_reset() -> Any:
        return gym.make("BrakeWear-v0", atlas=w.atlas, **FAST).unwrapped.step(0)

    cases = [
        Case("env", "render_mode='human'", "error", make(render_mode="human")),
        Case("env", "render_mode='video'", "error", make(render_mode="video")),
        Case("env", "render_mode='rgb_array_list'", "correct", make(render_mode="rgb_array_list"),
             same_rollout),
        Case("env", "gym.make, no options", "correct", make(), same_rollout),
        Case("env", "unknown keyword frameskip", "error", make(frameskip=4)),
        Case("env", "misspelt decison_interval", "error", make(decison_interval=5)),
        Case("env", "decision_interval=0", "error", make(decision_interval=0)),
        Case("env", "decision_interval=2.5", "error", make(decision_interval=2.5)),
        Case("env", "regime='weird'", "error", make(regime="weird")),
        Case("env", "ood_share=1.5", "error", make(ood_share=1.5)),
        Case("env", "costs with an unknown term", "error", make(costs={"failure": 3.0})),
        Case("env", "negative damage cost", "error", make(costs={"damage": -1.0})),
        Case("env", "negative sensor noise", "error", make(noise={"temp_c": -1.0})),
        Case("env", "atlas file that does not exist", "error",
             lambda: BrakeWearEnv(atlas="/nonexistent.npz")),
        Case("env", "step before reset", "error", before_reset, names=("BrakeWear-v0", "reset")),
    ]  # fmt: skip
    for label, action, names in [
        *bad_actions("BrakeWear-v0"),
        ("[0, 1]", np.array([0, 1]), ("BrakeWear-v0", r"\(2,\)")),
        ("[1]", np.array([1]), ("BrakeWear-v0", r"\(1,\)")),
        ("1.0", 1.0, ("BrakeWear-v0", r"1\.0")),
        ("float32 0", np.float32(0), ("BrakeWear-v0", "0")),
        ("0-d float array", np.array(1.0), ("BrakeWear-v0", "1")),
    ]:
        cases.append(Case("env", f"step({label})", "error", step(action), names=names))
    for label, action in [
        ("1", 1),
        ("np.int64(1)", np.int64(1)),
        ("0-d int array", np.array(1)),
        ("True", True),
    ]:
        cases.append(Case("env", f"step({label})", "correct", step(action), same_rollout))
    cases += rul_wrapper_cases(w)
    return cases


def rul_wrapper_cases(w: World) -> list[Case]:
    """RULObservation on BrakeWear-v0: the appended estimate is the predictor's own, fed
    the events the env gives (a reference env, same seed and actions), reset per pad."""
    actions = [0, 0, 1, 0]

    def wrapped(p: str, **kw: Any) -> Callable[[], Any]:
        def run() -> Any:
            env = RULObservation(BrakeWearEnv(atlas=w.atlas, **FAST), copy.deepcopy(w.fitted[p]),
                                 **kw)  # fmt: skip
            return [np.asarray(x[0] if isinstance(x, tuple) else x) for x in rollout(env, actions)]

        return run

    def known(p: str, fields: tuple[str, ...] = ("rul_mean",)) -> Check:
        env = BrakeWearEnv(atlas=w.atlas, **FAST)
        pred = copy.deepcopy(w.fitted[p])
        obs, info = env.reset(seed=0)
        want = []
        for a in [None, *actions]:
            if a is not None:
                obs, _, _, _, info = env.step(a)
            ev = info["events"]
            fresh = np.flatnonzero(ev.event == 0)
            if fresh.size:
                pred.reset()
                ev = ev[int(fresh[-1]) :]
            est = pred.update(ev)
            vals = [np.clip(getattr(est, f)[-1], 0, 1e7) for f in fields]
            want.append(np.concatenate([obs, np.asarray(vals, np.float32)]).astype(np.float32))
        return equals(want, "= the env's observation and the predictor fed its events", 1e-6)

    return [
        *(Case("env", f"RULObservation ({p})", "correct", wrapped(p), known(p))
          for p in ("twin", "physics", "window", "none")),
        Case("env", "RULObservation precompute=True (twin)", "correct",
             wrapped("twin", precompute=True), known("twin")),
        Case("env", "RULObservation twin rul_lower, rul_upper", "correct",
             wrapped("twin", fields=("rul_mean", "rul_lower", "rul_upper")),
             known("twin", ("rul_mean", "rul_lower", "rul_upper"))),
        Case("env", "RULObservation fields=('rul_p90',)", "error",
             wrapped("twin", fields=("rul_p90",)), names=("rul_p90|fields",)),
        Case("env", "RULObservation fields=()", "error", wrapped("twin", fields=())),
        Case("env", "RULObservation none with rul_lower (it gives none)", "error",
             wrapped("none", fields=("rul_lower",)), names=("none", "rul_lower")),
        Case("env", "RULObservation around BrakeWearFleet-v0", "error",
             lambda: RULObservation(BrakeWearFleetEnv(atlas=w.atlas, **FLEET), w.fitted["twin"])
             .reset(seed=0)),
    ]  # fmt: skip


# --------------------------------------------------------------------------- fleet env
FLEET_ACTIONS = [np.array(a, dtype=np.int64) for a in ([0, 1, 0], [1, 0, 2], [3, 2, 0])]


def fleet_ref(w: World, actions: list[Any] = FLEET_ACTIONS, **kw: Any) -> list[Any]:
    return rollout(BrakeWearFleetEnv(atlas=w.atlas, **{**FLEET, **kw}), actions)


def fleet_cases(w: World) -> list[Case]:
    """BrakeWearFleet-v0 (its small fleet): valid actions in any integer form equal the
    reference rollout; bad ones are refused naming the vehicle and the value."""
    ref = equals(fleet_ref(w), "= the reference rollout (seed 0, the same actions)")

    def make(*actions: Any, **kw: Any) -> Callable[[], Any]:
        acts = list(actions) or FLEET_ACTIONS
        return lambda: rollout(gym.make("BrakeWearFleet-v0", atlas=w.atlas, **{**FLEET, **kw}),
                               acts)  # fmt: skip

    def first(a: Any) -> Callable[[], Any]:
        return make(a, *FLEET_ACTIONS[1:])

    cases = [
        Case("fleet env", "gym.make, small fleet", "correct", make(), ref),
        Case("fleet env", "actions as lists", "correct", make(*(a.tolist() for a in FLEET_ACTIONS)),
             ref),
        Case("fleet env", "actions as tuples", "correct",
             make(*(tuple(a.tolist()) for a in FLEET_ACTIONS)), ref),
        Case("fleet env", "actions as int32 arrays", "correct",
             make(*(a.astype(np.int32) for a in FLEET_ACTIONS)), ref),
        Case("fleet env", "actions as uint8 arrays", "correct",
             make(*(a.astype(np.uint8) for a in FLEET_ACTIONS)), ref),
        Case("fleet env", "render_mode='ansi'", "correct", make(render_mode="ansi"), ref),
        Case("fleet env", "truth=True (only info grows)", "correct", make(truth=True), ref),
        Case("fleet env", "render_mode='human'", "error", make(render_mode="human")),
        Case("fleet env", "n_vehicles=0", "error", make(n_vehicles=0, hot_need=0, mild_need=0)),
        Case("fleet env", "hot_need + mild_need > n_vehicles", "error", make(hot_need=2)),
        Case("fleet env", "n_vehicles=2.5", "error", make(n_vehicles=2.5)),
        Case("fleet env", "n_vehicles=True", "error", make(n_vehicles=True)),
        Case("fleet env", "unknown keyword n_trucks", "error", make(n_trucks=2)),
        Case("fleet env", "breakdown_rate=1.0", "error", make(breakdown_rate=1.0)),
        Case("fleet env", "initial_age_max=NaN", "error", make(initial_age_max=float("nan"))),
        Case("fleet env", "costs with an unknown term", "error", make(costs={"fuel": 1.0})),
        Case("fleet env", "negative shortfall cost", "error", make(costs={"shortfall": -1.0})),
        Case("fleet env", "regime='weird'", "error", make(regime="weird")),
        Case("fleet env", "events_per_shift=0", "error", make(events_per_shift=0)),
        Case("fleet env", "lead_time=0", "error", make(lead_time=0)),
        Case("fleet env", "step before reset", "error",
             lambda: BrakeWearFleetEnv(atlas=w.atlas, **FLEET).step(FLEET_ACTIONS[0]),
             names=("BrakeWearFleet-v0", "reset")),
        Case("fleet env", "action_masks before reset", "error",
             lambda: BrakeWearFleetEnv(atlas=w.atlas, **FLEET).action_masks(), names=("reset",)),
        Case("fleet env", "step after the episode's end", "error",
             make(*([FLEET_ACTIONS[0]] * (FLEET["episode_shifts"] + 1))),
             names=("BrakeWearFleet-v0", "reset")),
        Case("fleet env", "order 9 (max_order is 8)", "error", first(np.array([0, 1, 9])),
             names=("BrakeWearFleet-v0", "9")),
        Case("fleet env", "action of shape (2,)", "error", first(np.array([0, 1])),
             names=("BrakeWearFleet-v0", r"\(2,\)|2 ")),
        Case("fleet env", "action of shape (1, 3)", "error", first(np.array([[0, 1, 0]])),
             names=("BrakeWearFleet-v0", r"\(1, 3\)")),
        Case("fleet env", "None as the action", "error", first(None),
             names=("BrakeWearFleet-v0", "None")),
    ]  # fmt: skip
    for label, value, names in bad_actions(r"vehicle[ _]0"):
        action = [value, 1, 0]
        cases.append(Case("fleet env", f"vehicle 0's duty {label}", "error", first(action),
                          names=("BrakeWearFleet-v0", *names)))  # fmt: skip
    cases.append(Case("fleet env", "the order 0.7", "error", first([0, 1, 0.7]),
                      names=("BrakeWearFleet-v0", "order", r"0\.7")))  # fmt: skip
    return cases + parallel_cases(w) + fleet_wrapper_cases(w)


def parallel_cases(w: World) -> list[Case]:
    """The PettingZoo version: agents' actions equal the joint action's rollout (each
    agent's observation its slice of the single env's, the reward the fleet's)."""
    n = FLEET["n_vehicles"]

    def joint(a: Any) -> dict[str, Any]:
        return {**{f"vehicle_{v}": a[v] for v in range(n)}, STORE: a[-1]}

    def as_single(rows: list[Any]) -> list[Any]:
        """The parallel env's rollout in the single env's terms (to compare with it)."""
        out = []
        for r in rows:
            obs = r if isinstance(r, dict) else r[0]
            veh = np.stack([obs[f"vehicle_{v}"]["observation"][:10] for v in range(n)])
            flat = np.concatenate([veh.ravel(), obs[STORE]["observation"]]).astype(np.float32)
            if isinstance(r, dict):
                out.append(flat)
                continue
            rew, term, trunc = r[1], r[2], r[3]
            one = {rew[a] for a in rew} | {None}
            out.append((flat, rew[STORE] if len(one) == 2 else None, term[STORE], trunc[STORE]))
        return out

    def prun(actions: list[dict[str, Any]], **kw: Any) -> Callable[[], Any]:
        def run() -> Any:
            env = BrakeWearFleetParallelEnv(atlas=w.atlas, **{**FLEET, **kw})
            obs, _ = env.reset(seed=0)
            rows: list[Any] = [obs]
            for a in actions:
                o, r, te, tr, _ = env.step(a)
                rows.append((o, r, te, tr))
            return as_single(rows)

        return run

    good = [joint(a) for a in FLEET_ACTIONS]
    ref = equals(fleet_ref(w), "= the single env's rollout (seed 0, the joint actions)")
    parked = [np.array([2] * n + [0])] * 2
    cases = [
        Case("fleet parallel", "dict of ints", "correct", prun(good), ref),
        Case("fleet parallel", "dict of np.int64", "correct",
             prun([{k: np.int64(v) for k, v in a.items()} for a in good]), ref),
        Case("fleet parallel", "dict of 0-d int arrays", "correct",
             prun([{k: np.array(v) for k, v in a.items()} for a in good]), ref),
        Case("fleet parallel", "empty dicts: every vehicle parks, no order", "correct",
             prun([{}, {}]), equals(fleet_ref(w, parked), "= parking every vehicle")),
        Case("fleet parallel", "step before reset", "error",
             lambda: BrakeWearFleetParallelEnv(atlas=w.atlas, **FLEET).step(good[0]),
             names=("reset",)),
        Case("fleet parallel", "an unknown agent", "error",
             prun([{**good[0], "vehicle_9": 0}]), names=("vehicle_9",)),
        Case("fleet parallel", "step after the episode's end", "error",
             prun([good[0]] * (FLEET["episode_shifts"] + 1)), names=("reset|done",)),
        Case("fleet parallel", "vehicle_0: array of shape (2,)", "error",
             prun([{**good[0], "vehicle_0": np.array([0, 1])}]), names=("vehicle_0", r"\(2,\)")),
        Case("fleet parallel", "store: order 0.7", "error",
             prun([{**good[0], STORE: 0.7}]), names=(STORE, r"0\.7")),
        Case("fleet parallel", "store: order 9 (max 8)", "error",
             prun([{**good[0], STORE: 9}]), names=(STORE, "9")),
    ]  # fmt: skip
    for label, value, names in bad_actions("vehicle_0"):
        cases.append(Case("fleet parallel", f"vehicle_0: {label}", "error",
                          prun([{**good[0], "vehicle_0": value}]), names=names))  # fmt: skip
    return cases


def fleet_wrapper_cases(w: World) -> list[Case]:
    """FleetRULObservation: each vehicle's estimate is its predictor's own, fed that
    vehicle's events of every shift (a copy per vehicle, reset at a new pad);
    ExpectedRULObservation: within 5% of the true hot-route RUL (simulated ahead)."""
    n = FLEET["n_vehicles"]

    def wrapped(p: str, fields: tuple[str, ...] = ("rul_mean",)) -> Callable[[], Any]:
        def run() -> Any:
            base = gym.make("BrakeWearFleet-v0", atlas=w.atlas, **FLEET)
            env = FleetRULObservation(base, copy.deepcopy(w.fitted[p]), fields)
            return [x if isinstance(x, np.ndarray) else x[0] for x in rollout(env, FLEET_ACTIONS)]

        return run

    def known(p: str) -> Check:
        """The wrapper's observation rebuilt by hand: a copy of the predictor per vehicle
        fed that vehicle's shift in uniform-mix events (``equivalent_batch``), carried onto
        the routes by ``route_rul``."""
        env = BrakeWearFleetEnv(atlas=w.atlas, **FLEET)
        preds = [copy.deepcopy(w.fitted[p]) for _ in range(n)]
        obs, _ = env.reset(seed=0)
        clocks, driven = duty_clocks(w.atlas), duty_clocks(w.atlas, ("hot", "mild", "uniform"))
        fresh = np.array([c.life(env.config.wear.k_mean) for c in clocks.routes])
        age, last = env.pads.pos.astype(float), np.full(n, -1)  # type: ignore[union-attr]
        est: list[Any] = [None] * n
        for pr in preds:
            pr.reset()

        def rows() -> Any:
            r = [fresh if e is None else route_rul(e, age[v : v + 1], clocks).mean[0]
                 for v, e in enumerate(est)]  # fmt: skip
            return np.clip(np.ravel(r) / env.config.events_per_shift, 0, 1e5)

        want = [np.concatenate([obs, rows()]).astype(np.float32)]
        for a in FLEET_ACTIONS:
            obs, _, _, _, info = env.step(a)
            ev = env.shift_events()
            assert ev is not None
            for v in np.flatnonzero((ev.n_done > 0) & (ev.first_event == 0)):
                preds[v].reset()
                age[v], last[v], est[v] = 0.0, -1, None
            vol = np.array([1.0 if e is None else route_rul(e, age[v : v + 1], clocks).volume[0]
                            for v, e in enumerate(est)])  # fmt: skip
            rate = driven.rate_ratio(vol)[np.arange(n), np.maximum(info["vehicles"]["route"], 0)]
            batch, at, vehicles, after = equivalent_batch(ev, age, rate, last)
            age = np.where(ev.n_done > 0, after, age)
            for v in vehicles:
                i = np.flatnonzero(at == v)
                got = preds[v].update(batch[int(i[0]) : int(i[-1]) + 1])
                est[v] = select(got, np.array([len(got) - 1]))
                last[v] = batch.event[i[-1]]
            for v in np.flatnonzero(env.pads.pos == 0):  # type: ignore[union-attr]
                preds[v].reset()
                age[v], last[v], est[v] = 0.0, -1, None
            want.append(np.concatenate([obs, rows()]).astype(np.float32))
        return equals(want, "= the env's observation and a predictor per vehicle", 1e-6)

    def expected() -> Any:
        env = ExpectedRULObservation(gym.make("BrakeWearFleet-v0", atlas=w.atlas, **FLEET))
        obs, _ = env.reset(seed=0)
        per_shift = env.unwrapped.config.events_per_shift  # type: ignore[attr-defined]

        def hot(o: Any) -> Any:  # the hot-route RUL in events, out of (hot, mild) per vehicle
            return o[-2 * n :].reshape(n, 2)[:, 0] * per_shift

        rows = [(hot(obs), env.unwrapped.true_rul("hot"))]  # type: ignore[attr-defined]
        for a in FLEET_ACTIONS:
            obs, *_ = env.step(a)
            rows.append((hot(obs), env.unwrapped.true_rul("hot")))  # type: ignore[attr-defined]
        return np.array([r[0] for r in rows], np.float64), np.array([r[1] for r in rows], float)

    near_truth = Check(
        "within 5% of the true hot-route RUL",
        lambda a: bool(np.all(np.abs(a[0] / np.maximum(a[1], 1) - 1) <= 0.05)),
    )
    return [
        *(Case("fleet wrappers", f"FleetRULObservation ({p})", "correct", wrapped(p), known(p))
          for p in ("twin", "physics", "window", "none")),
        Case("fleet wrappers", "ExpectedRULObservation", "correct", expected, near_truth),
        Case("fleet wrappers", "FleetRULObservation fields=('rul_p90',)", "error",
             wrapped("twin", ("rul_p90",)), names=("rul_p90|fields",)),
        Case("fleet wrappers", "ExpectedRULObservation fields=()", "error",
             lambda: ExpectedRULObservation(BrakeWearFleetEnv(atlas=w.atlas, **FLEET), ())),
        Case("fleet wrappers", "FleetRULObservation around BrakeWear-v0", "error",
             lambda: FleetRULObservation(BrakeWearEnv(atlas=w.atlas, **FAST), w.fitted["twin"])),
        Case("fleet wrappers", "ExpectedRULObservation around BrakeWear-v0", "error",
             lambda: ExpectedRULObservation(BrakeWearEnv(atlas=w.atlas, **FAST))),
    ]  # fmt: skip


# --------------------------------------------------------------------------------- CLI
def cli(*argv: str, read: Callable[[], Any] | None = None) -> Callable[[], Ran]:
    """``brakewear ARGV --quiet`` in this process; its output read back when it succeeds."""

    def run() -> Ran:
        err = io.StringIO()
        with contextlib.redirect_stderr(err):
            try:
                code = brakewear([*argv, "--quiet"])
            except SystemExit as e:  # argparse refuses an option: usage and exit code 2
                code = e.code if isinstance(e.code, int) else 1
        return Ran(code, err.getvalue() or "(no message)", read() if code == 0 and read else None)

    return run


def ran_check(kind: str, test: Callable[[Any], bool]) -> Check:
    return Check(kind, lambda r: isinstance(r, Ran) and r.code == 0 and test(r.output))


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
    model = w.tmp / "cli-model"
    pick = sorted(idl["run_id"].unique())[:1]
    probe_log = idl[idl["run_id"].isin(pick)].iloc[::50]

    def fitted_as(pred: str, data: Path) -> Check:
        """The saved model estimates as the library's fit of the same file does."""
        ref = make_predictor(pred, w.atlas, 0).fit(read_event_log(data))
        want = predict_log(ref, probe_log)
        return ran_check(f"saved model = library fit ({pred})", lambda got: same(got, want))

    def fit(data: Path, pred: str = "twin", *extra: str) -> Callable[[], Ran]:
        out = w.tmp / f"fit-{data.stem}-{pred}-{len(extra)}"
        return cli(
            "fit",
            "--data",
            str(data),
            "--predictor",
            pred,
            "--out",
            str(out),
            *atlas,
            *extra,
            read=lambda: predict_log(load_predictor(out, w.atlas), probe_log),
        )

    def traces(out: Path) -> pd.DataFrame:
        t = pd.read_parquet(out / "traces.parquet")
        return t[["run_id", "event", "rul_mean"]].assign(run_id=t["run_id"].astype(str))

    def predicted_as(log: Path) -> Check:
        want = predict_log(load_predictor(model, w.atlas), read_event_log(log))
        want = want[["run_id", "event", "rul_mean"]].assign(run_id=want["run_id"].astype(str))
        return ran_check(
            "traces.parquet = predict_log",
            lambda got: same_estimates(want.reset_index(drop=True), "", 1e-9).test(
                got.reset_index(drop=True)
            ),
        )

    def predict(log: Path, *extra: str) -> Callable[[], Ran]:
        out = w.tmp / f"pred-{log.stem}-{len(extra)}"
        return cli(
            "predict",
            "--model",
            str(model),
            "--log",
            str(log),
            "--out",
            str(out),
            *atlas,
            *extra,
            read=lambda: traces(out),
        )

    # The model the predict cases use, fitted by the library (the CLI's own fit is a case).
    save_predictor(make_predictor("twin", w.atlas, 0).fit(read_event_log(files["train"])), model,
                   w.atlas)  # fmt: skip
    return [
        Case("fit", "CLI: clean training log", "correct", fit(files["train"], "twin"),
             fitted_as("twin", files["train"])),
        Case("fit", "CLI: clean training log (physics)", "correct", fit(files["train"], "physics"),
             fitted_as("physics", files["train"])),
        Case("fit", "CLI: kelvin log --strict", "error",
             fit(files["kelvin"], "physics", "--strict")),
        Case("fit", "CLI: kelvin log", "warning", fit(files["kelvin"], "physics"),
             fitted_as("physics", files["kelvin"])),
        Case("fit", "CLI: 300 runs of 3 events", "warning", fit(files["short"], "physics"),
             fitted_as("physics", files["short"])),
        Case("fit", "CLI: log lacking columns", "error", fit(w.tmp / "bad.csv", "physics")),
        Case("fit", "CLI: log that does not exist", "error", fit(w.tmp / "nope.csv", "physics")),
        Case("fit", "CLI: unknown predictor", "error", fit(files["train"], "magic")),
        Case("fit", "CLI: --out is a file", "error",
             cli("fit", "--data", str(files["train"]), "--predictor", "none", "--out",
                 str(files["gaps"]), *atlas)),
        Case("predict", "CLI: log with every third event missing", "correct",
             predict(files["gaps"]), predicted_as(files["gaps"])),
        Case("predict", "CLI: kelvin log", "warning", predict(files["kelvin"]),
             predicted_as(files["kelvin"])),
        Case("predict", "CLI: m/s log --strict", "error", predict(files["ms"], "--strict")),
        Case("predict", "CLI: model directory missing", "error",
             cli("predict", "--model", str(w.tmp / "none"), "--log", str(files["gaps"]), *atlas)),
        Case("evaluate", "CLI: no --data", "error",
             cli("evaluate", "--out", str(w.tmp / "e0"), *atlas)),
        Case("evaluate", "CLI: --data not a dataset", "error",
             cli("evaluate", "--data", str(w.tmp / "nodir"), "--out", str(w.tmp / "e1"), *atlas)),
        Case("evaluate", "CLI: unknown predictor", "error",
             cli("evaluate", "--data", str(w.tmp / "data"), "--predictors", "magic", *atlas)),
        Case("diagnose", "CLI: kelvin log --strict", "error",
             cli("diagnose", "--real", str(files["kelvin"]), "--model", str(w.atlas_file),
                 "--out", str(w.tmp / "d0"), "--strict")),
        Case("diagnose", "CLI: log that does not exist", "error",
             cli("diagnose", "--real", str(w.tmp / "nope.csv"), "--out", str(w.tmp / "d1"))),
        Case("diagnose", "CLI: log lacking columns", "error",
             cli("diagnose", "--real", str(w.tmp / "bad.csv"), "--out", str(w.tmp / "d2"))),
        *fleet_study_cases(w, atlas),
        *collision_cases(w, files, model, traces, predicted_as),
    ]  # fmt: skip


TINY_STUDY = ("--predictors", "none,oracle", "--heuristics", "threshold", "--trials", "1",
              "--trials-best", "1", "--tune-episodes", "1", "--eval-episodes", "2", "--shifts",
              "10", "--n-train-runs", "2", "--workers", "0")  # fmt: skip


def costs_of(out: Path) -> Any:
    """A fleet study's costs.json without what differs between runs (timings, paths)."""
    doc = json.loads((out / "costs.json").read_text())
    return _drop(doc, ("seconds", "wall", "elapsed", "out", "figures", "time"))


def _drop(x: Any, words: tuple[str, ...]) -> Any:
    if isinstance(x, dict):
        return {k: _drop(v, words) for k, v in x.items() if not any(s in k for s in words)}
    if isinstance(x, list):
        return [_drop(v, words) for v in x]
    return x


def fleet_study_cases(w: World, atlas: list[str]) -> list[Case]:
    """``brakewear fleet-study`` on a tiny budget: its costs.json equals the library's
    run_fleet_study of the same settings (run once, into another folder)."""
    from agents.fleet.commands.cli import config_from_args
    from agents.fleet.commands.parser import register
    from agents.fleet.study.run import run_fleet_study
    from brake_env.runner import Runner

    lib = w.tmp / "fleet-lib"
    parser = argparse.ArgumentParser()
    register(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["fleet-study", *TINY_STUDY, "--out", str(lib)])
    with Runner(0) as runner, contextlib.redirect_stderr(io.StringIO()):
        run_fleet_study(config_from_args(args), w.atlas, lib, runner)
    want = costs_of(lib)
    out = w.tmp / "fleet-cli"

    def study(*extra: str, to: Path = out) -> Callable[[], Ran]:
        return cli("fleet-study", *TINY_STUDY, "--out", str(to), *atlas, *extra,
                   read=lambda: costs_of(to))  # fmt: skip

    def change(flag: str, value: str) -> Callable[[], Ran]:
        argv = list(TINY_STUDY)
        argv[argv.index(flag) + 1] = value
        return cli("fleet-study", *argv, "--out", str(w.tmp / "fs-bad"), *atlas)

    ok = ran_check("costs.json = the library's run_fleet_study", lambda got: same(got, want))
    return [
        Case("fleet-study", "tiny budget", "correct", study(), ok),
        Case("fleet-study", "run again into the same --out (resumes)", "correct", study(), ok),
        Case("fleet-study", "--shifts 1", "error", change("--shifts", "1")),
        Case("fleet-study", "--eval-episodes 1", "error", change("--eval-episodes", "1")),
        Case("fleet-study", "--predictors magic", "error", change("--predictors", "none,magic")),
        Case("fleet-study", "--heuristics magic", "error", change("--heuristics", "magic")),
        Case("fleet-study", "--trials 0", "error", change("--trials", "0")),
        Case("fleet-study", "--n-train-runs 0", "error", change("--n-train-runs", "0")),
        Case("fleet-study", "--size huge", "error",
             cli("fleet-study", *TINY_STUDY, "--size", "huge", "--out", str(w.tmp / "fs-b"))),
        Case("fleet-study", "--atlas that does not exist", "error",
             cli("fleet-study", *TINY_STUDY, "--out", str(w.tmp / "fs-c"), "--atlas",
                 str(w.tmp / "nope.npz"))),
    ]  # fmt: skip


def collision_cases(
    w: World, files: dict[str, Path], model: Path, traces: Callable[[Path], pd.DataFrame],
    predicted_as: Callable[[Path], Check],
) -> list[Case]:  # fmt: skip
    """One command's --out on another's folder, and a units/ folder holding foreign files:
    refused (a clear error), or the outputs right and the other command's files intact."""
    atlas = ["--atlas", str(w.atlas_file)]
    gaps = files["gaps"]

    def folder(name: str, *argv: str) -> Path:
        d = w.tmp / name
        with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
            assert brakewear([*argv, "--out", str(d), "--quiet", *atlas]) == 0
        return d

    def files_of(d: Path) -> dict[str, bytes]:
        return {str(p.relative_to(d)): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}

    def predict_into(d: Path, foreign: dict[str, str] | None = None) -> Callable[[], Ran]:
        def run() -> Ran:
            for rel, text in (foreign or {}).items():
                (d / rel).parent.mkdir(parents=True, exist_ok=True)
                (d / rel).write_text(text)
            before = files_of(d)
            r = cli("predict", "--model", str(model), "--log", str(gaps), "--out", str(d),
                    *atlas)()  # fmt: skip
            after = files_of(d)
            kept = {k: after.get(k) == v for k, v in before.items()}
            return replace(r, output=(traces(d), kept) if r.code == 0 else None)

        return run

    base = predicted_as(gaps)

    def right_and_kept(kind: str) -> Check:
        return Check(
            kind,
            lambda r: base.test(replace(r, output=r.output[0])) and all(r.output[1].values()),
            lambda r: replace(r, output=(r.output[0], {**r.output[1], "x": False})),
        )

    keep = right_and_kept("traces = predict_log, and every file there before still there")
    fit_dir = folder("col-fit", "fit", "--data", str(files["train"]), "--predictor", "none")
    fs_dir = w.tmp / "fleet-cli"  # the fleet study's, with its units/ (kept after the run)
    pred_dir = folder("col-pred", "predict", "--model", str(model), "--log", str(gaps))

    def fit_into(d: Path) -> Callable[[], Ran]:
        def run() -> Ran:
            before = files_of(d)
            r = cli("fit", "--data", str(files["train"]), "--predictor", "none", "--out", str(d),
                    *atlas)()  # fmt: skip
            after = files_of(d)
            others = {k: after.get(k) == v for k, v in before.items()
                      if k not in (HEADER, ARRAYS)}  # fmt: skip
            life = load_predictor(d, w.atlas).mean_life_events if r.code == 0 else None  # type: ignore[attr-defined]
            return replace(r, output=(life, others))

        return run

    mean_life = float(w.fitted["none"].mean_life_events)  # type: ignore[attr-defined]
    fit_ok = Check(
        "the model = library fit, the other files intact",
        lambda r: r.code == 0 and r.output[0] == mean_life and all(r.output[1].values()),
        lambda r: replace(r, output=(r.output[0] + 1, r.output[1])),
    )
    return [
        # A command's --out that another command wrote is refused (exit 2, naming the
        # other command), and a units/ folder the store did not write is left alone.
        Case("collisions", "predict --out on a fit's model folder", "error",
             predict_into(fit_dir), names=("holds the output of `brakewear fit`",)),
        Case("collisions", "predict --out on a fleet study's folder (its units/)", "error",
             predict_into(fs_dir), names=("holds the output of `brakewear fleet-study`",)),
        Case("collisions", "predict --out on the dataset folder", "correct",
             predict_into(w.tmp / "data"), keep),
        Case("collisions", "fit --out on a new folder", "correct", fit_into(w.tmp / "col-new"),
             fit_ok),
        Case("collisions", "fit --out on a predict's folder", "error", fit_into(pred_dir),
             names=("holds the output of `brakewear predict`",)),
        Case("collisions", "fit --out on a fleet study's folder", "error", fit_into(fs_dir),
             names=("holds the output of `brakewear fleet-study`",)),
        Case("collisions", "predict: units/ holds notes.txt", "error",
             predict_into(w.tmp / "col-u1", {"units/notes.txt": "mine"}),
             names=("notes.txt", "no settings.json")),
        Case("collisions", "predict: units/ holds a foreign JSON", "error",
             predict_into(w.tmp / "col-u2", {"units/results.json": '{"a": 1}'}),
             names=("results.json", "no settings.json")),
        Case("collisions", "predict: units/ holds another run's settings.json", "error",
             predict_into(w.tmp / "col-u3", {"units/settings.json": '{"seed": 7}'})),
        Case("collisions", "fleet-study: units/ holds a foreign JSON", "error",
             _study_foreign(w, atlas), names=("mine.json", "no settings.json")),
    ]  # fmt: skip


def _study_foreign(w: World, atlas: list[str]) -> Callable[[], Ran]:
    def run() -> Ran:
        d = w.tmp / "col-fs"
        (d / "units").mkdir(parents=True, exist_ok=True)
        (d / "units" / "mine.json").write_text('{"a": 1}')
        r = cli("fleet-study", *TINY_STUDY, "--out", str(d), *atlas)()
        kept = (d / "units" / "mine.json").is_file()
        return replace(r, output=(costs_of(d), kept) if r.code == 0 else None)

    return run


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

    renamed: dict[Path, bytes] = {}

    def rename(d: Path) -> None:  # no unit's name: the store leaves it alone (issue 44)
        f = json_of(d).rename(d / "pads-0002-0123456789.json")
        renamed[f] = f.read_bytes()

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

    two = Check("the two saved units", lambda got: got == keys[:2])
    redone = Check("the damaged unit redone", lambda got: got == keys[1:2])
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
            "unit file renamed: not a unit, left alone",
            "correct",
            reopen(filled(), rename),
            Check("the renamed file not taken for a unit", lambda got: got == [keys[1]]),
            lost=unchanged(renamed),
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


# ------------------------------------------------- set aside, output marks, hostile ids
def unchanged(files: dict[Path, bytes]) -> Callable[[], list[str]]:
    """``Case.lost`` of ``files`` (filled in by the case's run): those gone or changed."""
    return lambda: [p.name for p, b in files.items() if not p.is_file() or p.read_bytes() != b]


def keep(files: dict[Path, bytes], path: Path, data: bytes) -> Path:
    """Write ``data`` to ``path``, noted as a file the case must leave as it is."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)
    files[path] = data
    return path


Run = tuple[Callable[[], Any], dict[Path, bytes]]  # a case's run and the files it must keep


def set_aside_cases(w: World) -> list[Case]:
    """A unit store after a killed run: a user's file named like a unit is never moved or
    deleted; damaged units are set aside under numbers, never overwritten or deleted."""
    keys, settings = ["pads-0000", "pads-0001", "pads-0002"], {"seed": 0, "what": "aside"}
    result = {"life": np.arange(5)}
    n = iter(range(1000))

    def killed_store() -> Path:  # two of three units done, then the run was stopped
        d = w.tmp / f"aside-{next(n)}" / "units"
        with units.open_store(d, settings, keys, "probe") as st:
            st.save(keys[0], result)
            st.save(keys[1], result)
        return d

    def user_file(discard: bool) -> Run:
        files: dict[Path, bytes] = {}

        def run() -> Any:
            d = killed_store()
            keep(files, d / "report-2026112801.json", b'{"mine": true}\n')
            with units.open_store(d, settings, keys, "probe") as st:
                got = st.keys()
                if discard:
                    st.save(keys[2], result)
                    st.discard()
            return sorted(p.name for p in d.iterdir()) if discard else got

        return run, files

    def damaged(times: int, discard: bool = False) -> Run:
        files: dict[Path, bytes] = {}

        def run() -> Any:
            d = killed_store()
            for i in range(times):
                f = sorted(d.glob("pads-0000-*.json"))[0]
                f.write_bytes(f.read_bytes()[: 20 + i])
                files[d / "damaged" / f"{f.stem}.{i + 1}.json"] = f.read_bytes()
                with units.open_store(d, settings, keys, "probe") as st:
                    st.save(keys[0], result)
                    if discard:
                        st.discard()
            return sorted(p.name for p in (d / "damaged").iterdir())

        return run, files

    def damaged_is_a_file() -> Run:
        files: dict[Path, bytes] = {}

        def run() -> Any:
            d = killed_store()
            f = sorted(d.glob("pads-0001-*.json"))[0]
            f.write_bytes(f.read_bytes()[:30])
            keep(files, d / "damaged", b"my notes")
            return units.open_store(d, settings, keys, "probe")

        return run, files

    stem = units.UnitStore(w.tmp / "aside-names", {})._stem(keys[0]).name
    pairs = [f"{stem}.{i}{s}" for i in (1, 2) for s in (".json", ".npz")]
    table_: list[tuple[str, str, Run, Check | None, tuple[str, ...]]] = [
        ("a user's file named like a unit: reopened", "correct", user_file(False),
         Check("the two saved units", lambda got: got == keys[:2]), ()),
        ("a user's file named like a unit: reopened, discarded", "correct", user_file(True),
         Check("only the user's file left", lambda got: got == ["report-2026112801.json"]), ()),
        ("a unit damaged twice: two numbered copies", "correct", damaged(2),
         Check("both copies and their arrays", lambda got: got == pairs), ()),
        ("damaged/ outlives the store's discard", "correct", damaged(1, discard=True),
         Check("the copy and its arrays", lambda got: got == pairs[:2]), ()),
        ("a file named damaged", "error", damaged_is_a_file(), None, ("damaged is a file",)),
    ]  # fmt: skip
    return [
        Case("set aside", name, expect, run, check, names, unchanged(files))
        for name, expect, (run, files), check, names in table_
    ]


HOLD = (
    "import os, sys, time; from brake_env.run_lock import hold_output;"
    " held = hold_output(sys.argv[1], 'fleet-study', ['fleet-study']); held.__enter__();"
    " print('held', flush=True); time.sleep(60) if sys.argv[2] == 'run' else os._exit(0)"
)


def held(d: Path, how: str) -> subprocess.Popen[str]:
    """A process that marks ``d`` as a fleet study's, then keeps running (``how`` "run")
    or dies without a word ("kill": what a SIGKILL leaves)."""
    proc = subprocess.Popen([sys.executable, "-c", HOLD, str(d), how], stdout=subprocess.PIPE,
                            text=True)  # fmt: skip
    assert proc.stdout is not None and proc.stdout.readline().strip() == "held"
    if how == "kill":
        proc.wait()
    return proc


BAD_MARKS = {
    "garbage": b"{bad",
    "empty": b"",
    "binary": b"\x00\xff\xfe\x80",
    "a JSON list": b'["fleet-study"]',
    "a non-string command": b'{"format": 1, "command": 5}',
    "of another format": b'{"format": 2, "command": "fleet-study"}',
}


def mark_cases(w: World) -> list[Case]:
    """``--out`` marks: written when a command starts, so a running or killed fleet study's
    folder is refused to other commands and resumed by its own; a live one refused naming
    its process; an unreadable mark refused naming it; the folder's files kept."""
    atlas = ["--atlas", str(w.atlas_file)]
    n = iter(range(1000))

    def fit(d: Path) -> Callable[[], Ran]:
        return cli("fit", "--data", str(w.tmp / "train.csv"), "--predictor", "none", "--out",
                   str(d), *atlas)  # fmt: skip

    def study(d: Path) -> Callable[[], Ran]:
        return cli("fleet-study", *TINY_STUDY, "--out", str(d), *atlas, read=lambda: costs_of(d))

    def into(how: str, command: Callable[[Path], Callable[[], Ran]], resumes: bool = False) -> Run:
        """``command`` on a fleet study's folder; the study's mark must stay unless the
        study itself ``resumes`` (it marks the folder again, as its own process)."""
        files: dict[Path, bytes] = {}

        def run() -> Ran:
            d = w.tmp / f"mark-{next(n)}"
            proc = held(d, how)
            try:
                if not resumes:
                    files[d / OUTPUT_MARK] = (d / OUTPUT_MARK).read_bytes()
                keep(files, d / "notes" / "notes.txt", b"the study's own")
                return command(d)()
            finally:
                proc.kill()
                proc.wait()

        return run, files

    def bad_mark(data: bytes | None) -> Run:
        files: dict[Path, bytes] = {}

        def run() -> Ran:
            d = w.tmp / f"mark-{next(n)}"
            keep(files, d / "costs.json", b'{"theirs": 1}\n')
            if data is None:
                keep(files, d / OUTPUT_MARK / "x", b"a folder")
            else:
                keep(files, d / OUTPUT_MARK, data)
            return fit(d)()

        return run, files

    study_ok = ran_check("costs.json = the library's run_fleet_study",
                         lambda got: same(got, costs_of(w.tmp / "fleet-lib")))  # fmt: skip
    other = ("holds the output of `brakewear fleet-study`",)
    unreadable = ("is not a mark brakewear writes", re.escape(OUTPUT_MARK))
    table_: list[tuple[str, str, Run, Check | None, tuple[str, ...]]] = [
        ("fit --out on a killed fleet study's folder", "error", into("kill", fit), None, other),
        ("fit --out on a running fleet study's folder", "error", into("run", fit), None, other),
        ("fleet-study --out on a running one's folder", "error", into("run", study), None,
         (r"in use by another run \(fleet-study, pid \d+",)),
        ("fleet-study resumes its killed folder", "correct", into("kill", study, True), study_ok,
         ()),
        *((f"fit --out with a mark {what}", "error", bad_mark(data), None, unreadable)
          for what, data in BAD_MARKS.items()),
        ("fit --out with a mark that is a folder", "error", bad_mark(None), None, unreadable),
    ]  # fmt: skip
    return [
        Case("output marks", name, expect, run, check, names, unchanged(files))
        for name, expect, (run, files), check, names in table_
    ]


HOSTILE_IDS = ("=cmd|' /C calc'!A0", '+HYPERLINK("http://x.example","y")', "@SUM(A1:A9)",
               "-2+3", "\t=1+1", "\r=1+1")  # fmt: skip
HOSTILE_LABELS = ("$x$", r"$\x$", "$^$", "pad $5", "_hidden", "a\\$b$")


def drawn(label: str) -> list[str]:
    """``label`` as a title, tick label and legend entry drawn on the Agg canvas: the texts
    as shown (``<math>`` where matplotlib parses mathtext), zero-width spaces removed."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure()
    ax = fig.subplots()
    ax.plot([0, 1], [0, 1], label=label)
    ax.set_yticks([0.5], [label])
    ax.set_title(label)
    texts = [ax.title, ax.get_yticklabels()[0], *ax.legend().get_texts()]
    FigureCanvasAgg(fig).draw()
    # how matplotlib reads each text: (the text, whether it is mathtext); private, but
    # it is the only place that decides
    shown = [t._preprocess_math(t.get_text()) for t in texts]  # type: ignore[attr-defined]
    return ["<math>" if math else text.replace("\u200b", "") for text, math in shown]


def hostile_id_cases(w: World) -> list[Case]:
    """Pad ids a spreadsheet would run as formulas, written by :func:`write_csv` (each cell
    read back: a leading quote, the number beside it still a number); ids with a carriage
    return (the row kept); ids matplotlib would parse as mathtext (:func:`plain_text`)."""

    def cell(run_id: str) -> Callable[[], Any]:
        def run() -> tuple[str, str]:
            frame = pd.DataFrame({"run_id": [run_id], "rul_mean": [-1.5]})
            with open(write_csv(frame, w.tmp / "hostile.csv"), newline="") as f:
                row = next(csv.DictReader(f))
            return row["run_id"], row["rul_mean"]

        return run

    def rows() -> Any:
        frame = pd.DataFrame({"run_id": ["a\rb", "c\nd", "e"], "rul_mean": [1.0, -2.0, 3.0]})
        back = pd.read_csv(write_csv(frame, w.tmp / "rows.csv"))
        return back["run_id"].tolist(), back["rul_mean"].to_numpy()

    return [
        *(Case("hostile ids", f"CSV cell {i!r}", "correct", cell(i),
               equals(("'" + i, "-1.5"), "a leading quote; -1.5 a number")) for i in HOSTILE_IDS),
        Case("hostile ids", "CSV cell 'A-1'", "correct", cell("A-1"), equals(("A-1", "-1.5"), "")),
        Case("hostile ids", "CSV: a carriage return in a pad id", "correct", rows,
             equals((["a\rb", "c\nd", "e"], np.array([1.0, -2.0, 3.0])), "rows kept")),
        *(Case("hostile ids", f"figure label {lab!r}", "correct",
               functools.partial(lambda s: drawn(plain_text(s)), lab),
               equals([lab] * 3, "drawn as given")) for lab in HOSTILE_LABELS),
    ]  # fmt: skip


def trust_cases(w: World) -> list[Case]:
    return set_aside_cases(w) + mark_cases(w) + hostile_id_cases(w)


def all_cases(w: World) -> list[Case]:
    return (
        log_cases(w) + gap_cases(w) + model_cases(w) + env_cases(w) + fleet_cases(w)
        + cli_cases(w) + store_cases(w) + trust_cases(w) + input_cases(w, sys.modules[__name__])
    )  # fmt: skip


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--verbose", action="store_true", help="one line per case")
    args = ap.parse_args()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as d:
        w = build_world(Path(d), args.seed)
        cases = all_cases(w)
        results, checked, failing = [], 0, 0
        for c in cases:
            res, detail, answer = outcome(c)
            results.append((c, res, detail))
            if res in ("correct", "warning"):
                checked += 1
                failing += shown_to_fail(c, answer)
            if args.verbose or res in OUTCOMES[3:]:
                print(f"{res:20s} {c.area:14s} {c.name}: {detail}", file=sys.stderr)
    counts: dict[str, Counter[str]] = {}
    for c, res, _ in results:
        counts.setdefault(c.area, Counter())[res] += 1
    rows = [["area", "cases", *OUTCOMES]]
    for area, cnt in counts.items():
        rows.append([area, str(sum(cnt.values())), *(str(cnt[o]) for o in OUTCOMES)])
    total = Counter(res for _, res, _ in results)
    rows.append(["all", str(len(results)), *(str(total[o]) for o in OUTCOMES)])
    print(table(rows))
    print(
        f"\n{failing} of {checked} answer checks of the passing cases shown able to fail"
        " (each rejected a deliberately wrong answer)"
    )
    print(f"{len(results)} cases (seed {args.seed}), {time.perf_counter() - t0:.0f} s")
    return 1 if any(total[o] for o in OUTCOMES[3:]) else 0


if __name__ == "__main__":
    raise SystemExit(main())
