"""``brakewear evaluate`` end to end on a tiny dataset."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from brake_env.cli.demo import DemoContext
from brake_env.cli.main import build_parser, main
from brake_env.data.datasets import DatasetSpec, make_dataset, write_dataset
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime
from brake_env.prognostics.commands.evaluate import demo_stage

TINY = DatasetSpec(n_train=3, n_id=2, n_ood_slow=1, n_ood_fast=1, wear=WearRegime(2e-4, 2e-5))


@pytest.fixture(scope="module")
def data(small_atlas: Atlas, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    d = tmp_path_factory.mktemp("data")
    write_dataset(make_dataset(small_atlas, TINY, seed=1), d, ("parquet",))
    return d, small_atlas.save(d / "atlas.npz")


def test_evaluate_writes_metrics_table_figures_and_weights(
    data: tuple[Path, Path], tmp_path: Path
) -> None:
    d, atlas_file = data
    out = tmp_path / "eval"
    argv = ["evaluate", "--data", str(d), "--out", str(out), "--atlas", str(atlas_file)]
    argv += ["--predictors", "physics,data,twin,oracle", "--mlp-epochs", "2", "--quiet"]
    assert main(argv) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    assert list(metrics["models"]) == ["physics", "data", "twin", "oracle"]
    for model in metrics["models"].values():
        for split in ("id", "ood"):
            s = model["splits"][split]
            assert set(s["runs"]) == set(metrics["splits"][split]["runs"])
            assert set(s["mean"]["convergence_event"]) == {"0.05", "0.1", "0.2"}
            for key in ("rul_rmse", "relative_accuracy", "alpha_lambda", "phm08"):
                assert key in s["mean"]
    twin = metrics["models"]["twin"]["splits"]["ood"]["mean"]
    assert {"volume_rmse", "k_rel_error", "interval_coverage"} <= set(twin)
    assert "volume_rmse" in metrics["models"]["physics"]["splits"]["id"]["mean"]
    assert metrics["models"]["oracle"]["splits"]["id"]["mean"]["rul_rmse"] == 0.0
    assert (out / "models" / "data" / "predictor.json").is_file()  # brakewear predict --model
    assert {p.name for p in (out / "figures").iterdir()} == {
        "volume_estimates.png",
        "wear_coeff_estimates.png",
        "rul_estimates.png",
        "convergence.png",
    }
    assert "| physics |" in (out / "table.md").read_text()


def test_errors_exit_with_code_2(
    data: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    d, atlas_file = data
    base = ["evaluate", "--out", str(tmp_path / "o"), "--atlas", str(atlas_file), "--quiet"]
    assert main([*base, "--data", str(tmp_path / "nowhere")]) == 2
    assert "no such directory" in capsys.readouterr().err
    partial = tmp_path / "partial"
    partial.mkdir()
    (partial / "train.parquet").write_bytes((d / "train.parquet").read_bytes())
    assert main([*base, "--data", str(partial)]) == 2
    assert "missing id.parquet, ood.parquet" in capsys.readouterr().err
    bad = tmp_path / "bad"
    bad.mkdir()
    for split in ("train", "id", "ood"):
        (bad / f"{split}.csv").write_text("run_id,event\nr,0\n")
    assert main([*base, "--data", str(bad), "--predictors", "physics"]) == 2
    assert "speed_kmh" in capsys.readouterr().err  # the reader names the missing column
    with pytest.raises(SystemExit):
        build_parser().parse_args(["evaluate", "--data", str(d), "--predictors", "lstm"])


def test_demo_stage(data: tuple[Path, Path], tmp_path: Path) -> None:
    d, atlas_file = data
    args = build_parser().parse_args(["demo", "--out", str(tmp_path), "--quiet"])
    ctx = DemoContext(args, tmp_path, atlas_file, d)
    result, section = demo_stage(ctx)
    assert set(result["mean_rul_rmse"]) == {"physics", "data", "twin"}
    assert "![rul](evaluate/figures/rul_estimates.png)" in section
    assert (tmp_path / "evaluate" / "figures" / "rul_estimates.png").is_file()
