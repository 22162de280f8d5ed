"""Survival likelihood of the training lives: right-censored runs move the fit the right way."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from baselines._censoring import Evidence, fit_normal
from baselines._runs import training_runs
from tests.baselines.synthetic import cut_runs, synthetic_log


def test_without_censoring_it_is_the_sample_mean_and_std() -> None:
    x = np.array([1.0, 2.0, 4.0])
    assert fit_normal(Evidence(exact=x)) == (pytest.approx(x.mean()), pytest.approx(x.std()))


def test_censored_draws_recover_the_population() -> None:
    """2,000 pads of K ~ N(2, 0.2) (life 1 / K), each removed at a planned time drawn
    independently of its wear: about half are removed before failure."""
    rng = np.random.default_rng(0)
    k = rng.normal(2.0, 0.2, 2000)
    removal = rng.uniform(0.3, 0.7, 2000)  # life 1 / K is 0.4-0.7
    cens = removal < 1.0 / k
    upper = 1.0 / removal[cens]  # survived to the removal: K below this
    assert 0.3 < cens.mean() < 0.7
    mu, sd = fit_normal(Evidence(exact=k[~cens], upper=upper))
    assert mu == pytest.approx(2.0, abs=0.02) and sd == pytest.approx(0.2, rel=0.1)
    assert fit_normal(Evidence(exact=k[~cens]))[0] > mu + 0.03  # failures only: too high
    naive = fit_normal(Evidence(exact=np.concatenate([k[~cens], upper])))[0]
    assert naive > 2.2  # removals taken as failures: K far too high
    read = k[cens] + rng.normal(0, 0.05, cens.sum())  # volume readings, noise 0.05
    mu2, sd2 = fit_normal(
        Evidence(
            exact=k[~cens],
            measured=read,
            measured_sd=np.full(cens.sum(), 0.05),
            measured_upper=upper,
        )
    )
    assert mu2 == pytest.approx(2.0, abs=0.02) and sd2 == pytest.approx(0.2, rel=0.1)


def test_bounds_alone_do_not_fix_a_mean() -> None:
    with pytest.raises(ValueError, match="at least two"):
        fit_normal(Evidence(exact=np.array([1.0]), upper=np.array([3.0, 4.0])))


def test_training_runs_read_failure_truth_and_measurements() -> None:
    log = synthetic_log([50, 60, 70], with_truth=False)
    cut = cut_runs(log[log["run_id"] != "run-00"], 0.5)
    cut.loc[cut.index[-1], "measured_volume_frac"] = 0.7
    mixed = pd.concat([log[log["run_id"] == "run-00"], cut])
    runs = training_runs(mixed)
    np.testing.assert_array_equal(runs.life, [50, np.nan, np.nan])
    np.testing.assert_array_equal(runs.last_event, [49, 29, 34])
    assert runs.censored.tolist() == [False, True, True]
    assert runs.meas_run.tolist() == [2] and runs.meas_done.tolist() == [35.0]
    assert runs.describe(runs.censored) == "['run-01', 'run-02'] (2 runs)"
    truncated = synthetic_log([50, 60])  # truth gives the life of a run cut short
    assert training_runs(truncated[truncated["event"] < 40]).life.tolist() == [50, 60]
