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


# ---------------------------------------------------------------------- manifest
def _dataset(tmp_path, small_atlas, seed=2, formats=("parquet", "csv")):
    ds = make_dataset(small_atlas, SMALL, seed=seed)
    write_dataset(ds, tmp_path, formats)
    return ds


def test_the_manifest_is_written_last_and_vouches_for_every_file(tmp_path, small_atlas) -> None:
    import json

    from brake_env.data.datasets import find_logs
    from brake_env.output import sha256_file

    ds = _dataset(tmp_path, small_atlas)
    m = json.loads((tmp_path / "manifest.json").read_text())
    assert m["complete"] is True and m["meta"]["seed"] == 2
    assert m["meta"]["spec"]["n_train"] == SMALL.n_train
    assert set(m["files"]) == {
        f"{s}.{f}" for s in ("train", "id", "ood") for f in ("parquet", "csv")
    }
    for name, info in m["files"].items():
        assert info["sha256"] == sha256_file(tmp_path / name)
        assert info["rows"] == len(ds.logs[info["split"]])
    newest = max((tmp_path / n).stat().st_mtime_ns for n in m["files"])
    assert (tmp_path / "manifest.json").stat().st_mtime_ns >= newest
    assert find_logs(tmp_path) == {s: tmp_path / f"{s}.parquet" for s in ("train", "id", "ood")}
    assert not list(tmp_path.glob(".*tmp*"))  # no temporary file left


@pytest.mark.parametrize("damage", ["cut-off", "other-run", "missing", "unfinished"])
def test_a_cut_off_mixed_or_unfinished_directory_is_refused(tmp_path, small_atlas, damage) -> None:
    import json

    from brake_env.data.datasets import find_logs
    from brake_env.output import ManifestError

    _dataset(tmp_path / "a", small_atlas)
    d = tmp_path / "a"
    if damage == "cut-off":  # a file cut at a row boundary still reads as a valid log
        text = (d / "train.csv").read_bytes()
        (d / "train.csv").write_bytes(text[: text.rindex(b"\n", 0, len(text) - 1) + 1])
        read_event_log(d / "train.csv")
        expect = r"train.csv: does not match manifest.json"
    elif damage == "other-run":
        _dataset(tmp_path / "b", small_atlas, seed=9)
        (d / "id.parquet").write_bytes((tmp_path / "b" / "id.parquet").read_bytes())
        expect = r"id.parquet: does not match manifest.json"
    elif damage == "missing":
        (d / "ood.csv").unlink()
        expect = r"ood.csv: listed in manifest.json but missing"
    else:  # what a writer killed between the first and the last file leaves
        m = json.loads((d / "manifest.json").read_text())
        (d / "manifest.json").write_text(json.dumps({**m, "complete": False}))
        expect = r"manifest.json: the directory was being written and the write never finished"
    with pytest.raises(ManifestError, match=expect):
        find_logs(d)


def test_own_logs_without_a_manifest_are_read_as_they_are(tmp_path, small_atlas) -> None:
    from brake_env.data.datasets import find_logs

    _dataset(tmp_path, small_atlas, formats=("csv",))
    (tmp_path / "train.parquet").write_bytes(b"stale file of another run")
    assert find_logs(tmp_path)["train"] == tmp_path / "train.csv"  # the manifest's file
    assert find_logs(tmp_path, ("train",)) == {"train": tmp_path / "train.csv"}
    (tmp_path / "manifest.json").unlink()
    assert find_logs(tmp_path, ("train",))["train"] == tmp_path / "train.parquet"  # own files


def test_rewriting_a_directory_drops_the_old_summary(tmp_path, small_atlas) -> None:
    (tmp_path / "summary.json").write_text("{}")
    _dataset(tmp_path, small_atlas, formats=("parquet",))
    assert not (tmp_path / "summary.json").exists()
