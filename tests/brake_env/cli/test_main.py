import json

import pytest

from brake_env.cli.main import main

SMALL = [
    "--n-train",
    "1",
    "--n-id",
    "1",
    "--n-ood-slow",
    "1",
    "--n-ood-fast",
    "1",
    "--k-mean",
    "4e-5",
    "--k-std",
    "4e-6",
    "--quiet",
]


def test_simulate_writes_logs_summary_and_figures(tmp_path) -> None:
    out = tmp_path / "data"
    assert main(["simulate", "--out", str(out), "--seed", "1", *SMALL]) == 0
    for split in ("train", "id", "ood"):
        assert (out / f"{split}.parquet").stat().st_size > 0
        assert (out / f"{split}.csv").stat().st_size > 0
    s = json.loads((out / "summary.json").read_text())
    assert {"seed", "atlas", "life_events", "runs", "timing_s", "failure_volume_frac"} <= set(s)
    assert len(s["runs"]) == 4
    assert {"atlas_build", "simulate", "write"} <= set(s["timing_s"])
    assert 0.15 <= s["atlas"]["critical_volume_frac"] <= 0.25
    assert (out / "figures" / "volume_trajectories.png").stat().st_size > 0
    assert list((out / "figures").glob("trace_*.png"))


def test_simulate_same_seed_same_output(tmp_path) -> None:
    for d in ("a", "b"):
        main(["simulate", "--out", str(tmp_path / d), "--seed", "7", "--format", "csv", *SMALL])
    for split in ("train", "id", "ood"):
        assert (tmp_path / f"a/{split}.csv").read_bytes() == (
            tmp_path / f"b/{split}.csv"
        ).read_bytes()
    sa, sb = (json.loads((tmp_path / d / "summary.json").read_text()) for d in ("a", "b"))
    sa.pop("timing_s"), sb.pop("timing_s")  # wall times are the only difference
    assert sa == sb


@pytest.mark.slow
def test_atlas_command_and_demo(tmp_path, monkeypatch) -> None:
    import agents.commands.cli
    import agents.fleet.commands.cli
    import sim2real.commands.demo

    # Every stage at tiny budgets, in this process, into one report: this is the stages'
    # demo test (their commands have tests of their own: test_train_compare.py,
    # fleet/study/test_run.py; the prognostics' stage on data the twin can fit:
    # prognostics/commands/test_evaluate.py).
    tiny = {"heuristics": ("threshold",), "shifts": 20, "trials": 1, "episodes": 2}
    monkeypatch.setattr(agents.fleet.commands.cli, "DEMO_FLEET", tiny)
    monkeypatch.setattr(agents.fleet.commands.cli, "DEMO_FLEET_PREDICTORS", ("none", "oracle"))
    monkeypatch.setattr(sim2real.commands.demo, "DEMO_RUNS", 3)
    monkeypatch.setattr(sim2real.commands.demo, "DEMO_CANDIDATES", ("speed_friction", "tc_bias"))
    for name, value in (("DEMO_TUNE_PADS", 2), ("DEMO_EVAL_PADS", 2)):
        monkeypatch.setattr(agents.commands.cli, name, value)
    assert main(["atlas", "--out", str(tmp_path / "atlas"), "--quiet"]) == 0
    info = json.loads((tmp_path / "atlas" / "atlas.json").read_text())
    assert info["wear_per_event_ratio_end_fresh"] >= 1.2
    assert info["mean_temp_strictly_rising_everywhere"] is True
    assert (tmp_path / "atlas" / "calibration.png").stat().st_size > 0
    assert main(["demo", "--out", str(tmp_path / "demo"), "--workers", "0", *SMALL]) == 0
    report = (tmp_path / "demo/report.md").read_text()
    assert "(cannot-stop: the" in report and "## The fleet study" in report
    for section in ("## Prognostics", "## Maintenance cost by predictor", "## Sim-to-real gap"):
        assert section in report
    assert "Verdict: **speed_friction**" in report  # the withheld effect is named
    assert "the truth is 0.2" in report  # its fitted parameter set against the truth
    # Each stage's wall and CPU seconds, in run order, then the total.
    times = report.split("## Stage times")[1].split("\n## ")[0]
    stages = [r.split("|")[1].strip() for r in times.splitlines() if r.startswith("| ")][1:]
    assert stages == ["atlas", "datasets", "evaluate", "compare", "fleet", "diagnose", "total"]
    assert "## The fleet study (BrakeWearFleet-v2, `small` fleet)" in report
    demo = tmp_path / "demo"
    # The comparison: its table, and the agent it was given no budget to train named.
    assert "not trained" in report and "| policy |" in report
    # The fleet: its table without agents, and a ranking of the predictors.
    assert "no agent" in report and "| predictor |" in report
    assert json.loads((demo / "fleet" / "costs.json").read_text())["ranking"]["order"]


def test_bad_arguments_are_named(tmp_path, capsys) -> None:
    with pytest.raises(SystemExit):
        main(["simulate", "--out", str(tmp_path), "--format", "xlsx"])
    assert "--format" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["simulate", "--out", str(tmp_path), "--n-train", "-2"])
    with pytest.raises(SystemExit, match="2"):
        main(["simulate", "--out", str(tmp_path), "--k-std", "-1", "--quiet"])
    assert "--k-std" in capsys.readouterr().err


def test_the_whole_parser_loads_no_heavy_library() -> None:
    """Every plug-in registered (agents, sim2real): ``brakewear --help`` imports none of
    the libraries that take seconds; the commands import them when they run."""
    import subprocess
    import sys

    heavy = ("torch", "stable_baselines3", "scipy", "matplotlib", "ray")
    code = (
        "import sys; from brake_env.cli.main import build_parser; build_parser();"
        f" print(*[m for m in {heavy!r} if m in sys.modules])"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0 and done.stdout.split() == [], done.stdout + done.stderr[-500:]


def test_a_command_named_by_its_path_is_imported_when_it_runs() -> None:
    import os.path

    from brake_env.cli.main import command

    assert command("os.path:join") is os.path.join
    assert command(print) is print
