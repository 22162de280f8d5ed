"""The shipped baselines (issue 41): each suite's file is of the suite as it stands (its
digest), on its sealed test split, and a shipped rule re-scored on two test episodes gives
its shipped figures exactly; the leaderboard is the one the shipped files write."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from agents.fleet.benchmark.baselines import read_baselines
from agents.fleet.benchmark.entries import read_entries
from agents.fleet.benchmark.page import BEGIN, END, leaderboard
from agents.fleet.benchmark.score import Adapted, load_factory, score
from agents.fleet.benchmark.suite import read_suite
from agents.fleet.evaluation.costs import run_episode
from agents.fleet.study.build import rul_env
from agents.fleet.study.units import study_fit

RULES = {"oracle-rule", "twin-rule", "window-rule"}
SHIPPED = {
    "small": RULES | {"priced", "reference"},
    "default": RULES | {"data-rule", "physics-rule", "priced", "oracle-rollout", "twin-rollout"},
    "default-mixed": RULES | {"priced"},
    "large": RULES | {"priced"},
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
