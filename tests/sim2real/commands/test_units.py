"""``validate-gap`` on the runner: the same records in this process and on Ray, a killed run
resumed from its saved cases, a failing case named."""

from __future__ import annotations

import functools
import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

from brake_env.cli.main import build_parser, main
from brake_env.model.atlas import Atlas, AtlasSpec, cached_atlas
from brake_env.model.params import BrakeModel
from brake_env.output import json_safe
from brake_env.runner import Runner, UnitsFailed
from sim2real.commands.cli import _jobs_alias
from sim2real.commands.units import case_key, open_store, validate_gap
from sim2real.diagnosis.config import DiagnosisConfig
from sim2real.validation.validate import ValidationSpec, cases, selected_cases

TINY_FIELDS = {
    "fit_events_per_run": 400,
    "calibration_events_per_run": 400,
    "score_events_per_run": 2000,
    "grid_points": 2,
}
TINY = DiagnosisConfig(**TINY_FIELDS)
# One library effect and one control, 2 short runs each (~4 s a case): the smallest run
# that names an effect and abstains on a control.
SPEC = ValidationSpec(
    seeds_mid=1, n_controls=1, n_out_of_library=0, n_runs=2, with_rul=False, config=TINY
)
ONLY = ["tc_bias", "control"]
CLI = ["validate-gap", "--seeds", "1", "--controls", "1", "--out-of-library", "0"]
CLI += ["--runs", "2", "--no-rul", "--only", *ONLY, "--quiet"]
# The CLI has no option for the diagnosis settings: the subprocess runs it with TINY.
DRIVER = """\
import functools, sys
import sim2real.validation.validate as v
from sim2real.diagnosis.config import DiagnosisConfig
v.ValidationSpec = functools.partial(v.ValidationSpec, config=DiagnosisConfig(**{tiny!r}))
from brake_env.cli.main import main
raise SystemExit(main(sys.argv[1:]))
"""


@pytest.fixture(scope="module")
def cli_atlas() -> Atlas:
    """The atlas ``validate-gap`` loads (the hot-duty preset), in the test cache."""
    return cached_atlas(AtlasSpec(model=BrakeModel.preset("hot-duty")))


@pytest.fixture(scope="module")
def reference(cli_atlas: Atlas) -> tuple[dict[str, Any], list[str]]:
    """An uninterrupted run in this process, and its progress messages."""
    seen: list[str] = []
    return validate_gap(cli_atlas, SPEC, 0, seen.append, ONLY), seen


def _as_json(r: dict[str, Any]) -> dict[str, Any]:
    """What validation.json holds, without the timings and the run's settings."""
    d = json.loads(json.dumps(json_safe(r)))
    d["cases"] = [{k: v for k, v in c.items() if not k.startswith("seconds")} for c in d["cases"]]
    return {k: v for k, v in d.items() if k not in ("seconds", "settings")}


def test_case_keys_are_unique_though_labels_repeat() -> None:
    cs = cases(ValidationSpec(low_magnitude=True), seed=3)
    assert len({c.label for c in cs}) < len(cs) == len({case_key(c) for c in cs})


def test_records_are_the_same_in_process_and_on_ray(
    cli_atlas: Atlas, reference: tuple[dict[str, Any], list[str]], local_ray: Any, tmp_path: Path
) -> None:
    here, seen = reference
    assert [c["case"] for c in here["cases"]] == ["tc_bias:bias_k=10", "control"]
    assert seen == ["tc_bias:bias_k=10: tc_bias", "control: none of the candidates"]
    store = open_store(tmp_path, cli_atlas, SPEC, 0, ONLY)
    on_ray_seen: list[str] = []
    with Runner(workers=2) as runner:
        assert runner.on_ray
        on_ray = validate_gap(
            cli_atlas, SPEC, 0, on_ray_seen.append, ONLY, runner=runner, store=store
        )
    assert _as_json(on_ray) == _as_json(here)
    assert sorted(on_ray_seen) == sorted(seen)
    # Read back in this process from the store: the same records, nothing rerun.
    again = validate_gap(cli_atlas, SPEC, 0, None, ONLY, runner=Runner(), store=store)
    assert again["cases"] == on_ray["cases"]


def test_a_failing_case_is_named_and_the_others_are_saved(
    cli_atlas: Atlas, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def flaky(atlas: Atlas, spec: ValidationSpec, case: Any) -> dict[str, Any]:
        if case.label == "control":
            raise RuntimeError("simulated failure")
        return {"case": case.label, "answer": "tc_bias"}

    monkeypatch.setattr("sim2real.commands.units.run_case", flaky)
    store = open_store(tmp_path, cli_atlas, SPEC, 0, ONLY)
    effect, control = (case_key(c) for c in selected_cases(SPEC, 0, ONLY))
    with pytest.raises(UnitsFailed, match=f"{control}: RuntimeError: simulated failure"):
        validate_gap(cli_atlas, SPEC, 0, case_filter=ONLY, store=store)
    assert store.keys() == [effect]
    with pytest.raises(ValueError, match=r"n_runs: 2 -> 3"):
        validate_gap(cli_atlas, replace(SPEC, n_runs=3), 0, case_filter=ONLY, store=store)


def test_jobs_is_a_hidden_alias_of_workers(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["validate-gap", "--help"])
    shown = capsys.readouterr().out
    assert "--workers" in shown and "--ray" in shown and "--jobs" not in shown
    parser = build_parser()
    for jobs, workers in (("2", 2), ("1", 0)):
        args = parser.parse_args(["validate-gap", "--jobs", jobs])
        _jobs_alias(args)
        assert args.workers == workers
        assert "--jobs is deprecated" in capsys.readouterr().err
    with pytest.raises(ValueError, match="--workers only"):
        _jobs_alias(parser.parse_args(["validate-gap", "--jobs", "2", "--workers", "3"]))


def _saved_units(units: Path) -> list[Path]:
    # Not settings.json, nor a writer's hidden temporary file.
    return [p for p in units.glob("*.json") if p.name != "settings.json" and p.name[0] != "."]


def test_a_killed_run_resumes_to_the_uninterrupted_result(
    reference: tuple[dict[str, Any], list[str]],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    driver = tmp_path / "driver.py"
    driver.write_text(DRIVER.format(tiny=TINY_FIELDS))
    out = tmp_path / "out"
    cmd = [sys.executable, str(driver), *CLI, "--out", str(out)]
    env = {**os.environ, "MPLBACKEND": "Agg"}
    log = tmp_path / "killed.log"
    with log.open("w") as err:
        proc = subprocess.Popen(cmd, stdout=err, stderr=err, env=env)
        deadline = time.monotonic() + 240
        while not _saved_units(out / "units"):
            assert proc.poll() is None, f"exited before a case was saved:\n{log.read_text()}"
            assert time.monotonic() < deadline, "no case saved in 240 s"
            time.sleep(0.02)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    assert len(_saved_units(out / "units")) == 1 and not (out / "validation.json").exists()

    # The rerun in this process (the same TINY settings as the driver's): it resumes.
    import sim2real.commands.cli

    capsys.readouterr()
    with pytest.MonkeyPatch.context() as m:
        tiny_spec = functools.partial(ValidationSpec, config=TINY)
        m.setattr(sim2real.commands.cli, "ValidationSpec", tiny_spec)
        assert main([*CLI, "--out", str(out)]) == 0
    assert "validate-gap: resuming: 1 of 2 cases already done" in capsys.readouterr().err
    result = json.loads((out / "validation.json").read_text())
    assert _as_json(result) == _as_json(reference[0])
    assert (result["settings"]["workers"], result["settings"]["ray"]) == (0, None)

    # Other settings into the same --out: refused before any work, naming what changed.
    assert main([*CLI, "--out", str(out), "--runs", "3"]) == 2
    assert "n_runs: 2 -> 3" in capsys.readouterr().err
