"""``brakewear evaluate --seeds``: one unit per seed, the same numbers in this process and on
Ray and as a single ``--seed`` run, seeds that differ where they should, resumed seeds not
redone, and a bad seed list refused in one message."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from brake_env.cli.main import main
from brake_env.data.datasets import DatasetSpec, make_dataset, write_dataset
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime
from brake_env.prognostics import seeds as sd

TINY = DatasetSpec(n_train=3, n_id=2, n_ood_slow=1, n_ood_fast=1, wear=WearRegime(2e-4, 2e-5))
SIMULATE = ["--n-train", "3", "--n-id", "2", "--n-ood-slow", "1", "--n-ood-fast", "1"]
SIMULATE += ["--k-mean", "2e-4"]
TIMING = {"fit_seconds", "predict_seconds", "timing_s"}


@pytest.fixture(scope="module")
def data(small_atlas: Atlas, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    d = tmp_path_factory.mktemp("data")
    write_dataset(make_dataset(small_atlas, TINY, seed=1), d, ("parquet",))
    return d, small_atlas.save(d / "atlas.npz")


def evaluate(atlas: Path, out: Path, *extra: str) -> Path:
    argv = ["evaluate", "--out", str(out), "--atlas", str(atlas), "--quiet"]
    assert main([*argv, "--predictors", "physics,data", "--mlp-epochs", "2", *extra]) == 0
    return out


def untimed(tree: Any) -> Any:
    """``tree`` without its wall times."""
    if isinstance(tree, dict):
        return {k: untimed(v) for k, v in tree.items() if k not in TIMING}
    return tree


def rmse(doc: dict[str, Any], model: str, split: str) -> list[float]:
    return doc["metrics"][model][split]["rul_rmse"]["per_seed"]


def test_seeds_on_given_data_agree_in_process_on_ray_and_with_single_seed_runs(
    data: tuple[Path, Path], tmp_path: Path, local_ray: object
) -> None:
    d, atlas = data
    here = evaluate(atlas, tmp_path / "here", "--data", str(d), "--seeds", "0", "1")
    on_ray = evaluate(
        atlas, tmp_path / "ray", "--data", str(d), "--seeds", "0", "1", "--workers", "2"
    )
    doc = json.loads((here / "seeds.json").read_text())
    assert untimed(doc) == untimed(json.loads((on_ray / "seeds.json").read_text()))
    assert doc["seeds"] == [0, 1] and list(doc["metrics"]) == ["physics", "data"]
    # The same logs: the physics fit draws nothing, the MLP's weights follow the seed.
    for split in ("id", "ood"):
        a, b = rmse(doc, "physics", split)
        assert a == b and doc["metrics"]["physics"][split]["rul_rmse"]["std"] == 0.0
        a, b = rmse(doc, "data", split)
        assert a != b
        s = doc["metrics"]["data"][split]["rul_rmse"]
        assert s["min"] == min(a, b) and s["max"] == max(a, b) and s["mean"] == (a + b) / 2

    # Each seed's directory is what one --seed run writes (figures aside).
    single = evaluate(atlas, tmp_path / "single", "--data", str(d), "--seed", "1")
    one = json.loads((single / "metrics.json").read_text())
    seed1 = json.loads((here / "seed-1" / "metrics.json").read_text())
    for key in ("config", "splits", "models", "seed", "data_dir", "atlas_hash", "saved_models"):
        assert untimed(seed1[key]) == untimed(one[key]), key
    assert seed1["figures"] == {} and (here / "seed-1" / "table.md").is_file()
    assert (here / "seed-0" / "models" / "data" / "predictor.json").is_file()
    assert "| data | ood |" in (here / "seeds.md").read_text()


def test_simulated_seeds_differ_and_a_rerun_adds_only_new_seeds(
    data: tuple[Path, Path],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    _, atlas = data
    out = tmp_path / "sim"
    first = json.loads(
        (evaluate(atlas, out, "--seeds", "0", "1", *SIMULATE) / "seeds.json").read_text()
    )
    for split in ("id", "ood"):  # each seed its own data: every predictor's numbers move
        for model in ("physics", "data"):
            a, b = rmse(first, model, split)
            assert a != b
    assert first["data"]["simulated"]["n_train"] == 3

    calls: list[int] = []
    real = sd.evaluate_seed

    def counted(atlas, logs, seed, plan):  # type: ignore[no-untyped-def]
        calls.append(seed)
        return real(atlas, logs, seed, plan)

    monkeypatch.setattr(sd, "evaluate_seed", counted)
    again = json.loads(
        (evaluate(atlas, out, "--seeds", "2", "0", "1", *SIMULATE) / "seeds.json").read_text()
    )
    assert calls == [2] and again["seeds"] == [2, 0, 1]
    assert "evaluate: resuming: 2 of 3 units already done" in capsys.readouterr().err
    assert rmse(again, "data", "ood")[1:] == rmse(first, "data", "ood")
    # Other settings on this store (fewer MLP epochs) are refused, naming what changed.
    argv = ["evaluate", "--out", str(out), "--atlas", str(atlas), "--seeds", "0", *SIMULATE]
    assert main([*argv, "--predictors", "physics,data", "--mlp-epochs", "1", "--quiet"]) == 2
    assert "mlp_epochs: 2 -> 1" in capsys.readouterr().err


def test_a_bad_seed_list_is_one_clear_error(
    data: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    d, atlas = data
    base = ["evaluate", "--out", str(tmp_path / "o"), "--atlas", str(atlas), "--quiet"]
    assert main([*base, "--data", str(d), "--seeds", "0", "3", "0", "-2"]) == 2
    err = capsys.readouterr().err
    assert "--seeds takes distinct integers >= 0, got [0, 3, 0, -2]" in err
    assert err.count("error") == 1
    assert main([*base, "--data", str(d), "--seeds", "1", "1"]) == 2
    assert "given twice: [1]" in capsys.readouterr().err
    assert main(base) == 2
    assert "evaluate needs --data" in capsys.readouterr().err
    assert main([*base, "--data", str(d), "--seeds", "0", "--n-train", "3"]) == 2
    assert "--n-train: the simulated dataset's options" in capsys.readouterr().err
    assert main([*base, "--data", str(d), "--workers", "2", "--k-mean", "1e-5"]) == 2
    assert "--workers, --k-mean: options of --seeds" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main([*base, "--seeds", "zero"])
    assert not (tmp_path / "o").exists()
    with pytest.raises(ValueError, match="given twice"):
        sd.check_seeds([4, 4])
