"""The cost comparison end to end (``brakewear compare``, ``brakewear train`` and the demo's
stage on tiny budgets)."""

from __future__ import annotations

import argparse
import json

from agents.commands.cli import compare_and_report
from agents.study.config import StudyConfig
from brake_env.env.config import EnvConfig
from brake_env.runner import Runner
from tests.agents.budgets import ARGS, FAST_ENV, TINY


def tiny_config(**kw):
    base = dict(
        predictors=("none", "physics", "oracle"),
        agent_predictors=("oracle",),
        timesteps=256,
        min_timesteps=1,
        n_train_runs=2,
        tune_pads=2,
        eval_pads=3,
        min_tune_pads=1,
        n_resamples=200,
        env=EnvConfig.from_kwargs(FAST_ENV, regime="mixed"),
    )
    return StudyConfig(**{**base, **kw})


def test_tiny_comparison_writes_well_formed_costs(atlas, tmp_path):
    returned = compare_and_report(
        tiny_config(), atlas, tmp_path, 0, Runner(0), quiet=True, hyperparams={"oracle": TINY}
    )
    costs = json.loads((tmp_path / "costs.json").read_text())
    assert set(costs) == set(returned)
    assert costs["pads"] == {
        "tune": {"id": 2, "ood-slow": 2, "ood-fast": 2},
        "evaluate": {"id": 3, "ood-slow": 3, "ood-fast": 3},
    }
    expected = {"none/threshold", "physics/threshold", "oracle/threshold", "oracle/ppo"}
    assert set(costs["policies"]) == expected | {"fixed-interval", "replace-on-failure", "oracle"}
    assert costs["ranking"][0] in ("oracle", "oracle/threshold") and not costs["skipped"]
    ratios = [costs["policies"][p]["ratio_to_oracle"] for p in costs["ranking"]]
    assert [r["value"] for r in ratios] == sorted(r["value"] for r in ratios)
    assert all(r["low"] <= r["value"] <= r["high"] and r["low"] >= 1 - 1e-12 for r in ratios)
    assert len(costs["gaps"]) == len(ratios) - 1
    assert set(costs["sensitivity"]) == {"5", "10", "50", "200"}
    assert "targets" not in costs and costs["learning_curves"]["oracle"]
    for fam, value in costs["tuned_parameters"].items():
        assert value == "never" or value in costs["tuning"]["candidates"][fam]
    for fig in ("cost_ratio", "replacement_timing", "cost_sensitivity", "learning_curve"):
        assert (tmp_path / "figures" / f"{fig}.png").stat().st_size > 0


def test_a_budget_too_small_gives_no_figure_but_a_reason(atlas, tmp_path):
    config = tiny_config(predictors=("none", "oracle"), timesteps=10, min_timesteps=100,
                         min_tune_pads=100)  # fmt: skip
    costs = compare_and_report(config, atlas, tmp_path, 0, Runner(0), quiet=True)
    assert set(costs["policies"]) == {"replace-on-failure", "oracle"}
    skipped = costs["skipped"]
    assert "not trained" in skipped["oracle/ppo"] and "not tuned" in skipped["fixed-interval"]
    assert "none/threshold" in skipped and not (tmp_path / "agents").exists()


def test_brakewear_compare_and_the_demo_stage_run_on_tiny_budgets(atlas, tmp_path, monkeypatch):
    import agents.commands.cli
    from brake_env.cli.demo import DemoContext
    from brake_env.cli.main import main

    rc = main(["compare", "--out", str(tmp_path / "c"), "--quiet", "--predictors", "none,oracle",
               "--timesteps", "1", "--tune-pads", "2", "--eval-pads", "2", "--n-train-runs", "2",
               "--resamples", "100", "--k-mean", "1e-5", "--episode-events", "30000",
               "--workers", "0"])  # fmt: skip
    assert rc in (0, None) and (tmp_path / "c" / "costs.json").exists()
    monkeypatch.setattr(agents.commands.cli, "DEMO_TUNE_PADS", 2)
    monkeypatch.setattr(agents.commands.cli, "DEMO_EVAL_PADS", 2)
    monkeypatch.setattr(agents.commands.cli, "DEMO_WORKERS", 0)  # in this process: no Ray to start
    args = argparse.Namespace(**vars(ARGS), n_train=2, k_mean=1e-5, k_std=None, ood_shift_sigma=6.0)
    ctx = DemoContext(args, tmp_path / "demo", tmp_path / "atlas.npz", tmp_path / "data")
    summary, section = agents.commands.cli.demo_compare(ctx)
    assert "not trained" in section and "| policy |" in section and summary["ranking"]


def test_brakewear_train_writes_a_learning_curve_and_a_held_out_table(tmp_path):
    from brake_env.cli.main import main

    hp = tmp_path / "tiny.toml"
    table = "\n".join(f"{k} = {json.dumps(v)}" for k, v in TINY.items())
    hp.write_text(f"[ppo]\n{table}\n")
    out = tmp_path / "train"
    main(["train", "--out", str(out), "--quiet", "--predictor", "oracle", "--timesteps", "256",
          "--hyperparams", str(hp), "--n-train-runs", "2", "--curve-pads", "1",
          "--eval-pads", "2", "--k-mean", "1e-5", "--episode-events", "30000",
          "--workers", "0"])  # fmt: skip
    ev = json.loads((out / "evaluation.json").read_text())
    assert ev["pads"] == {"curve": 3, "held_out": 6} and ev["learning_curve"]
    assert {"oracle/ppo", "oracle", "replace-on-failure"} <= set(ev["policies"])
    assert (out / "figures" / "learning_curve.png").stat().st_size > 0
