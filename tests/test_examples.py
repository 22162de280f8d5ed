"""Every example runs (small settings) and does what it says."""

import importlib.util
from pathlib import Path

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


def test_every_example_has_a_test() -> None:
    tested = {"simulate_dataset"}
    assert {p.stem for p in EXAMPLES.glob("*.py")} == tested
