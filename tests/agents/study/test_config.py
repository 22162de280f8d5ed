"""StudyConfig: validated, its env reported flat, its cost ratios priced."""

from __future__ import annotations

import pytest

from agents.study.config import StudyConfig
from brake_env.env.config import EnvConfig
from brake_env.model.regime import WearRegime


def test_study_config_is_validated():
    with pytest.raises(ValueError, match="unknown predictor"):
        StudyConfig(predictors=("crystal-ball",))
    with pytest.raises(ValueError, match="eval_pads must be >= 1"):
        StudyConfig(eval_pads=0)
    with pytest.raises(TypeError, match="EnvConfig"):
        StudyConfig(env={"k_mean": 1e-5})


def test_study_config_reports_its_env_flat_and_prices_its_ratios():
    config = StudyConfig(
        env=EnvConfig(regime="mixed", k_mean=1e-5, k_std=1e-6, ood_shift_sigma=4.0)
    )
    assert config.wear == WearRegime(1e-5, 1e-6, 4.0)
    flat = config.to_dict()
    assert "env" not in flat and (flat["k_mean"], flat["ood_shift_sigma"]) == (1e-5, 4.0)
    assert list(flat)[:4] == ["regime", "ood_share", "decision_interval", "episode_events"]
    assert config.ratios() == (5.0, 10.0, 50.0, 200.0)
    assert config.weights(10.0) is config.costs
    w = config.weights(50.0)
    assert w.failure_to_planned == pytest.approx(50.0) and w.planned_replacement == 1000.0
