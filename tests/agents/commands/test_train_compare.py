"""The cost comparison end to end (``brakewear compare`` on tiny budgets), and what its tiny
comparison writes (checked where it runs, in this process and on Ray: test_compare_runner.py,
with ``brakewear train``'s; the demo's stage runs in the demo's test)."""

from __future__ import annotations

from pathlib import Path

from agents.commands.cli import compare_and_report
from agents.study.config import StudyConfig
from brake_env.env.config import EnvConfig
from brake_env.runner import Runner
from tests.agents.budgets import FAST_ENV


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


def check_tiny_costs(costs: dict, returned: dict, out: Path) -> None:
    """What :func:`tiny_config`'s comparison writes: the pads, the policies, a ranking whose
    ratios to the oracle are sorted and never below 1, the sensitivity, the curve, the
    figures. (Run in test_compare_runner.py's comparison in this process and on Ray.)"""
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
        assert (out / "figures" / f"{fig}.png").stat().st_size > 0


def test_a_budget_too_small_gives_no_figure_but_a_reason(atlas, tmp_path):
    config = tiny_config(predictors=("none", "oracle"), timesteps=10, min_timesteps=100,
                         min_tune_pads=100)  # fmt: skip
    costs = compare_and_report(config, atlas, tmp_path, 0, Runner(0), quiet=True)
    assert set(costs["policies"]) == {"replace-on-failure", "oracle"}
    skipped = costs["skipped"]
    assert "not trained" in skipped["oracle/ppo"] and "not tuned" in skipped["fixed-interval"]
    assert "none/threshold" in skipped and not (tmp_path / "agents").exists()


def test_brakewear_compare_runs_on_tiny_budgets(tmp_path):
    """The command end to end (its demo stage runs in the demo's test, test_main.py)."""
    from brake_env.cli.main import main

    rc = main(["compare", "--out", str(tmp_path / "c"), "--quiet", "--predictors", "none,oracle",
               "--timesteps", "1", "--tune-pads", "2", "--eval-pads", "2", "--n-train-runs", "2",
               "--resamples", "100", "--k-mean", "1e-5", "--episode-events", "30000",
               "--workers", "0"])  # fmt: skip
    assert rc in (0, None) and (tmp_path / "c" / "costs.json").exists()
