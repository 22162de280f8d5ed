"""Every example runs (small settings) and does what it says."""

import importlib.util
from pathlib import Path

import numpy as np

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def load(name: str):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_simulate_dataset_example(tmp_path) -> None:
    lives = load("simulate_dataset").main(str(tmp_path), k_mean=4e-5, runs=1)
    assert len(lives) == 4 and min(lives.values()) > 1000
    assert (tmp_path / "volume.png").exists() and (tmp_path / "train.parquet").exists()


def test_train_and_compare_example(tmp_path) -> None:
    result = load("train_and_compare").main(
        str(tmp_path),
        timesteps=64,
        tune_pads=2,
        eval_pads=2,
        predictors=("none", "oracle"),
        agent="oracle",  # the twin's version takes minutes; the compare tests cover it
    )
    # Budgets this small tune and train nothing, and the table says so.
    assert {"replace-on-failure", "oracle"} == set(result["policies"])
    assert {"none/threshold", "oracle/ppo"} <= set(result["skipped"])
    assert (tmp_path / "costs.json").exists() and (tmp_path / "figures/cost_ratio.png").exists()


def test_score_predictors_example() -> None:
    rmse = load("score_predictors").main()
    assert set(rmse) == {"none", "physics", "twin"} and set(rmse["twin"]) == {"id", "ood"}
    # The twin follows each pad's wear; the physics line cannot see a fast or slow pad.
    assert rmse["twin"]["ood"] < rmse["physics"]["ood"]


def test_every_example_is_run_by_a_test() -> None:
    tests = "\n".join(p.read_text() for p in Path(__file__).parent.rglob("test_*.py"))
    untested = [p.stem for p in EXAMPLES.glob("*.py") if f'"{p.stem}"' not in tests]
    assert not untested, f"examples without a test that loads them: {untested}"


def test_fleet_policies_example() -> None:
    out = load("fleet_policies").main(episodes=1, shifts=40, tail=20)
    assert len(out) == 4 and "perfect-information reference" in out
    assert all(np.isfinite(r["cost"]) and r["cost"] >= 0 for r in out.values())
    assert out["perfect-information reference"]["failures"] == 0


def test_fleet_marl_example() -> None:
    import pytest

    pytest.importorskip("torchrl")
    out = load("fleet_marl").main(shifts=30, imitate=1, frames=60, eval_seeds=2)
    assert set(out["cost"]) == {"rule", "shared MAPPO"}
    assert all(np.isfinite(c) and c >= 0 for c in out["cost"].values())
    assert out["agreement"] > 0.8 and len(out["history"]) == 1
