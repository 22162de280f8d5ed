"""The shipped baselines (issue 41): each suite's file is of the suite as it stands (its
digest), on its sealed test split, and a shipped rule re-scored on two test episodes gives
its shipped figures exactly; the leaderboard is the one the shipped files write."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from agents.fleet.benchmark.baselines import read_baselines, rebuilt_from
from agents.fleet.benchmark.entries import read_entries
from agents.fleet.benchmark.page import BEGIN, END, leaderboard
from agents.fleet.benchmark.score import Adapted, load_factory, score
from agents.fleet.benchmark.suite import read_suite
from agents.fleet.evaluation.costs import run_episode
from agents.fleet.study.build import rul_env
from agents.fleet.study.units import study_fit

RULES = {"oracle-rule", "twin-rule", "window-rule", "data-rule", "physics-rule"}
ROLLOUTS = {"oracle-rollout", "twin-rollout"}
SHIPPED = {
    "small": RULES | ROLLOUTS | {"priced", "reference", "twin-distilled"},
    "default": RULES | ROLLOUTS | {"priced", "oracle-distilled", "twin-distilled"},
    "default-mixed": RULES | ROLLOUTS | {"priced", "twin-distilled"},
    "large": RULES | ROLLOUTS | {"priced"},
}
PAGE = Path(__file__).parents[4] / "docs" / "benchmark.md"


@pytest.mark.parametrize("name", sorted(SHIPPED))
def test_each_shipped_file_is_of_its_suite_s_test_split(name) -> None:
    suite = read_suite(name)
    shipped = read_baselines(suite)  # refuses a file of another digest
    assert shipped is not None and shipped["seeds"] == suite.seeds("test")
    assert SHIPPED[name] <= set(shipped["baselines"])
    for b in shipped["baselines"].values():
        assert b["episodes"]["seed"] == shipped["seeds"]
    assert len(shipped["bound"]["episodes"]) == len(shipped["seeds"])


def test_a_shipped_rule_re_scored_on_two_test_episodes_gives_its_figures(atlas) -> None:
    suite = read_suite("small")
    shipped = read_baselines(suite)
    got = score(suite, "baseline:oracle-rule", atlas, episodes=2)
    want = shipped["baselines"]["oracle-rule"]["episodes"]
    assert got["episodes"]["seed"] == want["seed"][:2]
    assert got["episodes"]["net"] == want["net"][:2]
    assert got["episodes"]["cost"] == want["cost"][:2]


def test_the_leaderboard_on_the_page_is_the_shipped_files() -> None:
    text = PAGE.read_text()
    between = text.split(BEGIN, 1)[1].split(END, 1)[0]
    assert between.strip() == leaderboard().strip(), "run: brakewear fleet-leaderboard"


@pytest.fixture(scope="module")
def twin_test_env(atlas):
    """The default suite's scoring env on its first test episode (the twin's RUL, the
    suite's own fit): built once for the learned entries."""
    suite = read_suite("default")
    config = dataclasses.replace(suite.study_config("test"), eval_episodes=2)
    return suite, config, rul_env(config, atlas, "twin", study_fit(config, "twin", atlas, atlas))


@pytest.mark.parametrize(("entry", "factory"), [
    ("mappo", "agents.fleet.benchmark.training.mappo:factory"),
    ("maskable-ppo", "agents.fleet.benchmark.training.maskable:factory"),
])  # fmt: skip
def test_a_shipped_learned_entry_re_scored_gives_its_figures(entry, factory, twin_test_env):
    """The shipped model, loaded by the entry's factory as fleet-score loads it, acts within
    the masks (checked at each shift) and gives the entry's first test episode exactly (one:
    a MAPPO episode takes ~10 CPU s)."""
    suite, config, env = twin_test_env
    want = read_entries(suite)[entry]
    assert want["policy"] == factory
    policy = Adapted(load_factory(factory)(env), env)
    got = [run_episode(env, policy, seed, check_masks=True) for seed in config.eval_seeds()[:1]]
    assert [e.seed for e in got] == want["episodes"]["seed"][:1]
    assert [e.net for e in got] == want["episodes"]["net"][:1]


def test_a_baselines_file_of_the_env_id_before_the_credit_change_is_refused(tmp_path) -> None:
    """v1's figures stand on ``id`` fleets (v2 gives the same episodes there), not on a
    mixed one, whose net changed in v2."""
    import json

    for name, ok in (("small", True), ("default-mixed", False)):
        suite = read_suite(name)
        f = tmp_path / f"{name}.json"
        f.write_text(json.dumps({**read_baselines(suite), "env_id": "BrakeWearFleet-v1"}))
        if ok:
            assert read_baselines(suite, f)["env_id"] == "BrakeWearFleet-v1"
        else:
            with pytest.raises(ValueError, match="measured on BrakeWearFleet-v1"):
                read_baselines(suite, f)


def test_the_shipped_reference_re_scored_on_a_test_episode_gives_its_figures(atlas) -> None:
    """The exact program rebuilt from its ``tail`` and its spares' rule (the oracle's best,
    as its own study gave it), on the first two test episodes of ``small``."""
    suite = read_suite("small")
    shipped = read_baselines(suite)
    entry = shipped["baselines"]["reference"]
    got = score(suite, "baseline:reference", atlas, episodes=2)
    assert got["episodes"]["net"] == entry["episodes"]["net"][:2]
    assert got["episodes"]["cost"] == entry["episodes"]["cost"][:2]


def test_a_shipped_distilled_policy_re_scored_gives_its_seeds_mean(atlas) -> None:
    """Every training seed's shipped agent rebuilt (``small``'s twin, 5 seeds) on the first
    two test episodes: the seeds' mean is the shipped figure exactly."""
    suite = read_suite("small")
    entry = read_baselines(suite)["baselines"]["twin-distilled"]
    assert len(entry["training_seeds"]) == 5 and entry["nets"]["file"].endswith(".npz")
    got = score(suite, "baseline:twin-distilled", atlas, episodes=2)
    assert got["episodes"]["net"] == entry["episodes"]["net"][:2]
    assert got["episodes"]["cost"] == entry["episodes"]["cost"][:2]


def test_a_study_s_reference_records_its_tail_and_the_oracle_s_rule() -> None:
    rule = {"predictor": "oracle", "policy": "threshold", "params": {"s": 2}}
    summary = {
        "config": {"tail": 120},
        "best_heuristic": {"oracle": "threshold"},
        "rows": [{"predictor": "twin", "policy": "threshold", "params": {"s": 9}}, rule],
    }
    assert rebuilt_from(summary, "reference", "oracle") == {
        "tail": 120,
        "spares_of": {"policy": "threshold", "params": {"s": 2}},
    }
    no_oracle = {**summary, "best_heuristic": {"twin": "threshold"}}
    assert rebuilt_from(no_oracle, "reference", "oracle") == {"tail": 120, "spares_of": None}


def test_a_rollout_records_the_planner_s_own_seed_when_set_apart() -> None:
    rule = {"predictor": "oracle", "policy": "threshold", "params": {"s": 2}}
    cfg = {"rollout_horizon": 5, "rollout_samples": 4, "seed": 0}
    summary = {"config": cfg, "best_heuristic": {"oracle": "threshold"}, "rows": [rule]}
    assert rebuilt_from(summary, "rollout", "oracle")["planner"]["seed"] == 0
    moved = {**summary, "config": {**cfg, "rollout_seed": 2}}
    assert rebuilt_from(moved, "rollout", "oracle")["planner"]["seed"] == 2
