"""Scored entries on the leaderboard (issue 41): a fleet-score result plus its kind and
compute, shown per suite in the baselines' table and paired with them; an entry of another
suite digest, of other episodes or of a bad format is refused naming its file."""

from __future__ import annotations

import json

import numpy as np
import pytest

from agents.fleet.benchmark.baselines import read_baselines
from agents.fleet.benchmark.entries import make_entry, read_entries
from agents.fleet.benchmark.page import suite_section
from agents.fleet.benchmark.suite import read_suite
from agents.fleet.evaluation.costs import paired_interval


def _entry(suite, net) -> dict:
    seeds = suite.seeds("test")
    score = {"policy": "mine:make", "suite": suite.name, "suite_digest": suite.digest,
             "net": float(np.mean(net)), "episodes": {"seed": seeds, "net": list(net)}}  # fmt: skip
    return make_entry(score, "learned", training_steps=1000, cpu_hours=0.5,
                      commands=["python train.py", "brakewear fleet-score ..."])  # fmt: skip


def test_an_entry_is_in_its_suite_s_table_paired_with_the_baselines(tmp_path) -> None:
    """An entry above the twin's rule on every test episode by half the gap to the next
    baseline: ranked just below it, paired with the best; its compute and commands under
    the table."""
    suite = read_suite("small")
    shipped = read_baselines(suite)
    twin = np.asarray(shipped["baselines"]["twin-rule"]["episodes"]["net"])
    above = min(b["net"] for b in shipped["baselines"].values() if b["net"] > twin.mean())
    gap = (above - twin.mean()) / 2
    (tmp_path / "mine.json").write_text(json.dumps(_entry(suite, twin + gap)))
    entries = read_entries(suite, tmp_path)
    text = suite_section("small", "-", shipped, entries)
    rows = [r for r in text.splitlines() if r.startswith("| `")]
    names = [r.split("`")[1] for r in rows]
    assert names.index("mine") == names.index("twin-rule") + 1
    line = rows[names.index("mine")]
    assert "learned (entry)" in line
    best = np.asarray(shipped["baselines"][names[0]]["episodes"]["net"])
    iv = paired_interval(twin + gap, best, "difference")
    assert f"{iv.point:+.3f} [{iv.low:+.3f}, {iv.high:+.3f}]" in line
    assert "`mine` (scored entry): 1,000 training steps, 0.50 CPU-hours: `python train.py`" in text


def test_an_entry_shows_alone_where_no_baselines_are_shipped(tmp_path) -> None:
    suite = read_suite("large")
    (tmp_path / "mine.json").write_text(json.dumps(_entry(suite, [1.0, 3.0] * 10)))
    text = suite_section("large", "-", None, read_entries(suite, tmp_path))
    assert "| `mine` | learned (entry) | 2.000 [" in text and "| bound |" not in text


@pytest.mark.parametrize(
    ("change", "named"),
    [
        ({"suite_digest": "0" * 16}, "digest 0000000000000000, and suite 'small' is"),
        ({"kind": ""}, "'kind' must be a non-empty string"),
        ({"net": 5.0}, "'net' 5.0 is not the mean of episodes.net"),
        ({"compute": {"cpu_hours": 1.0}}, "'compute' must hold exactly"),
        ({"compute": {"training_steps": 1.5, "cpu_hours": 1.0, "commands": ["x"]}},
         "compute.training_steps must be an integer"),
        ({"compute": {"training_steps": None, "cpu_hours": -1, "commands": ["x"]}},
         "compute.cpu_hours must be a number >= 0"),
        ({"compute": {"training_steps": None, "cpu_hours": 1, "commands": []}},
         "compute.commands must be a non-empty list"),
    ],
)  # fmt: skip
def test_a_bad_entry_is_refused_naming_its_file(tmp_path, change, named) -> None:
    suite = read_suite("small")
    (tmp_path / "bad.json").write_text(json.dumps({**_entry(suite, [1.0] * 20), **change}))
    with pytest.raises(ValueError, match=r"bad\.json: ") as e:
        read_entries(suite, tmp_path)
    assert named in str(e.value)


def test_an_entry_of_other_episodes_or_with_a_baseline_s_name_is_refused(tmp_path) -> None:
    suite = read_suite("small")
    e = _entry(suite, [1.0] * 20)
    e["episodes"]["seed"] = [s + 1 for s in e["episodes"]["seed"]]
    (tmp_path / "moved.json").write_text(json.dumps(e))
    with pytest.raises(ValueError, match=r"moved\.json: episodes\.seed must be the suite's whole"):
        read_entries(suite, tmp_path)
    (tmp_path / "moved.json").unlink()
    (tmp_path / "twin-rule.json").write_text(json.dumps(_entry(suite, [1.0] * 20)))
    with pytest.raises(ValueError, match=r"entries \['twin-rule'\] have a baseline's name"):
        suite_section("small", "-", read_baselines(suite), read_entries(suite, tmp_path))


def test_the_shipped_index_entry_is_the_default_suite_s() -> None:
    """The index policy's shipped entry: of the default suite as it stands, its net the
    mean of its 20 test episodes (read_entries checks both)."""
    got = read_entries(read_suite("default"))["index"]
    assert got["kind"] == "index" and got["compute"]["training_steps"] is None
    assert len(got["episodes"]["net"]) == 20
