"""The fleet commands' numbers refused by the parser, before ``--out`` is created or marked
(issue 44, item 4): seeds beyond what numpy's legacy generator (Optuna's sampler) takes,
episodes longer than the env allows, a planner's futures beyond memory."""

from __future__ import annotations

import pytest

from brake_env.cli.main import main

CASES = [
    ("fleet-study", ["--seed", "4294967296"], "--seed"),
    ("fleet-study", ["--seed", str(2**70)], "--seed"),
    ("fleet-study", ["--seed", "2**70"], "--seed"),
    ("fleet-study", ["--shifts", "100001"], "--shifts"),
    ("fleet-study", ["--eval-episodes", "100001"], "--eval-episodes"),
    ("fleet-study", ["--rollout-samples", "1000001"], "--rollout-samples"),
    ("fleet-study", ["--rollout-horizon", "100001"], "--rollout-horizon"),
    ("fleet-distil", ["--study", "x", "--seed", "4294967296"], "--seed"),
    ("fleet-distil", ["--study", "x", "--label-episodes", "1000"], "--label-episodes"),
    ("fleet-distil", ["--study", "x", "--label-rounds", "1000"], "--label-rounds"),
    ("fleet-distil", ["--study", "x", "--seeds", "10001"], "--seeds"),
    ("simulate", ["--seed", "4294967296"], "--seed"),
]


@pytest.mark.parametrize(("command", "args", "option"), CASES)
def test_the_parser_refuses_before_out_is_created(tmp_path, capsys, command, args, option):
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as e:
        main([command, "--out", str(out), *args])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert option in err and "error" in err
    assert not out.exists()


def test_the_largest_seed_is_taken():
    from brake_env.cli.common import MAX_SEED, SEED

    assert SEED(str(MAX_SEED)) == 2**32 - 1


def test_a_bound_too_large_for_memory_is_refused_before_out_is_made(tmp_path, capsys, atlas):
    """The parser cannot know a bound's size (it needs the atlas's pad lives); the command
    builds the bound's model first, which refuses it before any unit runs, and the folder
    made for the command goes again (nothing was written)."""
    path = tmp_path / "atlas.npz"
    atlas.save(path)
    out = tmp_path / "out"
    code = main(["fleet-study", "--fleet", "default", "--shifts", "5000", "--bound-iterations",
                 "2", "--atlas", str(path), "--quiet", "--out", str(out)])  # fmt: skip
    assert code == 2
    assert "would allocate" in capsys.readouterr().err and not out.exists()
