"""The fleet benchmark (issue 41): suites and their splits, baselines made from a study of
the test split and re-scored exactly, a policy scored against them (SB3's predict with
masks, a callable), paired intervals and the bound's ratio only where it means something."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from agents.fleet.benchmark.baselines import from_summary, read_baselines, rebuild
from agents.fleet.benchmark.per_agent import parallel_env_of
from agents.fleet.benchmark.score import Adapted, compare, score
from agents.fleet.benchmark.suite import read_suite, shipped_suites
from agents.fleet.study.run import run_fleet_study
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.fleet_file import FleetFile, fleet_toml
from brake_env.runner import Runner
from tests.brake_env.env.fleet.small import SMALL

PROTOCOL = """
[protocol]
shifts = 20
dev_episodes = 4
test_from = 900000
test_episodes = 20
tune_episodes = 1
n_train_runs = 2
observe = "oracle"
"""


@pytest.fixture(scope="module")
def tiny(tmp_path_factory) -> Path:
    """A suite file of a 3-vehicle fast-wearing fleet, 20-shift episodes."""
    d = tmp_path_factory.mktemp("suite")
    (d / "fleet.toml").write_text(fleet_toml(FleetFile("tiny", "-", FleetConfig(**SMALL))))
    (d / "tiny.toml").write_text('name = "tiny"\nfleet = "fleet.toml"\n' + PROTOCOL)
    return d / "tiny.toml"


@pytest.fixture(scope="module")
def made(tiny, atlas, tmp_path_factory) -> dict:
    """Baselines of the tiny suite: the oracle's tuned threshold rule, the rollout on it,
    the bound and the price-directed policy, on the test split."""
    suite = read_suite(tiny)
    config = suite.study_config("test", predictors=("oracle",), heuristics=("threshold",),
                                trials=2, rollout_predictors=("oracle",), rollout_horizon=5,
                                rollout_samples=4, bound_iterations=5)  # fmt: skip
    out = tmp_path_factory.mktemp("study")
    summary = run_fleet_study(config, atlas, out, Runner(0))
    return from_summary(suite, summary, "test")


def test_the_shipped_suites_seal_a_test_split_apart_from_the_dev_side() -> None:
    assert set(shipped_suites()) >= {"small", "default", "default-mixed", "large"}
    for name in shipped_suites():
        s = read_suite(name)
        test, dev = s.seeds("test"), s.seeds("dev")
        assert len(test) >= 20 and not set(test) & set(dev)
        assert s.study_config("test").tune_seeds()[-1] < test[0]
        assert s.objective == "net" and s.fleet_file.config.episode_shifts == s.shifts
    assert read_suite("default").seeds("test", episodes_from=5)[:2] == [5, 6]


@pytest.mark.parametrize(
    ("protocol", "named"),
    [
        ("test_episodes = 5", "test_episodes must be >= 20"),
        ("test_from = 3", "overlaps the dev side"),
        ("objective = 'cost'\nobservee = 'twin'", "observee"),
        ("observe = 'crystal-ball'", "observe must be one of"),
        ("shifts = -1", "shifts must be an integer"),
    ],
)
def test_a_bad_suite_is_refused_naming_the_key(tmp_path, protocol, named) -> None:
    path = tmp_path / "s.toml"
    path.write_text(f'fleet = "small"\n[protocol]\n{protocol}\n')
    with pytest.raises(ValueError, match=named) as e:
        read_suite(path)
    assert str(path) in str(e.value)


def test_the_suite_s_digest_follows_its_fleet_s_content(tiny, tmp_path) -> None:
    d0 = read_suite(tiny).digest
    fleet = tiny.parent / "fleet.toml"
    text = fleet.read_text()
    fleet.write_text(text.replace("bays = 2", "bays = 3"))
    try:
        assert read_suite(tiny).digest != d0
    finally:
        fleet.write_text(text)
    assert read_suite(tiny).digest == d0


def test_a_baseline_re_scored_equals_its_shipped_episodes(tiny, atlas, made) -> None:
    suite = read_suite(tiny)
    assert set(made["baselines"]) == {"oracle-rule", "oracle-rollout", "priced"}
    assert made["seeds"] == list(range(900_000, 900_020))
    got = score(suite, "baseline:oracle-rule", atlas, baselines=made)
    assert got["episodes"]["net"] == made["baselines"]["oracle-rule"]["episodes"]["net"]
    minus = got["baselines"]["oracle-rule"]["minus"]
    assert minus["mean"] == minus["low"] == minus["high"] == 0.0
    with pytest.raises(ValueError, match="ships no baseline 'twin-rule'"):
        score(suite, "baseline:twin-rule", atlas, baselines=made)


@pytest.mark.parametrize("name", ["oracle-rollout", "priced"])
def test_a_planner_or_the_priced_policy_re_scored_equals_its_episodes(
    tiny, atlas, made, name
) -> None:
    """Rebuilt from what the file records (the base rule and planner, the price steps), on
    the last 2 test episodes alone: the same figures as in the whole split's study."""
    suite = read_suite(tiny)
    entry = made["baselines"][name]
    got = score(suite, f"baseline:{name}", atlas, baselines=made, episodes=2,
                episodes_from=900_018)  # fmt: skip
    assert got["episodes"]["net"] == entry["episodes"]["net"][-2:]
    assert got["episodes"]["cost"] == entry["episodes"]["cost"][-2:]
    if name == "priced":  # the search's steps, as the study was asked (its history has 6)
        assert entry["steps"] == 5 and made["bound"]["iterations"] == 6
    if name == "oracle-rollout":
        assert entry["base"]["policy"] == "threshold"
        assert entry["planner"] == {"horizon": 5, "samples": 4, "seed": 0}
        moved = {**entry, "planner": {**entry["planner"], "seed": 1}}
        other = score(suite, "baseline:x", atlas, episodes=2, episodes_from=900_018,
                      baselines={**made, "baselines": {"x": moved}})  # fmt: skip
        assert other["episodes"]["net"] != got["episodes"]["net"]  # the seed is used
    with pytest.raises(ValueError, match="made before"):
        old = {k: v for k, v in entry.items() if k not in ("base", "steps")}
        score(suite, "baseline:x", atlas, episodes=2, baselines={**made, "baselines": {"x": old}})


def test_a_policy_is_scored_against_the_baselines(tiny, atlas, made, tmp_path) -> None:
    """A callable that never asks for service (each vehicle's first allowed duty, no
    order), scored on the first 4 test episodes: paired with the tuned rule's shipped
    figures on those episodes, the difference of the means."""
    suite = read_suite(tiny)

    def never(env):
        n = env.unwrapped.config.n_vehicles

        def act(obs):
            duty = env.unwrapped.action_masks()[: 4 * n].reshape(n, 4).argmax(axis=1)
            return np.append(duty, 0)

        return act

    got = score(suite, never, atlas, baselines=made, episodes=4)
    rule = made["baselines"]["oracle-rule"]["episodes"]["net"][:4]
    b = got["baselines"]["oracle-rule"]
    assert b["episodes"] == rule
    assert b["minus"]["mean"] == pytest.approx(np.mean(got["episodes"]["net"]) - np.mean(rule))
    # The example's hand-written rule (loaded by path, as fleet-score --policy does) keeps
    # to the mask on every shift (score checks each action) and acts: it services pads
    # that never servicing leaves (20-shift episodes are too short for either to fail).
    example = Path(__file__).parents[4] / "examples" / "fleet_score_policy.py"
    assert example.stem == "fleet_score_policy"
    mine = score(suite, f"{example}:factory", atlas, baselines=made, episodes=4)
    assert mine["episodes"]["seed"] == got["episodes"]["seed"]
    assert all(a != b for a, b in zip(mine["episodes"]["net"], got["episodes"]["net"], strict=True))
    moved = score(suite, never, atlas, baselines=made, episodes=2, episodes_from=7)
    assert moved["episodes"]["seed"] == [7, 8]
    assert moved["not_paired"] == ["oracle-rule", "oracle-rollout", "priced"]
    path = tmp_path / "b.json"
    path.write_text(json.dumps(made))
    assert read_baselines(suite, path)["baselines"].keys() == made["baselines"].keys()


def test_baselines_of_another_protocol_are_refused(tiny, made, tmp_path) -> None:
    path = tmp_path / "b.json"
    path.write_text(json.dumps({**made, "suite_digest": "0" * 16}))
    with pytest.raises(ValueError, match="made for suite digest 0000"):
        read_baselines(read_suite(tiny), path)


def test_masks_go_to_a_predict_that_takes_them_and_a_bad_policy_is_named() -> None:
    class Env:
        class unwrapped:
            @staticmethod
            def action_masks():
                return np.array([True, False])

    class Masked:
        def predict(self, obs, deterministic=True, action_masks=None):
            self.seen = action_masks
            return np.array([1]), None

    m = Masked()
    a = Adapted(m, Env())
    assert a.kind == "predict, masked" and a.predict(None)[0].tolist() == [1]
    assert m.seen.tolist() == [True, False]
    assert Adapted(lambda obs: [0], Env()).kind == "callable"
    with pytest.raises(ValueError, match="neither an object with predict"):
        Adapted(3, Env())


def test_no_ratio_to_a_bound_that_is_not_positive() -> None:
    shipped = {"seeds": [1, 2, 3], "baselines": {},
               "bound": {"net": -0.5, "episodes": [-0.4, -0.5, -0.6]}}  # fmt: skip
    got = compare([1, 2, 3], [1.0, 2.0, 3.0], shipped)
    assert got["bound"]["net"] == pytest.approx(-0.5) and got["ratio_to_bound"] is None
    shipped["bound"]["episodes"] = [0.5, 1.0, 1.5]
    r = compare([1, 2, 3], [1.0, 2.0, 3.0], shipped)["ratio_to_bound"]
    assert r["mean"] == pytest.approx(2.0) and r["low"] <= 2.0 <= r["high"]


def test_a_maskable_ppo_is_scored_with_the_env_s_masks(tiny, atlas, made) -> None:
    """sb3-contrib's MaskablePPO applies masks only when given ``action_masks=`` (handed to
    ``run_episodes`` bare, an untrained one broke the mask); through the factory it keeps
    to the mask on every shift of the scored episodes."""
    sb3c = pytest.importorskip("sb3_contrib")
    from sb3_contrib.common.wrappers import ActionMasker

    def factory(env):
        masked = ActionMasker(env, lambda e: e.unwrapped.action_masks())
        return sb3c.MaskablePPO("MlpPolicy", masked, n_steps=32, batch_size=32, seed=0).learn(32)

    got = score(read_suite(tiny), factory, atlas, baselines=made, episodes=2)
    assert got["episodes"]["seed"] == [900_000, 900_001]
    assert np.isfinite(got["episodes"]["net"]).all()


def test_a_per_agent_wrapper_of_a_rule_scores_the_rule_s_figures(tiny, atlas, made) -> None:
    """The shipped rule written as PettingZoo users write a policy (``policy(observation,
    agent)``, reading the Parallel env's ``state()``), driven through the fleet's Parallel
    env: exactly the rule's per-episode figures; the same as a mapping of agent to
    callable; an action outside an agent's mask is named with the agent and the shift."""
    suite = read_suite(tiny)
    config = suite.study_config("test")
    _, rule = rebuild(suite, made["baselines"]["oracle-rule"], atlas, config)

    def factory(env):
        penv = parallel_env_of(env)
        where = {a: i for i, a in enumerate(penv.possible_agents)}

        def policy(observation, agent):
            assert (
                observation["observation"].shape
                == penv.observation_space(agent)["observation"].shape
            )
            return int(rule.predict(penv.state())[0][where[agent]])

        return policy

    got = score(suite, factory, atlas, baselines=made, episodes=3)
    want = made["baselines"]["oracle-rule"]["episodes"]
    assert got["episodes"]["net"] == want["net"][:3]
    assert got["episodes"]["cost"] == want["cost"][:3]

    def as_mapping(env):
        penv, policy = parallel_env_of(env), factory(env)
        return {a: (lambda obs, a=a: policy(obs, a)) for a in penv.possible_agents}

    mapped = score(suite, as_mapping, atlas, baselines=made, episodes=2)
    assert mapped["episodes"]["net"] == want["net"][:2]

    def service_always(env):
        return lambda observation, agent: 3 if agent != "store" else 0

    with pytest.raises(ValueError, match=r"broke vehicle_\d's mask at shift \d+: action 3"):
        score(suite, service_always, atlas, baselines=made, episodes=2)
    with pytest.raises(ValueError, match=r"no callable for \['vehicle_1', 'vehicle_2', 'store'\]"):
        score(suite, lambda env: {"vehicle_0": print}, atlas, baselines=made, episodes=2)
