import numpy as np
import pytest

from brake_env.data.datasets import DatasetSpec, make_dataset, write_dataset
from brake_env.data.schema import GROUND_TRUTH, REQUIRED, read_event_log
from brake_env.model.regime import WearRegime
from brake_env.model.simulator import SensorNoise

SMALL = DatasetSpec(n_train=2, n_id=2, n_ood_slow=1, n_ood_fast=1, wear=WearRegime(4e-5, 4e-6))


def test_plan_follows_the_paper() -> None:
    spec = DatasetSpec()
    plan = spec.plan(np.random.default_rng(0))
    splits = [p.split for p in plan]
    assert splits.count("train") == 10 and splits.count("id") == 10 and splits.count("ood") == 10
    k = {p.run_id: p.wear_coeff for p in plan}
    slow = [v for r, v in k.items() if r.startswith("ood-slow")]
    fast = [v for r, v in k.items() if r.startswith("ood-fast")]
    train = [v for r, v in k.items() if r.startswith("train")]
    assert len(slow) == len(fast) == 5
    # Means shifted by -6 and +6 sigma: every OOD draw lies far outside the training spread.
    assert max(slow) < 2e-6 - 3 * 2e-7 < min(train) and min(fast) > 2e-6 + 3 * 2e-7 > max(train)


def test_logs_hold_truth_and_noise_of_the_paper(small_atlas) -> None:
    ds = make_dataset(small_atlas, SMALL, seed=1)
    noiseless = make_dataset(
        small_atlas, DatasetSpec(**{**SMALL.__dict__, "noise": SensorNoise.none()}), seed=1
    )
    log, clean = ds.logs["train"], noiseless.logs["train"]
    assert [c.name for c in REQUIRED] + list(GROUND_TRUTH) == list(log.columns)
    assert len(log) == sum(r.trajectory.n_events for r in ds.runs if r.split == "train")
    resid = log["temp_c"] - clean["temp_c"]
    assert resid.std() == pytest.approx(5.0, rel=0.05)
    assert (log["energy_j"] - clean["energy_j"]).std() == pytest.approx(2000.0, rel=0.05)
    np.testing.assert_array_equal(log["speed_kmh"], clean["speed_kmh"])  # no speed noise
    np.testing.assert_array_equal(log["volume_frac"], clean["volume_frac"])  # truth untouched
    for _, run in log.groupby("run_id", observed=True):
        assert run["failed"].sum() == 1 and run["failed"].iloc[-1]
        assert run["rul_events"].iloc[-1] == 0 and run["event"].iloc[0] == 0


def test_same_seed_gives_identical_files(tmp_path, small_atlas) -> None:
    for d in ("a", "b"):
        write_dataset(make_dataset(small_atlas, SMALL, seed=3), tmp_path / d)
    for name in ("train.parquet", "id.csv", "ood.parquet"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()
    write_dataset(make_dataset(small_atlas, SMALL, seed=4), tmp_path / "c")
    assert (tmp_path / "a/id.csv").read_bytes() != (tmp_path / "c/id.csv").read_bytes()


def test_written_logs_read_back_identically(tmp_path, small_atlas) -> None:
    ds = make_dataset(small_atlas, SMALL, seed=2)
    write_dataset(ds, tmp_path)
    for split, log in ds.logs.items():
        pq = read_event_log(tmp_path / f"{split}.parquet")
        csv = read_event_log(tmp_path / f"{split}.csv")
        for df in (pq, csv):
            assert list(df.columns) == list(log.columns)
            np.testing.assert_array_equal(df["temp_c"].to_numpy(), log["temp_c"].to_numpy())
            np.testing.assert_array_equal(df["run_id"].astype(str), log["run_id"].astype(str))
            np.testing.assert_array_equal(df["failed"], log["failed"])


def test_spec_validation() -> None:
    with pytest.raises(ValueError, match="n_train"):
        DatasetSpec(n_train=-1)
    with pytest.raises(ValueError, match="k_std"):
        DatasetSpec(wear=WearRegime(k_std=0.0))
    with pytest.raises(ValueError, match="slow OOD mean"):
        DatasetSpec(wear=WearRegime(2e-6, 5e-7))  # slow mean -1e-6
    DatasetSpec(n_ood_slow=0, wear=WearRegime(2e-6, 5e-7))  # no slow OOD pads: valid
    with pytest.raises(ValueError, match="no runs"):
        DatasetSpec(n_train=0, n_id=0, n_ood_slow=0, n_ood_fast=0)
