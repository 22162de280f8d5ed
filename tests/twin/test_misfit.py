"""The twin's misfit test (twin.misfit): quiet on the atlas's own physics, loud on a log whose
temperatures follow another course over the life, and honest about what it could not check."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from brake_env.data.datasets import Dataset
from brake_env.prognostics.protocol import iter_runs
from twin import DigitalTwin
from twin.misfit import MIN_EVENTS, MIN_PADS, T_THRESHOLD, drift, misfit


def _steeper(log: pd.DataFrame, kelvin: float) -> pd.DataFrame:
    """The log with each pad's temperatures raised by ``kelvin`` times its life fraction: a
    pad that heats up over its life faster than the atlas says."""
    out = log.copy()
    frac = out["event"] / out.groupby("run_id")["event"].transform("max")
    out["temp_c"] = out["temp_c"] + kelvin * frac
    return out


def test_quiet_on_the_atlas_own_physics(fitted: DigitalTwin, dataset: Dataset) -> None:
    assert fitted.grid is not None
    for split in ("train", "id"):
        found = misfit(fitted.grid, dataset.logs[split])
        assert found.checked and not found.warns, found.message()
        assert abs(found.t) < T_THRESHOLD and abs(np.log(found.factor)) < 0.05
    assert fitted.self_check(dataset.logs["train"])["warns"] is False


def test_loud_on_a_temperature_course_the_atlas_does_not_have(
    fitted: DigitalTwin, dataset: Dataset
) -> None:
    assert fitted.grid is not None
    log = _steeper(dataset.logs["train"], 15.0)
    found = misfit(fitted.grid, log)
    # The windows need K that drift the same way on every pad, beyond the threshold, and
    # the opposite way when the course is shallower instead.
    assert found.warns and abs(found.t) > T_THRESHOLD
    sign = np.sign(found.z)
    assert all(np.sign(z) == sign for z in found.per_pad.values())
    assert np.sign(np.log(found.factor)) == sign
    assert "brakewear diagnose --real" in found.message()
    shallower = misfit(fitted.grid, _steeper(dataset.logs["train"], -15.0))
    assert shallower.warns and np.sign(shallower.z) == -sign


def test_drift_of_one_pad_is_the_same_alone_or_with_others(
    fitted: DigitalTwin, dataset: Dataset
) -> None:
    assert fitted.grid is not None
    runs = [ev for _, ev in iter_runs(dataset.logs["train"])]
    together = drift(fitted.grid, runs)
    alone = drift(fitted.grid, runs[2:3])
    np.testing.assert_allclose(alone[0][0], together[0][2], rtol=1e-9)
    np.testing.assert_allclose(alone[1][0], together[1][2], rtol=1e-9)


def test_too_few_pads_or_events_is_not_checked(fitted: DigitalTwin, dataset: Dataset) -> None:
    assert fitted.grid is not None
    log = dataset.logs["train"]
    few = log[log["run_id"].isin(log["run_id"].unique()[: MIN_PADS - 1])]
    found = misfit(fitted.grid, _steeper(few, 15.0))
    assert not found.checked and not found.warns and "not checked" in found.message()
    short = log[log["event"] < MIN_EVENTS - 1]
    assert misfit(fitted.grid, short).pads == 0
    with pytest.raises(RuntimeError, match="fit"):
        DigitalTwin(fitted.atlas).self_check(log)
