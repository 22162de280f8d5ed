"""``brakewear fit`` then ``brakewear predict`` end to end: on a log written by hand (no
truth, two pads, one starting mid-life) and on a simulated fleet logged from mid-life."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from brake_env.cli.main import main
from brake_env.data.censor import censor_log
from brake_env.data.datasets import Dataset, DatasetSpec, make_dataset
from brake_env.data.schema import GROUND_TRUTH, write_event_log
from brake_env.model.atlas import Atlas, AtlasSpec
from brake_env.model.regime import WearRegime
from brake_env.model.wear import WearModel
from brake_env.output import OUTPUT_MARK
from brake_env.prognostics.persist import load_predictor, read_header
from brake_env.prognostics.protocol import predict_log

# Lives of ~11,000 events on the coarse test atlas: long enough for the twin to converge.
SPEC = DatasetSpec(n_train=6, n_id=3, n_ood_slow=0, n_ood_fast=0, wear=WearRegime(2e-5, 2e-6))

# Pad A from installation; pad B logged from event 5,000 on (5,000 unlogged events).
HAND_LOG = """\
run_id,event,speed_kmh,mass_kg,slope_rad,energy_j,temp_c,stop_dist_m
A,0,12.4,51100,0.087,303130,508.1,2.4
A,1,6.4,46800,0.073,73956,463.3,1.2
A,2,6.4,53000,0.105,83753,467.1,2.2
A,3,9.5,52700,0.137,183494,492.5,5.2
B,5000,10.0,47400,0.046,182870,489.7,2.6
B,5001,12.4,46200,0.039,274063,508.4,4.5
A,4,9.1,47900,0.108,153032,480.9,1.3
A,5,10.4,45700,0.134,190699,490.8,1.3
B,5002,9.6,51000,0.051,181333,490.4,2.6
B,5003,12.4,48100,0.086,285334,519.5,2.2
B,5004,6.1,52300,0.031,75080,,5.2
B,5005,8.9,52500,0.072,160437,488.1,5.7
"""


def _strict_json(path: Path) -> object:
    def refuse(token: str) -> None:
        raise ValueError(f"non-standard JSON token {token}")

    return json.loads(path.read_text(), parse_constant=refuse)


@pytest.fixture(scope="module")
def fleet(small_atlas: Atlas) -> Dataset:
    return make_dataset(small_atlas, SPEC, seed=3)


@pytest.fixture(scope="module")
def model(
    small_atlas: Atlas, fleet: Dataset, tmp_path_factory: pytest.TempPathFactory
) -> tuple[Path, Path]:
    """(model directory of a twin fitted through the CLI, its atlas file)."""
    d = tmp_path_factory.mktemp("fit")
    write_event_log(fleet.logs["train"], d / "data" / "train.parquet")
    atlas_file = small_atlas.save(d / "atlas.npz")
    argv = ["fit", "--data", str(d / "data"), "--predictor", "twin", "--out", str(d / "model")]
    assert main([*argv, "--atlas", str(atlas_file), "--quiet"]) == 0
    return d / "model", atlas_file


def test_hand_written_log_two_pads_one_mid_life(
    model: tuple[Path, Path], small_atlas: Atlas, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    (tmp_path / "pads.csv").write_text(HAND_LOG)
    out = tmp_path / "pred"
    argv = ["predict", "--model", str(model[0]), "--log", str(tmp_path / "pads.csv")]
    assert main([*argv, "--out", str(out), "--atlas", str(model[1]), "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "5,006" in printed and "2 pads, 12 events" in printed

    table = pd.read_csv(out / "fleet.csv", keep_default_na=False)
    assert list(table["run_id"]) == ["B", "A"]  # most urgent first
    b, a = table.to_dict("records")
    assert (a["first_event"], a["events_since_install"], a["events_logged"]) == (0, 6, 6)
    assert (b["first_event"], b["events_since_install"], b["events_logged"]) == (5000, 5006, 6)
    # Twelve events say little: both pads sit near the prior's life, B 5,000 events further.
    prior = read_header(model[0])["meta"]["calibration"]["k_log_mean"]
    life = float(WearModel.from_atlas(small_atlas).life(np.exp(prior)))
    assert a["rul_mean"] == pytest.approx(life - 6, rel=0.1)
    assert a["rul_mean"] - b["rul_mean"] == pytest.approx(5000, rel=0.1)
    for r in (a, b):
        assert r["rul_lower"] <= r["rul_mean"] <= r["rul_upper"] and 0 < r["volume_frac"] < 1
        assert r["missing_channels"] == ""  # one temperature dropout is not a missing channel

    doc = _strict_json(out / "fleet.json")
    assert isinstance(doc, dict) and doc["predictor"] == "twin" and doc["warnings"] == []
    assert [p["run_id"] for p in doc["pads"]] == ["B", "A"]
    traces = pd.read_parquet(out / "traces.parquet")
    assert len(traces) == 12 and list(traces["event"][traces["run_id"] == "B"]) == list(
        range(5000, 5006)
    )
    assert (out / "fleet.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    left = [p for p in out.iterdir() if p.name.startswith(".") and p.name != OUTPUT_MARK]
    assert not left  # no temporary left


def test_a_channel_missing_for_a_whole_pad_is_reported(
    model: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    rows = [r.split(",") for r in HAND_LOG.splitlines()]
    for r in rows[1:]:
        if r[0] == "A":
            r[6] = ""  # temp_c
    (tmp_path / "pads.csv").write_text("\n".join(",".join(r) for r in rows) + "\n")
    out = tmp_path / "pred"
    argv = ["predict", "--model", str(model[0]), "--log", str(tmp_path / "pads.csv")]
    assert main([*argv, "--out", str(out), "--atlas", str(model[1]), "--quiet"]) == 0
    assert "pad A: temp_c missing at every event" in capsys.readouterr().err
    table = pd.read_csv(out / "fleet.csv", keep_default_na=False).set_index("run_id")
    assert (
        table.loc["A", "missing_channels"] == "temp_c" and table.loc["B", "missing_channels"] == ""
    )
    doc = _strict_json(out / "fleet.json")
    assert isinstance(doc, dict) and len(doc["warnings"]) == 1
    assert {p["run_id"]: p["missing_channels"] for p in doc["pads"]} == {"A": ["temp_c"], "B": []}


def test_simulated_fleet_logged_from_mid_life(
    model: tuple[Path, Path], fleet: Dataset, tmp_path: Path
) -> None:
    """Each pad logged from 40% to 70% of its life only: the RUL counts the unlogged
    events. The same rows renumbered from 0 read as a fresh pad already worn half down:
    a K far too high and an RUL far too short."""
    log = fleet.logs["id"]
    life = log.groupby("run_id", observed=True)["event"].transform("size")
    mid = log[(log["event"] >= 0.4 * life) & (log["event"] < 0.7 * life)]
    truth = mid.groupby("run_id", observed=True).tail(1).set_index("run_id")
    write_event_log(mid.drop(columns=list(GROUND_TRUTH)), tmp_path / "mid.parquet")
    out = tmp_path / "pred"
    argv = ["predict", "--model", str(model[0]), "--log", str(tmp_path / "mid.parquet")]
    assert main([*argv, "--out", str(out), "--atlas", str(model[1]), "--quiet"]) == 0
    got = pd.read_csv(out / "fleet.csv").set_index("run_id").loc[truth.index]
    run_life = life.groupby(log["run_id"], observed=True).first().loc[truth.index]
    err = (got["rul_mean"] - truth["rul_events"]) / run_life
    assert (err.abs() < 0.05).all(), err
    assert (got["events_since_install"] == truth["event"] + 1).all()

    atlas = Atlas.load(model[1])
    renumbered = mid.assign(event=mid.groupby("run_id", observed=True).cumcount())
    wrong = predict_log(load_predictor(model[0], atlas), renumbered)
    wrong_last = wrong.groupby("run_id", observed=True)["rul_mean"].last().loc[truth.index]
    assert ((truth["rul_events"] - wrong_last) / run_life > 0.15).all()


def test_fit_on_censored_runs_records_them(
    model: tuple[Path, Path], fleet: Dataset, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    cut = censor_log(fleet.logs["train"], np.random.default_rng(0))
    write_event_log(cut, tmp_path / "cut.csv")
    argv = ["fit", "--data", str(tmp_path / "cut.csv"), "--predictor", "twin"]
    assert main([*argv, "--out", str(tmp_path / "m"), "--atlas", str(model[1]), "--quiet"]) == 0
    assert "on 6 runs (6 censored)" in capsys.readouterr().out
    assert len(read_header(tmp_path / "m")["info"]["censored_runs"]) == 6


def test_preconditions_fail_fast_with_clear_messages(
    model: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    log = tmp_path / "pads.csv"
    log.write_text(HAND_LOG)
    base = ["predict", "--out", str(tmp_path / "o"), "--quiet"]
    assert main([*base, "--model", str(tmp_path / "none"), "--log", str(log)]) == 2
    assert "no such directory" in capsys.readouterr().err
    other = Atlas.build(AtlasSpec(n_speed=4, n_mass=2, n_slope=3)).save(tmp_path / "other.npz")
    argv = [*base, "--model", str(model[0]), "--log", str(log), "--atlas", str(other)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "was fitted with atlas" in err and Atlas.load(other).content_hash[:16] in err
    log.write_text(HAND_LOG.replace(",temp_c,", ",temp,"))
    assert main([*base, "--model", str(model[0]), "--log", str(log)]) == 2
    assert "missing required column(s) ['temp_c']" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()  # nothing written before the checks pass
    (tmp_path / "file").write_text("")
    fit = ["fit", "--data", str(log), "--predictor", "twin", "--out", str(tmp_path / "file")]
    with pytest.raises(SystemExit, match="2"):
        main([*fit, "--quiet"])
    assert "argument --out: " in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["fit", "--data", str(log), "--predictor", "lstm"])


def test_predict_leaves_a_units_folder_of_the_users_alone(
    model: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    """The reproduction of issue 29: X/units holding the user's files, then predict --out X.
    They were moved and deleted; now predict refuses, naming the folder, and changes nothing."""
    log = tmp_path / "pads.csv"
    log.write_text(HAND_LOG)
    out = tmp_path / "X"
    (out / "units").mkdir(parents=True)
    (out / "units" / "notes.json").write_text("{}\n")
    (out / "units" / "a.txt").touch()
    argv = ["predict", "--model", str(model[0]), "--log", str(log), "--out", str(out)]
    assert main([*argv, "--atlas", str(model[1]), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"{out / 'units'} is not empty (a.txt, notes.json) but has no settings.json" in err
    assert err.count("error") == 1
    assert sorted(p.name for p in out.rglob("*")) == ["a.txt", "notes.json", "units"]
    assert (out / "units" / "notes.json").read_text() == "{}\n"


def test_predict_refuses_the_folder_of_its_model(
    model: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    log = tmp_path / "pads.csv"
    log.write_text(HAND_LOG)
    before = sorted(p.name for p in model[0].iterdir())
    argv = ["predict", "--model", str(model[0]), "--log", str(log), "--out", str(model[0])]
    assert main([*argv, "--atlas", str(model[1]), "--quiet"]) == 2
    assert "holds the output of `brakewear fit`" in capsys.readouterr().err
    assert sorted(p.name for p in model[0].iterdir()) == before
