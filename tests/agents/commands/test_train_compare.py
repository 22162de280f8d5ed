"""SB3 training (tiny budgets), the learning curve, agents evaluated pad by pad, and the cost
comparison end to end (``brakewear compare`` and the demo's stage on tiny budgets)."""

from __future__ import annotations

import argparse
import json

import numpy as np
import pytest
import torch

from agents.commands.cli import compare_and_report
from agents.learning.curve import agent_outcomes
from agents.learning.hyperparameters import load_hyperparams
from agents.learning.train import TrainedAgent, agent_env, train_agent
from agents.study import outcomes as oc
from agents.study.config import StudyConfig
from agents.study.pads import PadDraws, collect_pads
from agents.study.tuning import fit_predictors
from brake_env.env.config import EnvConfig
from brake_env.model.regime import WearRegime
from brake_env.prognostics.protocol import NoPrognostics, Oracle
from brake_env.runner import Runner

FAST = {"k_mean": 1e-5, "k_std": 1e-6, "decision_interval": 500, "episode_events": 30_000}
TINY = {
    "n_envs": 2,
    "n_steps": 32,
    "batch_size": 32,
    "n_epochs": 1,
    "net_arch": [16],
    "initial_replace_prob": 0.05,
    "torch_threads": 1,
}
FAST_ENV = EnvConfig.from_kwargs(**FAST)
ARGS = argparse.Namespace(seed=0, quiet=True, preset="hot-duty", cache_dir=None, atlas=None)


@pytest.fixture(scope="module")
def curve_pads(atlas):
    config = EnvConfig.from_kwargs(**FAST, regime="mixed")
    draws = PadDraws.stratified(config.pad_regime, 2, [0, 3])
    return collect_pads(draws, atlas, config, {"oracle": Oracle()})


def test_hyperparameter_files_exist_for_every_predictor():
    for name in ("none", "physics", "data", "twin", "oracle"):
        for algo in ("ppo", "dqn"):
            assert "net_arch" in load_hyperparams(name, algo)
    with pytest.raises(ValueError, match="unknown algorithm"):
        load_hyperparams("twin", "a2c")


def test_training_twice_with_a_seed_gives_the_same_agent(atlas, tmp_path):
    params = []
    for run in ("a", "b"):
        train_agent(
            Oracle(), atlas, tmp_path / run, timesteps=128, seed=3, env=FAST_ENV,
            hyperparams=TINY,
        )  # fmt: skip
        params.append(TrainedAgent(tmp_path / run).model.policy.state_dict())
    for k, v in params[0].items():
        assert torch.equal(v, params[1][k]), k
    for f in ("agent.json", "agent.npz", "obs_normalization.npz", "train.json"):
        assert (tmp_path / "a" / f).exists()


def test_the_learning_curve_keeps_the_best_agent(atlas, tmp_path, curve_pads):
    res = train_agent(
        Oracle(), atlas, tmp_path, timesteps=512, seed=0, env=FAST_ENV, hyperparams=TINY,
        curve_pads=curve_pads, n_evals=4,
    )  # fmt: skip
    points = json.loads((tmp_path / "learning_curve.json").read_text())["points"]
    assert points == res.curve  # every 64 vector steps of 2 envs, the last at the end
    assert [p["timesteps"] for p in points] == [128, 256, 384, 512]
    best = min(points, key=lambda p: p["ratio_to_oracle"])
    assert res.best_step == best["timesteps"] and all(p["ratio_to_oracle"] >= 1 for p in points)
    # The saved agent is that one: pad by pad it costs what the curve said.
    agent = TrainedAgent(tmp_path)
    out = agent_outcomes(agent, "oracle", curve_pads, ("rul_mean",), FAST["episode_events"])
    costs = EnvConfig().costs
    ratio = oc.cost_per_1000(curve_pads, out, costs) / oc.cost_per_1000(
        curve_pads, oc.oracle(curve_pads), costs
    )
    assert ratio == pytest.approx(best["ratio_to_oracle"], rel=1e-12)


def test_an_agent_takes_pads_off_pad_by_pad_where_it_does_in_the_env(atlas, tmp_path):
    """A (hand-set) agent that replaces below its mean RUL feature: its first replacement
    on each pad, from the pad-level observations, is where it replaces in the env."""
    train_agent(Oracle(), atlas, tmp_path, timesteps=64, seed=0, env=FAST_ENV, hyperparams=TINY)
    agent = TrainedAgent(tmp_path)
    with torch.no_grad():  # replace where the normalised RUL feature is below 0
        hidden, action = (
            agent.model.policy.mlp_extractor.policy_net[0],
            agent.model.policy.action_net,
        )
        hidden.weight.zero_(), hidden.bias.zero_(), action.weight.zero_(), action.bias.zero_()
        hidden.weight[0, 1] = 1.0
        action.weight[1, 0] = -10.0
    env = agent_env(
        Oracle(), atlas, EnvConfig.from_kwargs(FAST_ENV, episode_events=200_000, regime="mixed")
    )
    obs, _ = env.reset(seed=2)
    config = EnvConfig.from_kwargs(**FAST, regime="mixed")
    rng = np.random.default_rng(2)
    taken, done = [], False
    while not done:
        obs, _, terminated, truncated, info = env.step(agent.predict(obs)[0])
        done = terminated or truncated
        taken += [(p.life_left, p.life) for p in info["retired"]]
    assert len(taken) >= 3 and all(t[0] > 0 for t in taken)  # planned: no phase shifts
    for i in range(len(taken)):
        k, label = config.pad_regime.draw(rng)
        draws = PadDraws(
            np.array([k]), np.array([label]), np.array([rng.integers(2**63)]), {label: 1}
        )
        first = [1 if i == 0 else FAST["decision_interval"]]  # reset observes one event
        pads = collect_pads(draws, atlas, config, {"oracle": Oracle()}, first=first)
        out = agent_outcomes(agent, "oracle", pads, ("rul_mean",), 200_000)
        assert (int(pads.life[0] - out.events[0]), int(pads.life[0])) == taken[i]


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


def test_study_config_is_validated():
    with pytest.raises(ValueError, match="unknown predictor"):
        StudyConfig(predictors=("crystal-ball",))
    with pytest.raises(ValueError, match="eval_pads must be >= 1"):
        StudyConfig(eval_pads=0)
    with pytest.raises(TypeError, match="EnvConfig"):
        StudyConfig(env={"k_mean": 1e-5})


def test_study_config_reports_its_env_flat_and_prices_its_ratios():
    config = StudyConfig(
        env=EnvConfig(regime="mixed", k_mean=1e-5, k_std=1e-6, ood_shift_sigma=4.0)
    )
    assert config.wear == WearRegime(1e-5, 1e-6, 4.0)
    flat = config.to_dict()
    assert "env" not in flat and (flat["k_mean"], flat["ood_shift_sigma"]) == (1e-5, 4.0)
    assert list(flat)[:4] == ["regime", "ood_share", "decision_interval", "episode_events"]
    assert config.ratios() == (5.0, 10.0, 50.0, 200.0)
    assert config.weights(10.0) is config.costs
    w = config.weights(50.0)
    assert w.failure_to_planned == pytest.approx(50.0) and w.planned_replacement == 1000.0


def test_an_agent_env_observes_age_and_rul_in_log_steps(atlas):
    env = agent_env(NoPrognostics(2e4), atlas, FAST_ENV)
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs) and obs.shape == (2,)
    assert obs == pytest.approx(np.log1p(np.array([1, 2e4]) / 500))
    _, reward, *_ = env.step(1)
    assert reward == -1.0  # a planned replacement, in planned replacements
    predictors, _ = fit_predictors(("twin",), atlas, 0, 2, WearRegime(1e-5, 1e-6))
    assert agent_env(predictors["twin"], atlas, FAST_ENV).observation_space.shape == (3,)


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
