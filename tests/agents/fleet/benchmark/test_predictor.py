"""``fleet-score --predictor``: a new RUL predictor scored by the shipped rules' protocol
(fitted on the suite's pads, the rule family tuned on its RUL, the test split), paired with
the shipped baselines; a factory that is not one refused naming the option."""

from __future__ import annotations

import json

import pytest

from agents.fleet.benchmark.baselines import read_baselines
from agents.fleet.benchmark.predictor import score_predictor
from agents.fleet.benchmark.suite import read_suite
from brake_env.cli.main import main


def not_a_predictor(atlas, seed):  # a factory of something else
    return {"atlas": atlas, "seed": seed}


@pytest.fixture(scope="module")
def scored(atlas):
    suite = read_suite("small")
    shipped = read_baselines(suite)
    got = score_predictor(suite, "baselines.window:make_window", atlas, shipped=shipped,
                          episodes=2, trials=2)  # fmt: skip
    return got, shipped


def test_a_new_predictor_is_tuned_scored_and_paired(scored) -> None:
    got, shipped = scored
    assert got["episodes"]["seed"] == shipped["seeds"][:2]
    assert got["trials"] == 2 and set(got["params"]) >= {"must", "s", "S_minus_s"}
    for name in ("oracle-rule", "twin-rule", "window-rule"):
        b = got["baselines"][name]
        assert b["episodes"] == shipped["baselines"][name]["episodes"]["net"][:2]
        m = b["minus"]
        assert m["low"] <= m["mean"] <= m["high"]
        assert m["mean"] == pytest.approx(got["net"] - b["net"])
    assert got["bound"] is not None and got["ratio_to_bound"]["mean"] > 0


def test_the_command_writes_score_json_and_repeats_the_figures(
    scored, tmp_path, monkeypatch
) -> None:
    """The same predictor under another name, through the command: the same figures (the
    fit, the tuning sampler and the episodes are all seeded)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "mine.py").write_text(
        "from baselines.window import make_window\n\ndef make(atlas, seed):\n"
        "    return make_window(atlas, seed)\n"
    )
    argv = ["fleet-score", "--suite", "small", "--predictor", "mine.py:make", "--episodes", "2",
            "--trials", "2", "--out", str(tmp_path / "o"), "--quiet"]  # fmt: skip
    assert main(argv) == 0
    doc = json.loads((tmp_path / "o" / "score.json").read_text())
    assert doc["predictor"] == "mine.py:make"
    assert doc["episodes"] == scored[0]["episodes"] and doc["params"] == scored[0]["params"]


@pytest.mark.parametrize(
    ("spec", "named"),
    [
        ("no_such_module:f", "--predictor 'no_such_module:f': cannot import"),
        ("baselines.window:nothing", "has no callable 'nothing'"),
        (f"{__name__}:not_a_predictor", "not a RUL predictor"),
    ],
)
def test_a_factory_that_gives_no_predictor_is_refused(atlas, spec, named) -> None:
    with pytest.raises(ValueError, match=named):
        score_predictor(read_suite("small"), spec, atlas, shipped=None, episodes=2, trials=1)


def test_policy_and_predictor_are_exclusive(capsys) -> None:
    with pytest.raises(SystemExit):
        main(["fleet-score", "--policy", "baseline:twin-rule", "--predictor", "a:b"])
    assert "not allowed with argument" in capsys.readouterr().err
