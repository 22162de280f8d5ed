"""``brakewear predict``'s planner columns (issue 42): appended after the current ones, as-of
time and events per shift read from the log's time stamps, the twin's route RUL, the flags
and their errors."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from brake_env.cli.main import main
from brake_env.data.datasets import DatasetSpec, make_dataset
from brake_env.data.schema import GROUND_TRUTH, write_event_log
from brake_env.env.fleet.route_rul import duty_clocks
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime
from brake_env.prognostics.planner_units import PLANNER_ROUTES

SPEC = DatasetSpec(n_train=4, n_id=3, n_ood_slow=0, n_ood_fast=0, wear=WearRegime(2e-5, 2e-6))
CURRENT = [  # predict's columns before issue 42, in their order
    *("run_id", "events_logged", "first_event", "events_since_install"),
    *("rul_mean", "rul_lower", "rul_upper", "volume_frac", "wear_coeff", "missing_channels"),
]
PER_DAY = 800  # events a day in the log written here: 400 a shift of 12 h
T0 = 1.7e9


@pytest.fixture(scope="module")
def fitted(small_atlas: Atlas, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A twin fitted through the CLI; three pads' first 2,500 events, with time stamps
    (an event every 86,400 / 800 s from T0) and without."""
    d = tmp_path_factory.mktemp("planner")
    ds = make_dataset(small_atlas, SPEC, seed=3)
    write_event_log(ds.logs["train"], d / "train.parquet")
    atlas = small_atlas.save(d / "atlas.npz")
    argv = ["fit", "--data", str(d / "train.parquet"), "--predictor", "twin"]
    assert main([*argv, "--out", str(d / "model"), "--atlas", str(atlas), "--quiet"]) == 0
    log = ds.logs["id"].drop(columns=list(GROUND_TRUTH))
    log = log[log["event"] < 2500].reset_index(drop=True)
    write_event_log(log, d / "plain.parquet")
    log.insert(2, "time_s", T0 + log["event"] * (86_400 / PER_DAY))
    write_event_log(log, d / "timed.parquet")
    return {"model": d / "model", "atlas": atlas, "timed": d / "timed.parquet", "dir": d}


def predict(fitted: dict[str, Path], log: str, out: Path, *extra: str) -> int:
    argv = ["predict", "--model", str(fitted["model"]), "--log", str(fitted["dir"] / log)]
    return main([*argv, "--atlas", str(fitted["atlas"]), "--out", str(out), "--quiet", *extra])


def test_planner_columns_follow_the_current_ones(fitted, small_atlas, tmp_path):
    out = tmp_path / "p"
    assert predict(fitted, "timed.parquet", out, "--horizons", "2,5.5") == 0
    t = pd.read_csv(out / "fleet.csv", keep_default_na=False, na_values=[""])
    assert list(t.columns[: len(CURRENT)]) == CURRENT
    log = pd.read_parquet(fitted["timed"])
    last = log.groupby("run_id")["time_s"].max()
    assert np.array_equal(t["as_of"], last.loc[t["run_id"]].to_numpy())
    assert (t["events_per_shift"] == PER_DAY / 2).all()  # the median whole day over 2
    clocks = duty_clocks(small_atlas, PLANNER_ROUTES)
    v, k = t["volume_frac"].to_numpy(), t["wear_coeff"].to_numpy()
    ratio = clocks.remaining_ratio(v)
    for j, (r, c) in enumerate(zip(PLANNER_ROUTES, clocks.routes, strict=True)):
        np.testing.assert_allclose(t[f"rul_{r}_events"], t["rul_mean"] * ratio[:, j], rtol=1e-9)
        np.testing.assert_allclose(t[f"rul_{r}_events_lo"], t["rul_lower"] * ratio[:, j], rtol=1e-9)
        # the twin's RUL is its clock's at its volume and K to its posterior's spread
        np.testing.assert_allclose(t[f"rul_{r}_events"], c.rul(v, k), rtol=0.01)
        np.testing.assert_allclose(t[f"rul_{r}_shifts"], t[f"rul_{r}_events"] / 400, rtol=1e-12)
        fail = t["as_of"] + t[f"rul_{r}_shifts"] * 12 * 3600
        np.testing.assert_allclose(t[f"fail_{r}_time_s"], fail, rtol=1e-12)
        p = t[[f"p_fail_{r}_2_shifts", f"p_fail_{r}_5p5_shifts"]].to_numpy()
        assert ((p >= 0) & (p <= 1)).all() and (p[:, 0] <= p[:, 1]).all()
    assert (t["rul_hot_shifts"] < t["rul_uniform_shifts"]).all()
    assert (t["rul_uniform_shifts"] < t["rul_mild_shifts"]).all()
    doc = json.loads((out / "fleet.json").read_text())
    assert doc["planner_units"]["horizons_shifts"] == [2.0, 5.5]
    assert doc["pads"][0]["as_of"] == t["as_of"][0] and doc["warnings"] == []


def test_events_per_shift_flag_and_a_log_without_time(fitted, tmp_path, capsys):
    out = tmp_path / "flag"
    assert predict(fitted, "plain.parquet", out, "--events-per-shift", "250") == 0
    t = pd.read_csv(out / "fleet.csv")
    np.testing.assert_allclose(t["rul_hot_shifts_hi"], t["rul_hot_events_hi"] / 250, rtol=1e-12)
    assert t["as_of"].isna().all() and t["fail_hot_time_s"].isna().all()
    assert t["p_fail_mild_28_shifts"].notna().all()  # the default horizons 7, 14, 28

    capsys.readouterr()
    assert predict(fitted, "plain.parquet", tmp_path / "bare") == 0
    assert "no time stamps (time_s)" in capsys.readouterr().err
    t = pd.read_csv(tmp_path / "bare" / "fleet.csv")
    assert t.filter(like="_shifts").isna().all().all() and t["rul_hot_events"].notna().all()

    out = tmp_path / "refused"
    assert predict(fitted, "plain.parquet", out, "--horizons", "7") == 2
    err = capsys.readouterr().err
    assert "--horizons asks for shifts" in err and "give --events-per-shift N" in err
    assert not (out / "fleet.csv").exists()


@pytest.mark.parametrize(
    ("flag", "value"),
    [
        ("--horizons", "0"),
        ("--horizons", "7,-1"),
        ("--horizons", "7,7"),
        ("--horizons", "seven"),
        ("--events-per-shift", "0"),
        ("--events-per-shift", "nan"),
        ("--shift-hours", "-2"),
    ],
)
def test_bad_flags_are_refused_naming_the_flag(flag, value, tmp_path, capsys):
    argv = ["predict", "--model", "m", "--log", "l.csv", "--out", str(tmp_path / "o")]
    with pytest.raises(SystemExit) as e:
        main([*argv, flag, value])
    assert e.value.code == 2 and f"argument {flag}:" in capsys.readouterr().err
