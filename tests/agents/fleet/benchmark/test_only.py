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


def _distil(seeds: list[int], nets: list[list[float]]) -> dict:
    """A fleet-distil distil.json of ``len(nets)`` training seeds on episodes ``seeds``."""
    rows = [{"seed": s, "net": float(sum(n) / len(n)), "train_seconds": 2.0,
             "evaluate_seconds": 1.0,
             "episodes": {"seed": seeds, "net": n, "cost": [v + 1.0 for v in n]}}
            for s, n in enumerate(nets)]  # fmt: skip
    return {
        "predictor": "twin",
        "base": "best combination",
        "distil": {"seeds": len(nets)},
        "labels": {"seconds": 10.0},
        "central": {"seeds": rows},
        "command": "brakewear d",
    }


def test_a_distilled_policy_is_merged_from_its_fleet_distil(tmp_path, capsys) -> None:
    from brake_env.cli.main import main

    suite = read_suite("small")
    shipped = read_baselines(suite)
    seeds = shipped["seeds"]
    a = [float(i) for i in range(len(seeds))]
    b = [v + 2.0 for v in a]
    run = tmp_path / "distil"
    run.mkdir()
    (run / "distil.json").write_text(json.dumps(_distil(seeds, [a, b])))
    into = tmp_path / "small.json"
    into.write_text(json.dumps(shipped))
    main(["fleet-baselines", "--suite", "small", "--only", "twin-distilled", "--distil-from",
          str(run), "--into", str(into), "--out", str(tmp_path / "out")])  # fmt: skip
    got = json.loads(into.read_text())
    d = got["baselines"]["twin-distilled"]
    assert d["episodes"]["net"] == [v + 1.0 for v in a]  # each episode: the seeds' mean
    assert d["episodes"]["cost"] == [v + 2.0 for v in a]
    assert d["net"] == pytest.approx(sum(a) / len(a) + 1.0)
    assert d["seed_nets"] == [sum(a) / len(a), sum(b) / len(b)] and d["kind"] == "distilled"
    assert d["seconds"] == 16.0 and f"--distil-from {run}" in d["command"]
    assert d["distil_command"] == "brakewear d"
    assert "nets" not in d  # a run without agents: its figures are read, not re-scored
    others = [{k: v for k, v in f["baselines"].items() if k != "twin-distilled"}
              for f in (got, shipped)]  # fmt: skip
    assert others[0] == others[1]
    bad = _distil(seeds, [a, b])
    bad["central"]["seeds"][1]["episodes"]["seed"] = list(range(len(seeds)))
    (run / "distil.json").write_text(json.dumps(bad))
    before = into.read_text()
    assert main(["fleet-baselines", "--suite", "small", "--only", "twin-distilled",
                 "--distil-from", str(run), "--into", str(into)]) == 2  # fmt: skip
    assert "training seeds ran different episodes" in capsys.readouterr().err
    assert main(["fleet-baselines", "--suite", "small", "--only", "twin-distilled,bound",
                 "--into", str(into)]) == 2  # a distilled policy is read, never made  # fmt: skip
    assert "merged alone, from the fleet-distil run" in capsys.readouterr().err
    assert into.read_text() == before
