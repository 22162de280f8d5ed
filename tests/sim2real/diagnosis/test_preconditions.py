"""The diagnosis's preconditions: a log it cannot use fails in a fraction of a second, with
the runs or columns named; a channel missing for a whole pad is reported, not fatal."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from brake_env.cli.main import main
from brake_env.data.schema import validate_event_log, write_event_log
from sim2real.diagnosis.config import DiagnosisConfig
from sim2real.diagnosis.preconditions import DiagnosisInputError, check_log


def fleet(n_runs: int = 4, n: int = 50, start: int = 0, rul: bool = True) -> pd.DataFrame:
    rng = np.random.default_rng(0)
    parts = []
    for r in range(n_runs):
        parts.append(
            pd.DataFrame(
                {
                    "run_id": f"pad-{r}",
                    "event": start + np.arange(n),
                    "speed_kmh": rng.uniform(5, 40, n),
                    "mass_kg": rng.uniform(3e4, 6e4, n),
                    "slope_rad": rng.uniform(0, 0.1, n),
                    "energy_j": rng.uniform(1e5, 1e6, n),
                    "temp_c": rng.uniform(100, 500, n),
                    "stop_dist_m": rng.uniform(1, 20, n),
                    **({"rul_events": n - 1 - np.arange(n)} if rul else {}),
                }
            )
        )
    return validate_event_log(pd.concat(parts, ignore_index=True))


def test_a_usable_log_passes_mid_life_starts_included() -> None:
    check = check_log(fleet(start=100))
    assert check.missing_channels == {} and check.warnings == []


def test_two_runs_leave_one_calibration_run_for_the_twin() -> None:
    with pytest.raises(DiagnosisInputError, match=r"2 runs, so 1 calibration run.*--no-rul"):
        check_log(fleet(2))
    check_log(fleet(2), with_rul=False)  # without the RUL error, 2 runs do
    check_log(fleet(2, rul=False))  # no rul_events: the RUL error is not computed
    with pytest.raises(DiagnosisInputError, match=r"3 runs, so 1 .*raise --calibration-fr"):
        check_log(fleet(3), DiagnosisConfig(calibration_fraction=0.2))
    check_log(fleet(3), DiagnosisConfig(calibration_fraction=0.5))  # 2 of 3
    with pytest.raises(DiagnosisInputError, match=r"1 run \('pad-0'\).*at least 2"):
        check_log(fleet(1), with_rul=False)


def test_runs_too_short_to_fit_are_named() -> None:
    log = pd.concat([fleet(3), fleet(1, n=1).assign(run_id="stub")], ignore_index=True)
    with pytest.raises(DiagnosisInputError, match=r"run\(s\) 'stub': 1 have fewer than 10"):
        check_log(validate_event_log(log))
    no_speed = fleet(3)
    no_speed.loc[no_speed.run_id == "pad-1", "speed_kmh"] = np.nan
    with pytest.raises(DiagnosisInputError, match=r"'pad-1': 0 have fewer"):
        check_log(no_speed)


def test_a_compared_channel_missing_everywhere_is_fatal_for_one_pad_reported() -> None:
    with pytest.raises(DiagnosisInputError, match=r"column 'temp_c' has 0 readings in 200"):
        check_log(fleet().assign(temp_c=np.nan))
    log = fleet()
    log.loc[log.run_id == "pad-2", ["temp_c", "energy_j"]] = np.nan
    check = check_log(log)
    assert check.missing_channels == {"pad-2": ["energy_j", "temp_c"]}
    assert "run 'pad-2' has no energy_j, temp_c at all" in check.warnings[0]
    assert "prior over K" in check.warnings[0]
    assert check.summary()["missing_channels"] == {"pad-2": ["energy_j", "temp_c"]}


def test_the_command_fails_in_seconds_naming_the_problem(tmp_path: Path, capsys) -> None:
    path = write_event_log(fleet().assign(temp_c=np.nan), tmp_path / "log.parquet")
    rc = main(["diagnose", "--real", str(path), "--out", str(tmp_path / "d"), "--quiet"])
    assert rc == 2 and "column 'temp_c' has 0 readings" in capsys.readouterr().err
    assert not (tmp_path / "d").exists()  # it stopped before any work
