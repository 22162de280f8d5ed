"""``brakewear backtest`` and :mod:`brake_env.prognostics.backtest`: a history scored
without truth columns, on tiny simulated fleets and on a log written by hand."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from brake_env.cli.main import main
from brake_env.data.censor import censor_log
from brake_env.data.datasets import DatasetSpec, make_dataset
from brake_env.data.schema import FAILED, MEASURED_VOLUME, TRUTH, write_event_log
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime
from brake_env.prognostics.backtest import assign_folds, backtest, history_pads
from brake_env.prognostics.protocol import EventBatch, Predictor, RULEstimate

# Lives of ~1,000-3,000 events on the coarse test atlas keep every fit fast.
SPEC = DatasetSpec(n_train=7, n_id=0, n_ood_slow=0, n_ood_fast=0, wear=WearRegime(2e-4, 2e-5))
CENSORED = ["train-01", "train-03", "train-05"]
FAST = ("physics", "window")


@pytest.fixture(scope="module")
def simulated(small_atlas: Atlas) -> pd.DataFrame:
    """7 pads run to failure, with truth columns."""
    return make_dataset(small_atlas, SPEC, seed=5).logs["train"]


def _history(log: pd.DataFrame, keep_truth: bool) -> pd.DataFrame:
    """``CENSORED`` removed before failure with their volume measured, the others whole;
    with ``keep_truth`` the truth columns stay on every row (a simulated history)."""
    cut = censor_log(log[log["run_id"].isin(CENSORED)], np.random.default_rng(0))
    cut = cut.merge(log[["run_id", "event", *TRUTH]], on=["run_id", "event"], how="left")
    whole = log[~log["run_id"].isin(CENSORED)].assign(**{MEASURED_VOLUME: np.nan})
    out = pd.concat([whole, cut], ignore_index=True)
    out["run_id"] = pd.Categorical(out["run_id"].astype(str))  # every pad a category
    return out if keep_truth else out.drop(columns=list(TRUTH))


@pytest.fixture(scope="module")
def history(simulated: pd.DataFrame) -> pd.DataFrame:
    return _history(simulated, keep_truth=True)


@pytest.fixture(scope="module")
def result(small_atlas: Atlas, history: pd.DataFrame):
    return backtest(history.drop(columns=list(TRUTH)), small_atlas, FAST, seed=1)


def test_the_known_rul_of_a_failed_pad_is_rul_events(simulated: pd.DataFrame) -> None:
    _, pads, truth = history_pads(simulated)
    assert truth == list(TRUTH)
    for pad in pads:
        true = simulated.loc[simulated["run_id"] == pad.run_id, "rul_events"].to_numpy()
        np.testing.assert_array_equal(pad.rul_floor(), true)


def test_a_censored_pad_s_floor_is_one_above_a_failure_at_removal(
    history: pd.DataFrame, simulated: pd.DataFrame
) -> None:
    """Removed after event c without failing: the RUL after k is at least c + 1 - k, and
    the truth the history dropped is never below it."""
    _, pads, _ = history_pads(history)
    by_id = {p.run_id: p for p in pads}
    for run in CENSORED:
        pad = by_id[run]
        assert not pad.failed and np.isfinite(pad.measured_volume)
        np.testing.assert_array_equal(pad.rul_floor(), pad.done - pad.events.event)
        true = history.loc[history["run_id"] == run, "rul_events"].to_numpy()
        assert np.all(true >= pad.rul_floor())


def test_scores_and_counts(result, history: pd.DataFrame) -> None:
    rows = result.pads
    assert len(rows) == 2 * 7 and set(rows["predictor"]) == set(FAST)
    for name in FAST:
        s = result.summary[name]
        assert (s["failed_pads"], s["censored_pads"]) == (4, 3)
        assert s["rmse"]["lo"] <= s["rmse"]["mean"] <= s["rmse"]["hi"]
        assert s["rmse"]["lo"] >= 0
    assert result.summary["window"]["coverage"] is not None  # it gives intervals
    assert result.summary["physics"]["coverage"] is None  # it gives none
    assert result.summary["physics"]["measured_pads"] == 3  # a volume estimate
    assert result.summary["window"]["volume_abs_error"] is None  # no volume estimate
    assert result.ranking["order"][0] in FAST
    json.dumps(result.summary, allow_nan=False)
    assert set(result.errors["pad"]) == set(rows.loc[rows["outcome"] == "failed", "pad"])


def test_truth_columns_change_nothing(small_atlas: Atlas, history: pd.DataFrame, result) -> None:
    """A fit that read ``rul_events`` would know the censored pads' lives (the baselines
    read it when present); the back-test drops it first, so the scores are the same."""
    with_truth = backtest(history, small_atlas, FAST, seed=1)
    pd.testing.assert_frame_equal(with_truth.pads, result.pads)
    assert with_truth.summary == result.summary
    assert with_truth.settings["truth_columns_ignored"] == list(TRUTH)
    assert result.settings["truth_columns_ignored"] == []


class Recorder(Predictor):
    """Fits on nothing, remembers what it was given; a constant estimate."""

    name = "recorder"
    fitted: list[set[str]] = []  # noqa: RUF012 - shared by the instances of a test

    def _fit(self, train_log: pd.DataFrame) -> None:
        runs = set(train_log["run_id"].astype(str))
        cats = getattr(train_log["run_id"], "cat", None)
        if cats is not None:  # no held-out pad hiding as an unused category either
            runs |= set(map(str, cats.categories))
        Recorder.fitted.append(runs)

    def _update(self, events: EventBatch) -> RULEstimate:
        return RULEstimate(rul_mean=np.full(len(events), 100.0))


@pytest.mark.parametrize("folds", [0, 3])
def test_no_fold_fits_on_a_pad_it_scores(
    small_atlas: Atlas, history: pd.DataFrame, folds: int
) -> None:
    Recorder.fitted = []
    res = backtest(history, small_atlas, {"rec": lambda a, s: Recorder()}, folds, seed=2)
    every = set(history["run_id"].astype(str))
    held = res.pads.groupby("fold")["pad"].apply(set)
    assert len(Recorder.fitted) == (7 if folds == 0 else 3) == len(held)
    for fitted, scored in zip(Recorder.fitted, held, strict=True):
        assert fitted == every - scored
    assert sorted(res.pads["pad"]) == sorted(every)  # every pad held out once


def test_folds_are_deterministic_and_deal_failed_pads_around(history: pd.DataFrame) -> None:
    _, pads, _ = history_pads(history)
    a, b = assign_folds(pads, 3, seed=4), assign_folds(pads, 3, seed=4)
    np.testing.assert_array_equal(a, b)
    assert any(not np.array_equal(a, assign_folds(pads, 3, s)) for s in range(5, 10))
    failed = np.array([p.failed for p in pads])
    assert all(failed[a == f].any() for f in range(3))  # 4 failed pads over 3 folds
    np.testing.assert_array_equal(assign_folds(pads, 0, seed=4), np.arange(len(pads)))


def test_same_seed_same_scores(small_atlas: Atlas, history: pd.DataFrame) -> None:
    one = backtest(history, small_atlas, ["physics"], folds=2, seed=9)
    two = backtest(history, small_atlas, ["physics"], folds=2, seed=9)
    pd.testing.assert_frame_equal(one.pads, two.pads)
    assert one.summary == two.summary and one.settings == two.settings


# ---------------------------------------------------------------------- by hand
def _hand_log() -> pd.DataFrame:
    """Three pads of 100 events: A failed, B removed (volume 0.45 measured), C removed."""
    n = 100
    parts = []
    for run, failed, vol in (("A", True, np.nan), ("B", False, 0.45), ("C", False, np.nan)):
        part = pd.DataFrame(
            {
                "run_id": run,
                "event": np.arange(n),
                "speed_kmh": 10.0,
                "mass_kg": 48000.0,
                "slope_rad": 0.05,
                "energy_j": 2e5,
                "temp_c": 480.0,
                "stop_dist_m": 2.5,
                FAILED: np.arange(n) == n - 1 if failed else False,
                MEASURED_VOLUME: np.where(np.arange(n) == n - 1, vol, np.nan),
            }
        )
        parts.append(part)
    return pd.concat(parts, ignore_index=True)


class Fixed(Predictor):
    """RUL 40 in [30, 50] (or 40 alone), volume 0.5, after every event."""

    name = "fixed"

    def __init__(self, bounds: bool) -> None:
        super().__init__()
        self.bounds = bounds

    def _update(self, events: EventBatch) -> RULEstimate:
        n = len(events)
        lo, hi = (np.full(n, 30.0), np.full(n, 50.0)) if self.bounds else (None, None)
        return RULEstimate(np.full(n, 40.0), lo, hi, volume_frac=np.full(n, 0.5))


def test_scores_by_hand(small_atlas: Atlas) -> None:
    """Cut points: events 15..90 of 100 (76). A failed at 99: RUL 99 - e. B and C did 100
    events without failing: RUL at least 100 - e."""
    factories = {"bounds": lambda a, s: Fixed(True), "mean": lambda a, s: Fixed(False)}
    res = backtest(_hand_log(), small_atlas, factories)
    row = res.pads.set_index(["predictor", "pad"])
    e = np.arange(15, 91)
    assert row.loc[("bounds", "A"), "cut_points"] == 76
    assert row.loc[("bounds", "A"), "rmse"] == pytest.approx(np.sqrt(np.mean((40 - (99 - e)) ** 2)))
    assert row.loc[("bounds", "A"), "rmse_all"] == pytest.approx(
        np.sqrt(np.mean((40 - (99 - np.arange(100))) ** 2))
    )
    assert row.loc[("bounds", "A"), "coverage"] == pytest.approx(21 / 76)  # e in 49..69
    assert np.isnan(row.loc[("mean", "A"), "coverage"])
    # Upper bound 50 below 100 - e for e in 15..49; the mean 40 for e in 15..59.
    for pad in ("B", "C"):
        assert row.loc[("bounds", pad), "premature"] == pytest.approx(35 / 76)
        assert row.loc[("mean", pad), "premature"] == pytest.approx(45 / 76)
    assert row.loc[("bounds", "B"), "volume_abs_error"] == pytest.approx(0.05)
    assert np.isnan(row.loc[("bounds", "C"), "volume_abs_error"])  # nothing measured
    s = res.summary["bounds"]
    assert (s["failed_pads"], s["censored_pads"], s["measured_pads"]) == (1, 2, 1)
    assert s["rmse"]["lo"] is None  # no interval from one pad
    assert s["premature"] == {"mean": pytest.approx(35 / 76), "lo": pytest.approx(35 / 76),
                              "hi": pytest.approx(35 / 76), "pads": 2}  # fmt: skip


def test_errors_name_the_problem(small_atlas: Atlas, history: pd.DataFrame) -> None:
    log = _hand_log()
    one = log[log["run_id"] == "A"]
    with pytest.raises(ValueError, match=r"1 pad.*at least 2"):
        backtest(one, small_atlas, ["physics"])
    blind = log[log["run_id"] != "A"].assign(**{MEASURED_VOLUME: np.nan})
    with pytest.raises(ValueError, match="nothing to score"):
        backtest(blind, small_atlas, ["physics"])
    with pytest.raises(ValueError, match=r"unknown predictor.*'nope'"):
        backtest(history, small_atlas, ["physics", "nope"])
    with pytest.raises(ValueError, match="oracle reads truth"):
        backtest(history, small_atlas, ["oracle"])
    with pytest.raises(ValueError, match=r"folds must be 0 .* or 2..7, got 1"):
        backtest(history, small_atlas, ["physics"], folds=1)
    with pytest.raises(ValueError, match="got 8"):
        backtest(history, small_atlas, ["physics"], folds=8)
    with pytest.raises(ValueError, match="no predictors"):
        backtest(history, small_atlas, [])


def test_a_predictor_that_cannot_be_fitted_on_a_fold_is_named(
    small_atlas: Atlas, history: pd.DataFrame
) -> None:
    """window needs two failed pads to fit on: of two, leaving one out leaves it one."""
    two_failed = history[~history["run_id"].isin(["train-00", "train-02"])]
    with pytest.raises(ValueError, match=r"fitting window without pad\(s\) \['train-04'\]"):
        backtest(two_failed, small_atlas, ["window"])


# ---------------------------------------------------------------------- the command
def test_the_command_writes_its_files(
    small_atlas: Atlas, history: pd.DataFrame, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    atlas_file = tmp_path / "atlas.npz"
    small_atlas.save(atlas_file)
    log_file = write_event_log(history, tmp_path / "history.parquet")
    out = tmp_path / "bt"
    args = ["backtest", "--data", str(log_file), "--predictors", "physics,window"]
    assert main([*args, "--atlas", str(atlas_file), "--out", str(out), "--quiet"]) == 0
    printed = capsys.readouterr()
    assert "truth column(s) volume_frac, wear_coeff, rul_events" in printed.err
    assert "FAILED model" in printed.out and "premature" in printed.out
    assert "leave one pad out" in printed.out
    doc = json.loads((out / "backtest.json").read_text(), parse_constant=_refuse)
    assert doc["settings"]["data"] == str(log_file)
    assert set(doc["summary"]) == {"physics", "window"}
    csv = pd.read_csv(out / "backtest.csv")
    assert len(csv) == 14 and set(csv["outcome"]) == {"failed", "censored"}
    assert (out / "backtest.png").stat().st_size > 0
    assert main([*args, "--atlas", str(atlas_file), "--out", str(out), "--folds", "1"]) == 2
    assert "folds must be 0" in capsys.readouterr().err


def _refuse(token: str) -> None:
    raise ValueError(f"non-standard JSON token {token}")


@pytest.mark.parametrize(("flag", "value"), [("--folds", "-1"), ("--predictors", "twin,magic")])
def test_bad_options_are_refused_while_parsing(
    flag: str, value: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["backtest", "--data", "d.parquet", "--out", str(tmp_path / "o"), flag, value]
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    assert exit_.value.code == 2
    assert f"brakewear backtest: error: argument {flag}" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_an_effect_adds_the_fed_back_predictors_beside_the_nominal_ones(
    small_atlas: Atlas, history: pd.DataFrame, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--effect`` (or ``--diagnosis``) scores each ``--fed-back`` predictor a second time,
    made on the atlas with the effect: that atlas is the one recorded, not the nominal."""
    log_file = write_event_log(history, tmp_path / "history.parquet")
    atlas_file = str(small_atlas.save(tmp_path / "atlas.npz"))
    out = tmp_path / "bt"
    argv = ["backtest", "--data", str(log_file), "--predictors", "physics", "--folds", "2"]
    argv += ["--atlas", atlas_file]
    effect = ["--effect", "heat_partition:phi=0.25", "--fed-back", "physics"]
    assert main([*argv, *effect, "--out", str(out), "--quiet"]) == 0
    doc = json.loads((out / "backtest.json").read_text(), parse_constant=_refuse)
    assert set(doc["summary"]) == {"physics", "physics+effect"}
    assert doc["settings"]["effects"] == ["heat_partition:phi=0.25"]
    nominal, fed = (
        doc["summary"][n]["volume_abs_error"]["mean"] for n in ("physics", "physics+effect")
    )
    assert nominal != fed  # another atlas, other estimates
    bad = ["--effect", "heat_partition:phi=0.25", "--fed-back", "oracle"]
    assert main([*argv, *bad, "--out", str(tmp_path / "x"), "--quiet"]) == 2
    assert "unknown predictor(s) ['oracle']" in capsys.readouterr().err
