"""run_ends: how each run of a log ended, the one reading every fit uses."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from brake_env.data.runs import run_ends


def log(**extra: list) -> pd.DataFrame:
    return pd.DataFrame(
        {"run_id": ["b", "b", "a", "a", "a", "c"], "event": [5, 6, 0, 1, 2, 9], **extra}
    )


def test_runs_in_order_of_appearance_with_their_last_event_and_end():
    nan = np.nan
    failed = [False, True, False, False, False, False]
    ends = run_ends(log(failed=failed, measured_volume_frac=[nan, nan, nan, nan, 0.4, 0.7]))
    assert list(ends.names) == ["b", "a", "c"]
    np.testing.assert_array_equal(ends.codes, [0, 0, 1, 1, 1, 2])
    np.testing.assert_array_equal(ends.last_row, [1, 4, 5])
    np.testing.assert_array_equal(ends.last_event, [6, 2, 9])
    np.testing.assert_array_equal(ends.failed, [True, False, False])
    np.testing.assert_array_equal(ends.meas_rows, [4, 5])
    np.testing.assert_array_equal(ends.meas_volume, [0.4, 0.7])
    assert ends.describe(ends.censored) == "['a', 'c'] (2 runs)"


def test_without_the_failed_column_every_run_ends_at_failure():
    ends = run_ends(log())
    assert ends.failed.all() and ends.meas_rows.size == 0


def test_a_run_marked_failed_before_its_last_event_is_named():
    with pytest.raises(ValueError, match=r"fit: run\(s\) \['a'\] are marked 'failed' before"):
        run_ends(log(failed=[False, True, True, False, False, True]), "fit")


def test_an_empty_log_is_refused():
    with pytest.raises(ValueError, match="no events"):
        run_ends(log().iloc[:0])
