"""Partial regeneration (issue 41): ``fleet-baselines --only NAMES`` remakes the named
baselines and merges them into the shipped file, keeping the others and recording each
remade one's command; a file of another suite digest is refused."""

from __future__ import annotations

import copy
import json

import pytest

from agents.fleet.benchmark.baselines import merge, read_baselines, split_only
from agents.fleet.benchmark.suite import read_suite


def _made(shipped: dict, shift: float) -> dict:
    """A remade bound and priced policy of the small suite: the shipped figures + shift."""
    priced = copy.deepcopy(shipped["baselines"]["priced"])
    priced["episodes"]["net"] = [v + shift for v in priced["episodes"]["net"]]
    bound = {**shipped["bound"], "episodes": [v + shift for v in shipped["bound"]["episodes"]]}
    return {"suite": "small", "suite_digest": shipped["suite_digest"],
            "baselines": {"priced": priced}, "bound": bound, "seconds": 12.0}  # fmt: skip


def test_only_the_named_baselines_are_replaced_each_with_its_command() -> None:
    shipped = read_baselines(read_suite("small"))
    before = copy.deepcopy(shipped)
    got = merge(shipped, _made(shipped, 1.0), {"bound", "priced"}, "brakewear x --only b")
    assert shipped == before  # the shipped content is not changed in place
    assert got["command"] == shipped["command"]  # the file's command stays for the rest
    for k in ("reference", "oracle-rule", "twin-rule", "window-rule"):
        assert got["baselines"][k] == shipped["baselines"][k]
    priced, old = got["baselines"]["priced"], shipped["baselines"]["priced"]
    assert priced["episodes"]["net"] == [v + 1.0 for v in old["episodes"]["net"]]
    assert priced["command"] == got["bound"]["command"] == "brakewear x --only b"
    assert got["bound"]["episodes"] == [v + 1.0 for v in shipped["bound"]["episodes"]]
    only_priced = merge(shipped, _made(shipped, 1.0), {"priced"}, "c")
    assert only_priced["bound"] == shipped["bound"]


def test_a_merge_into_another_suite_digest_or_of_other_episodes_is_refused(tmp_path) -> None:
    suite = read_suite("small")
    shipped = read_baselines(suite)
    other = tmp_path / "other.json"
    other.write_text(json.dumps({**shipped, "suite_digest": "f" * 16}))
    with pytest.raises(ValueError, match="made for suite digest ffff"):
        read_baselines(suite, other)  # what --into reads first
    with pytest.raises(ValueError, match="the file to merge into is of suite digest ffff"):
        merge({**shipped, "suite_digest": "f" * 16}, _made(shipped, 0.0), {"bound"}, "c")
    moved = _made(shipped, 0.0)
    moved["baselines"]["priced"]["episodes"]["seed"] = list(range(20))
    with pytest.raises(ValueError, match="priced was made on other test episodes"):
        merge(shipped, moved, {"priced"}, "c")
    with pytest.raises(ValueError, match=r"\['twin-rule'\] were not made"):
        merge(shipped, _made(shipped, 0.0), {"twin-rule"}, "c")


def test_only_s_names() -> None:
    assert split_only("bound,priced") == ({"bound", "priced"}, ())
    assert split_only("twin-rule, oracle-rule,window-rollout")[1] == ("oracle", "twin", "window")
    with pytest.raises(ValueError, match=r"\['best'\] not baseline names"):
        split_only("bound,best")
