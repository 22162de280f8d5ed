"""The twin's calibration from run-to-failure and censored runs: closed form, survival
likelihood, measured volumes, and the refusals."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from brake_env.data.censor import censor_log
from brake_env.data.datasets import Dataset
from brake_env.data.schema import FAILED, MEASURED_VOLUME
from brake_env.model.atlas import Atlas
from brake_env.model.wear import WearModel
from twin.calibration import (
    _log_likelihood,
    censored_loglik,
    fit_calibration,
    training_runs,
)


@pytest.fixture(scope="module")
def wear(atlas: Atlas) -> WearModel:
    return WearModel.from_atlas(atlas)


@pytest.fixture(scope="module")
def train(dataset: Dataset) -> pd.DataFrame:
    return dataset.logs["train"]


def test_run_to_failure_is_the_closed_form(
    atlas: Atlas, train: pd.DataFrame, wear: WearModel
) -> None:
    cal = fit_calibration(atlas, train)
    life = train.groupby("run_id", observed=True)["event"].max().to_numpy() + 1
    log_k = np.log(wear.life_work / life)
    n = life.size
    assert cal.k_log_mean == pytest.approx(log_k.mean(), rel=1e-12)
    assert cal.k_log_scale == pytest.approx(np.std(log_k, ddof=1) * math.sqrt(1 + 1 / n))
    assert cal.prior_dof == n - 1 and cal.n_runs == n
    # Without a failed column every run is taken to end at failure: the same fit.
    assert train[FAILED].sum() == n
    assert fit_calibration(atlas, train.drop(columns=FAILED)) == cal


def test_survival_likelihood_matches_the_normal_cdf(train: pd.DataFrame, wear: WearModel) -> None:
    """One run removed after n events, none measured: its evidence integrated over a
    Gaussian prior is P(K < life_work / n) up to the operating-mix spread of the life."""
    one = train[train["run_id"] == train["run_id"].iloc[0]].iloc[:20_000]
    runs = training_runs(one.assign(**{FAILED: False}), wear)
    grid, ll = censored_loglik(runs, wear)
    mu, s = math.log(wear.life_work / 18_000), 0.1  # most prior lives end before 20,000
    got = _log_likelihood(mu, s, np.zeros(0), grid, ll)
    want = stats.norm.logcdf((math.log(wear.life_work / 20_000) - mu) / s)
    assert got == pytest.approx(want, abs=0.01)


def test_censored_with_volume_recovers_the_prior(
    atlas: Atlas, train: pd.DataFrame, dataset: Dataset
) -> None:
    full = fit_calibration(atlas, train)
    cut = censor_log(train, np.random.default_rng(0), volume_noise=0.02)
    cal = fit_calibration(atlas, cut)
    true_log_k = np.log(train.groupby("run_id", observed=True)["wear_coeff"].first())
    assert cal.k_log_mean == pytest.approx(true_log_k.mean(), abs=0.03)
    assert cal.k_log_mean == pytest.approx(full.k_log_mean, abs=0.03)
    assert 0.5 < cal.k_log_scale / full.k_log_scale < 2.0
    # The noise model is fitted along each run's path at its estimated K.
    assert cal.temp_sigma_c == pytest.approx(full.temp_sigma_c, rel=0.1)
    assert abs(cal.temp_bias_c) < 0.5
    # Taking the cut lengths for lives (no failed column) is what the likelihood avoids.
    naive = fit_calibration(atlas, cut.drop(columns=[FAILED, MEASURED_VOLUME]))
    assert naive.k_log_mean - true_log_k.mean() > 0.2


def test_a_short_censored_run_is_not_a_short_life(atlas: Atlas, train: pd.DataFrame) -> None:
    """A pad removed after a tenth of its life, unmeasured, barely moves the prior; read as
    a life it would pull the mean K up by a factor ~10 / n_runs in log."""
    base = fit_calibration(atlas, train)
    extra = train[train["run_id"] == train["run_id"].iloc[0]].iloc[:10_000]
    extra = extra.assign(run_id="removed-early")
    both = pd.concat([train, extra.assign(**{FAILED: False})], ignore_index=True)
    cal = fit_calibration(atlas, both)
    assert cal.k_log_mean == pytest.approx(base.k_log_mean, abs=0.01)
    assert cal.n_runs == base.n_runs + 1 and cal.prior_dof == base.prior_dof
    # Its K is only bounded, so its path is unknown: the noise model leaves it out.
    assert (cal.temp_bias_c, cal.temp_sigma_c) == (base.temp_bias_c, base.temp_sigma_c)


def test_refusals_name_the_runs(atlas: Atlas, train: pd.DataFrame) -> None:
    blind = censor_log(train, np.random.default_rng(0), volume_noise=None)
    with pytest.raises(ValueError, match=r"got 0; runs like \['train-00'"):
        fit_calibration(atlas, blind)
    early = train.copy()
    early.loc[early.index[5], FAILED] = True
    with pytest.raises(ValueError, match=r"\['train-00'\] are marked 'failed' before"):
        fit_calibration(atlas, early)
    cut = censor_log(train, np.random.default_rng(0))
    row = int(np.flatnonzero(cut[MEASURED_VOLUME].notna())[1])
    cut.loc[row, MEASURED_VOLUME] = 0.0
    with pytest.raises(ValueError, match=rf"row {row}, run 'train-01'.* 0 is impossible"):
        fit_calibration(atlas, cut)
