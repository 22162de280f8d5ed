"""Bad option values of every ``brakewear`` subcommand are refused while parsing: exit code
2, one line on stderr naming the option, and nothing written."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from brake_env.cli import common
from brake_env.cli.main import build_parser, main

# What each command needs besides the option under test (files need not exist: parsing
# stops at the bad value).
REQUIRED = {
    "fit": ["--data", "d.parquet", "--predictor", "twin"],
    "predict": ["--model", "m", "--log", "l.parquet"],
    "diagnose": ["--real", "r.parquet"],
    "fleet-distil": ["--study", "s"],
}
COMMON = ["atlas", "simulate", "demo", "evaluate", "fit", "train", "compare", "fleet-study",
          "fleet-distil", "diagnose", "validate-gap"]  # fmt: skip
RUNNERS = ["predict", "evaluate", "train", "compare", "fleet-study", "fleet-distil",
           "validate-gap"]  # fmt: skip

BAD: list[tuple[str, str, str]] = [
    *((cmd, "--seed", "-1") for cmd in COMMON),
    *((cmd, "--seed", "1.5") for cmd in ("simulate", "fleet-study")),
    *((cmd, "--out", "FILE") for cmd in [*COMMON, "predict"]),
    *((cmd, "--out", "FILE/sub") for cmd in ("simulate", "predict", "fleet-study")),
    *((cmd, "--cache-dir", "FILE") for cmd in ("atlas", "predict", "compare")),
    *((cmd, "--workers", "-1") for cmd in RUNNERS),
    ("simulate", "--n-train", "-1"),
    ("simulate", "--format", ""),
    ("simulate", "--k-mean", "0"),
    ("simulate", "--k-std", "nan"),
    ("simulate", "--ood-shift-sigma", "-1"),
    ("simulate", "--route-block-events", "-5"),
    ("simulate", "--mean-gap-s", "0"),
    ("demo", "--n-id", "-3"),
    ("evaluate", "--predictors", ""),
    ("evaluate", "--predictors", "twin,magic"),
    ("evaluate", "--batch-events", "-1"),
    ("evaluate", "--mlp-epochs", "0"),
    ("predict", "--pads-per-unit", "0"),
    ("train", "--timesteps", "0"),
    ("train", "--n-train-runs", "0"),
    ("train", "--curve-pads", "0"),
    ("train", "--eval-pads", "-4"),
    ("train", "--decision-interval", "0"),
    ("train", "--episode-events", "1"),
    ("compare", "--predictors", ""),
    ("compare", "--predictors", ","),
    ("compare", "--timesteps", "-100"),
    ("compare", "--tune-pads", "0"),
    ("compare", "--eval-pads", "0"),
    ("compare", "--resamples", "10"),
    ("compare", "--k-mean", "-2e-6"),
    ("fleet-study", "--predictors", ""),
    ("fleet-study", "--agents", "magic"),
    ("fleet-study", "--heuristics", ""),
    ("fleet-study", "--shifts", "1"),
    ("fleet-study", "--trials", "0"),
    ("fleet-study", "--trials-best", "0"),
    ("fleet-study", "--tune-episodes", "0"),
    ("fleet-study", "--eval-episodes", "1"),
    ("fleet-study", "--agent-seeds", "-1"),
    ("fleet-study", "--shared-seeds", "-1"),
    ("fleet-study", "--timesteps", "0"),
    ("fleet-study", "--dagger", "-1"),
    ("fleet-study", "--learning-rate", "0"),
    ("fleet-study", "--ent-coef", "-0.1"),
    ("fleet-study", "--imitate", "-1"),
    ("fleet-study", "--curve-every", "0"),
    ("fleet-study", "--curve-episodes", "0"),
    ("fleet-study", "--imitation-epochs", "0"),
    ("fleet-study", "--imitation-lr", "0"),
    ("fleet-study", "--n-envs", "0"),
    ("fleet-study", "--clip-range", "-1"),
    ("fleet-study", "--reorder", "-1"),
    ("fleet-study", "--tail", "-1"),
    ("fleet-distil", "--predictor", "magic"),
    ("fleet-distil", "--seeds", "-1"),
    ("fleet-distil", "--shared-seeds", "-1"),
    ("fleet-distil", "--label-episodes", "0"),
    ("fleet-distil", "--label-rounds", "-1"),
    ("fleet-distil", "--label-chunk", "0"),
    ("fleet-distil", "--timesteps", "-1"),
    ("fleet-distil", "--imitation-epochs", "0"),
    ("fleet-distil", "--imitation-lr", "0"),
    ("fleet-distil", "--learning-rate", "-1"),
    ("fleet-distil", "--ent-coef", "-0.1"),
    ("fleet-distil", "--n-envs", "0"),
    ("diagnose", "--calibration-fraction", "1.5"),
    ("diagnose", "--candidates", " "),
    ("validate-gap", "--seeds", "0"),
    ("validate-gap", "--controls", "-1"),
    ("validate-gap", "--out-of-library", "-1"),
    ("validate-gap", "--runs", "0"),
    ("validate-gap", "--only", ""),
    ("validate-gap", "--route-block-events", "-1"),
]


@pytest.mark.parametrize(("command", "flag", "value"), BAD, ids=[" ".join(b) for b in BAD])
def test_a_bad_value_exits_2_naming_the_flag_and_writes_nothing(
    command: str, flag: str, value: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    a_file = tmp_path / "FILE"
    a_file.write_text("mine\n")
    value = value.replace("FILE", str(a_file))
    out = ["--out", str(tmp_path / "out")] if flag != "--out" else []
    argv = [command, *REQUIRED.get(command, []), *out, flag, value]
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err  # one line
    assert f"brakewear {command}: error: argument {flag}" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["FILE"]
    assert a_file.read_text() == "mine\n"


def test_every_number_option_is_checked() -> None:
    """No subcommand takes a bare int or float: each goes through a validator of
    :mod:`brake_env.cli.common` (``evaluate --seeds`` is checked by the command: it names
    repeated and negative seeds together)."""
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    bare = [
        f"{name} {a.option_strings[0]}"
        for name, parser in sub.choices.items()
        for a in parser._actions
        if a.type in (int, float) and (name, a.dest) != ("evaluate", "seeds")
    ]
    assert bare == []
    for name, parser in sub.choices.items():
        types = {a.dest: a.type for a in parser._actions}
        if "out" in types:
            assert types["out"] is common.out_dir, name
        if "seed" in types:
            assert types["seed"] is common.SEED, name


def test_an_empty_agent_list_means_no_agent() -> None:
    args = build_parser().parse_args(["compare", "--agents", ""])
    assert args.agents == ()
