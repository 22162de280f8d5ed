"""``brakewear predict`` in units: the same files in this process and on Ray, the same as the
whole fleet at once to rounding, and a run cut off (a failed unit, a killed process)
resumes from the saved units without redoing them."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from brake_env.cli.main import main
from brake_env.data.datasets import DatasetSpec, make_dataset
from brake_env.data.schema import GROUND_TRUTH, read_event_log, write_event_log
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime
from brake_env.output import OUTPUT_MARK
from brake_env.prognostics.commands import fit_predict, predict_units
from brake_env.prognostics.commands.fit_predict import missing_channels
from brake_env.prognostics.fleet import ESTIMATE_FIELDS, predict_runs
from brake_env.prognostics.persist import load_predictor
from brake_env.prognostics.protocol import Predictor, iter_runs
from brake_env.runner import UnitStore

# Seven pads of ~11,000-event lives on the coarse test atlas, logged from event 2,000 to 4,999.
SPEC = DatasetSpec(n_train=4, n_id=7, n_ood_slow=0, n_ood_fast=0, wear=WearRegime(2e-5, 2e-6))
N_PADS = 7


@pytest.fixture(scope="module")
def fitted(small_atlas: Atlas, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A twin fitted through the CLI, its atlas file and a fleet log without truth."""
    d = tmp_path_factory.mktemp("predict")
    ds = make_dataset(small_atlas, SPEC, seed=5)
    write_event_log(ds.logs["train"], d / "train.parquet")
    fleet = ds.logs["id"]
    fleet = fleet[(fleet["event"] >= 2000) & (fleet["event"] < 5000)]
    write_event_log(fleet.drop(columns=list(GROUND_TRUTH)), d / "fleet.parquet")
    atlas = small_atlas.save(d / "atlas.npz")
    argv = ["fit", "--data", str(d / "train.parquet"), "--predictor", "twin"]
    assert main([*argv, "--out", str(d / "model"), "--atlas", str(atlas), "--quiet"]) == 0
    return {"model": d / "model", "atlas": atlas, "log": d / "fleet.parquet"}


def predict_argv(fitted: dict[str, Path], out: Path, *extra: str) -> list[str]:
    return [
        "predict",
        *("--model", str(fitted["model"]), "--log", str(fitted["log"])),
        *("--atlas", str(fitted["atlas"]), "--out", str(out), "--quiet", *extra),
    ]


def predict(fitted: dict[str, Path], out: Path, *extra: str) -> Path:
    assert main(predict_argv(fitted, out, *extra)) == 0
    return out


def assert_same_outputs(a: Path, b: Path) -> None:
    assert (a / "fleet.csv").read_bytes() == (b / "fleet.csv").read_bytes()
    doc_a, doc_b = (json.loads((p / "fleet.json").read_text()) for p in (a, b))
    doc_a.pop("model"), doc_b.pop("model")  # the only paths that may differ
    assert doc_a == doc_b
    pd.testing.assert_frame_equal(
        pd.read_parquet(a / "traces.parquet"), pd.read_parquet(b / "traces.parquet")
    )


# The whole fleet at once: the reference the units agree with.
def run_fleet(pred: Predictor, log: pd.DataFrame) -> pd.DataFrame:
    """Every pad of ``log`` through ``pred`` in one go (all at once when it has a fleet of its
    own, :func:`~brake_env.prognostics.fleet.predict_runs`): one row per event, pads in order
    of first appearance, with ``run_id``, ``event`` and the estimate's columns: the
    reference the units' :func:`merge` agrees with to rounding."""
    runs = list(iter_runs(log))
    ests = predict_runs(pred, [ev for _, ev in runs])
    sizes = [len(ev) for _, ev in runs]
    names = pd.Index([r for r, _ in runs])
    codes = np.repeat(np.arange(len(runs)), sizes)
    frame = pd.DataFrame(
        {
            "run_id": pd.Categorical.from_codes(codes, names),
            "event": np.concatenate([ev.event for _, ev in runs]),
        }
    )
    for f in ESTIMATE_FIELDS:
        if all(getattr(e, f) is not None for e in ests):  # fields the predictor gives
            frame[f] = np.concatenate([getattr(e, f) for e in ests])
    return frame


def fleet_table(traces: pd.DataFrame, missing: dict[str, list[str]]) -> pd.DataFrame:
    """One row per pad, at its last logged event, sorted by RUL (most urgent first)."""
    g = traces.groupby("run_id", observed=True, sort=False)
    last = g.tail(1).set_index("run_id")
    rows = pd.DataFrame(
        {
            "run_id": last.index.astype(str),
            "events_logged": g.size().to_numpy(),
            "first_event": g["event"].first().to_numpy(),
            "events_since_install": last["event"].to_numpy() + 1,
        }
    )
    for f in ESTIMATE_FIELDS:
        if f in last:
            rows[f] = last[f].to_numpy()
    return predict_units.sort_table(rows, missing)


def test_in_process_on_ray_and_whole_fleet_agree(
    fitted: dict[str, Path], tmp_path: Path, local_ray: object
) -> None:
    here = predict(fitted, tmp_path / "here", "--pads-per-unit", "3")
    on_ray = predict(fitted, tmp_path / "ray", "--pads-per-unit", "3", "--workers", "2")
    assert_same_outputs(here, on_ray)
    assert not (here / "units").exists() and not (on_ray / "units").exists()
    assert sorted(p.name for p in here.iterdir()) == [
        OUTPUT_MARK,
        "fleet.csv",
        "fleet.json",
        "fleet.png",
        "traces.parquet",
    ]

    # All pads in one fleet: the same rows, the estimates equal to rounding.
    log = read_event_log(fitted["log"])
    pred = load_predictor(fitted["model"], Atlas.load(fitted["atlas"]))
    whole = run_fleet(pred, log)
    table = fleet_table(whole, missing_channels(log))
    traces = pd.read_parquet(here / "traces.parquet")
    got = pd.read_csv(here / "fleet.csv", keep_default_na=False)
    assert len(traces) == len(log) and traces["run_id"].nunique() == N_PADS
    pd.testing.assert_frame_equal(traces, whole, check_exact=False, rtol=1e-9)
    # the table's own columns first, the planner's appended after them (planner_units)
    assert list(got.columns[: table.shape[1]]) == list(table.columns)
    pd.testing.assert_frame_equal(got[table.columns], table, check_exact=False, rtol=1e-9)
    assert (got["events_since_install"] == 5000).all() and (got["first_event"] == 2000).all()


def test_a_failed_unit_alone_is_redone_and_the_files_are_the_same(
    fitted: dict[str, Path],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    reference = predict(fitted, tmp_path / "reference", "--pads-per-unit", "2")
    real = predict_units.predict_pads
    calls: list[list[str]] = []

    def flaky(model, atlas, runs):  # type: ignore[no-untyped-def]
        calls.append([r for r, _ in runs])
        if len(calls) == 2 and fail:
            raise RuntimeError("worker lost")
        return real(model, atlas, runs)

    monkeypatch.setattr(predict_units, "predict_pads", flaky)
    out = tmp_path / "resumed"
    fail = True
    assert main(predict_argv(fitted, out, "--pads-per-unit", "2")) == 2
    assert len(calls) == 4  # the units after the failed one ran and were saved
    settings = json.loads((out / "units" / "settings.json").read_text())
    assert UnitStore(out / "units", settings).keys() == ["pads-0000", "pads-0002", "pads-0003"]
    assert "pads-0001: RuntimeError: worker lost" in capsys.readouterr().err

    # Other settings on this store are refused, naming what changed.
    assert main(predict_argv(fitted, out, "--pads-per-unit", "3")) == 2
    assert "pads_per_unit: 2 -> 3" in capsys.readouterr().err

    failed, calls[:] = calls[1], []
    fail = False
    predict(fitted, out, "--pads-per-unit", "2")
    assert calls == [failed]
    assert "predict: resuming: 3 of 4 units already done" in capsys.readouterr().err
    assert_same_outputs(reference, out)
    assert not (out / "units").exists()


def test_a_killed_predict_resumes_from_the_saved_units(
    fitted: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    reference = predict(fitted, tmp_path / "reference", "--pads-per-unit", "1")
    out = tmp_path / "killed"
    argv = predict_argv(fitted, out, "--pads-per-unit", "1")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    proc = subprocess.Popen([sys.executable, "-m", "brake_env.cli.main", *argv], env=env)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and proc.poll() is None:
        if len(list((out / "units").glob("pads-*.json"))) >= 2:
            proc.send_signal(signal.SIGKILL)
            break
        time.sleep(0.002)
    proc.wait()
    if proc.returncode == 0:  # pragma: no cover - finished before the kill: nothing to resume
        pytest.skip("predict finished before it could be killed")
    assert proc.returncode == -signal.SIGKILL
    saved = len(list((out / "units").glob("pads-*.json")))
    assert 2 <= saved < N_PADS

    calls: list[str] = []
    real = predict_units.predict_pads

    def counted(model, atlas, runs):  # type: ignore[no-untyped-def]
        calls.extend(r for r, _ in runs)
        return real(model, atlas, runs)

    monkeypatch.setattr(predict_units, "predict_pads", counted)
    predict(fitted, out, "--pads-per-unit", "1")
    assert len(calls) == N_PADS - saved
    assert_same_outputs(reference, out)


def test_damaged_units_are_named_before_the_start_up_and_redone(
    fitted: dict[str, Path],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    reference = predict(fitted, tmp_path / "reference", "--pads-per-unit", "2")
    real = predict_units.predict_pads
    calls: list[list[str]] = []

    def last_fails(model, atlas, runs):  # type: ignore[no-untyped-def]
        calls.append([r for r, _ in runs])
        if len(calls) == 4:
            raise RuntimeError("worker lost")
        return real(model, atlas, runs)

    monkeypatch.setattr(predict_units, "predict_pads", last_fails)
    out = tmp_path / "damaged"
    assert main(predict_argv(fitted, out, "--pads-per-unit", "2")) == 2
    units = out / "units"
    cut = next(units.glob("pads-0000-*.json"))
    cut.write_bytes(cut.read_bytes()[:40])
    npz = next(units.glob("pads-0001-*.npz"))
    npz.write_bytes(npz.read_bytes()[:-9] + b"012345678")
    capsys.readouterr()

    # The damage is told before the model is loaded (the long start-up).
    told: list[str] = []
    loaded = fit_predict.load_predictor

    def load(*a):  # type: ignore[no-untyped-def]
        told.append(capsys.readouterr().err)
        return loaded(*a)

    monkeypatch.setattr(fit_predict, "load_predictor", load)
    calls[:] = []
    predict(fitted, out, "--pads-per-unit", "2")
    assert f"predict: unit pads-0000: {cut} is damaged (not whole JSON" in told[0]
    assert f"predict: unit pads-0001: {npz.with_suffix('.json')} is damaged (its arrays" in told[0]
    assert "predict: resuming: 1 of 4 units already done" in told[0]
    assert len(calls) == 3  # the two damaged units and the failed one
    assert_same_outputs(reference, out)


def test_a_second_predict_into_the_same_out_refuses_naming_the_first(
    fitted: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "busy"
    code = (
        "import sys, time; from brake_env.units import open_store;"
        " s = open_store(sys.argv[1], {}, [], 'predict'); print('locked', flush=True);"
        " time.sleep(60)"
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    first = subprocess.Popen(
        [sys.executable, "-c", code, str(out / "units")], stdout=subprocess.PIPE, text=True, env=env
    )
    try:
        assert first.stdout is not None and first.stdout.readline().strip() == "locked"
        assert main(predict_argv(fitted, out)) == 2
        err = capsys.readouterr().err
        assert f"{out / 'units'} is in use by another run (predict, pid {first.pid} on" in err
        assert not (out / "fleet.csv").exists()
    finally:
        first.kill()
        first.wait()
    (out / "units" / "settings.json").unlink()  # the stand-in's settings are not predict's
    predict(fitted, out)  # the first is gone: its lock is taken over
    assert "taking over the lock" in capsys.readouterr().err


def test_pads_are_cut_into_readable_units_in_order() -> None:
    runs = [(f"p{i}", None) for i in range(5)]
    units = predict_units.pad_units("model", "atlas", runs, 2)  # type: ignore[arg-type]
    assert [u.key for u in units] == ["pads-0000", "pads-0001", "pads-0002"]
    assert [[r for r, _ in u.args[2]] for u in units] == [["p0", "p1"], ["p2", "p3"], ["p4"]]
    with pytest.raises(ValueError, match="pads per unit must be >= 1"):
        predict_units.pad_units("model", "atlas", runs, 0)  # type: ignore[arg-type]
