"""Plausibility checks (issue 22 item 2): the issue's cases are named, with their evidence;
clean simulated logs raise nothing; ``strict`` makes findings one error; the commands warn
before the long work."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from brake_env.cli.main import main
from brake_env.data.datasets import Dataset, DatasetSpec, make_dataset
from brake_env.data.plausibility import (
    ImplausibleDataError,
    PlausibilityConfig,
    PlausibilityWarning,
    check_log,
    check_wear_coeff,
    report,
    warn_implausible,
)
from brake_env.data.schema import write_event_log
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime

# Lives of ~6,000 events on the default atlas: quick, and K 10x nominal is plausible.
SPEC = DatasetSpec(n_train=6, n_id=3, n_ood_slow=1, n_ood_fast=1, wear=WearRegime(2e-5, 2e-6))


@pytest.fixture(scope="module")
def data(atlas: Atlas) -> Dataset:
    return make_dataset(atlas, SPEC, seed=5)


def _checks(findings: list) -> dict[str, tuple[str, ...]]:
    return {f.check: f.runs for f in findings}


def test_clean_simulated_logs_raise_nothing(atlas: Atlas, data: Dataset) -> None:
    for split, log in data.logs.items():
        assert check_log(log, atlas, lives=True) == [], split


def test_kelvin_temperatures_are_named(atlas: Atlas, data: Dataset) -> None:
    log = data.logs["id"]
    found = check_log(log.assign(temp_c=log["temp_c"] + 273.15), atlas)
    assert _checks(found) == {"response": tuple(log["run_id"].unique())}
    msg = found[0].message("predict")
    assert "logged in kelvin" in msg and "id-00" in msg and "+2" in msg  # median excess


def test_fahrenheit_and_a_bias_sensor_are_told_apart(atlas: Atlas, data: Dataset) -> None:
    log = data.logs["id"]
    (f,) = check_log(log.assign(temp_c=log["temp_c"] * 1.8 + 32), atlas)
    assert "Fahrenheit" in f.evidence
    (b,) = check_log(log.assign(temp_c=log["temp_c"] - 150.0), atlas)
    assert "sensor bias" in b.evidence and "-1" in b.evidence


def test_speeds_in_m_per_s_are_named(atlas: Atlas, data: Dataset) -> None:
    log = data.logs["id"]
    found = check_log(log.assign(speed_kmh=log["speed_kmh"] / 3.6), atlas)
    checks = _checks(found)
    assert set(checks) >= {"envelope", "energy"}
    text = " ".join(f.evidence for f in found)
    assert "m/s (x3.6)" in text and "speed_kmh logged in m/s" in text


def test_mass_in_tonnes_and_slope_in_degrees(atlas: Atlas, data: Dataset) -> None:
    log = data.logs["id"]
    t = " ".join(f.evidence for f in check_log(log.assign(mass_kg=log["mass_kg"] / 1000), atlas))
    assert "t (x1000)" in t
    d = check_log(log.assign(slope_rad=np.degrees(log["slope_rad"])), atlas)
    assert "deg (x pi/180)" in " ".join(f.evidence for f in d)


def test_ten_thousand_runs_of_three_events_are_too_short(atlas: Atlas, data: Dataset) -> None:
    one = data.logs["train"].iloc[:3].drop(columns=["failed"], errors="ignore")
    log = pd.concat(
        [one.assign(run_id=f"r{i:05d}", event=np.arange(3)) for i in range(10_000)],
        ignore_index=True,
    )
    found = check_log(log, atlas, lives=True)
    assert len(_checks(found)["short"]) == 10_000
    assert "after 3 events" in found[0].evidence
    assert check_log(log, atlas) == []  # not lives (predict): nothing to say


def test_unmarked_censoring_is_found_by_reverse_inference(atlas: Atlas, data: Dataset) -> None:
    """Pads removed at 50-90% of their life, written without ``failed``: each counts as a
    failure, while its temperatures say it ended far above the failure volume."""
    train = data.logs["train"]
    life = train.groupby("run_id", observed=True)["event"].transform("max") + 1
    names = list(train["run_id"].unique())
    frac = dict(zip(names, np.linspace(0.5, 0.9, len(names)), strict=True))
    share = train["run_id"].astype(str).map(frac).astype(float)
    cut = train[train["event"] < share * life].drop(columns=["failed", "rul_events"])
    found = check_log(cut, atlas, lives=True)
    assert _checks(found) == {"censoring": tuple(names)}
    assert "failure volume" in found[0].evidence and "'failed' false" in found[0].evidence
    # Marked as removed (``failed`` false), the same runs are fine.
    assert check_log(cut.assign(failed=False), atlas, lives=True) == []


def test_fitted_wear_coeff_far_from_physical() -> None:
    assert check_wear_coeff("twin", 2e-5) == []
    (f,) = check_wear_coeff("twin", 0.079)
    assert "K = 0.079, 3.95e+04x the nominal 2e-06" in f.evidence
    assert check_wear_coeff("physics", float("nan"))[0].check == "fitted"


def test_report_warns_or_raises_with_strict(atlas: Atlas, data: Dataset) -> None:
    log = data.logs["id"].assign(temp_c=lambda d: d["temp_c"] + 273.15)
    with pytest.warns(PlausibilityWarning, match=r"predict: implausible \(response\)"):
        warn_implausible(log, atlas, "predict")
    with pytest.raises(ImplausibleDataError, match="kelvin") as e:
        warn_implausible(log, atlas, "predict", strict=True)
    assert isinstance(e.value, ValueError)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        report([], "x", strict=True)  # nothing found: silent
    with pytest.raises(ValueError, match="share"):
        PlausibilityConfig(share=1.5)


def test_commands_warn_before_the_long_work_and_strict_stops(
    atlas: Atlas, data: Dataset, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    atlas_file = atlas.save(tmp_path / "atlas.npz")
    log = data.logs["id"].assign(temp_c=lambda d: d["temp_c"] + 273.15)
    path = write_event_log(log, tmp_path / "kelvin.csv")
    args = ["fit", "--data", str(path), "--predictor", "physics", "--atlas", str(atlas_file)]
    args += ["--quiet", "--out", str(tmp_path / "m")]
    assert main([*args, "--strict"]) == 2
    err = capsys.readouterr().err
    assert "implausible (response)" in err and "logged in kelvin" in err
    assert not (tmp_path / "m").exists()  # stopped before fitting
    with pytest.warns(PlausibilityWarning, match="kelvin"):
        assert main(args) == 0
