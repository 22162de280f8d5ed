"""Fixtures of the twin tests: a few simulated pads and a twin fitted on their training runs."""

from __future__ import annotations

import pandas as pd
import pytest

from brake_env.data.datasets import Dataset, DatasetSpec, make_dataset
from brake_env.model.atlas import Atlas
from brake_env.prognostics.protocol import predict_log
from twin import DigitalTwin, TwinConfig

# A coarser K grid than the default keeps the tests fast; the filter is the same.
TEST_CONFIG = TwinConfig(n_grid=256)


@pytest.fixture(scope="module")
def dataset(atlas: Atlas) -> Dataset:
    """6 training pads, 3 in-distribution and 1 fast-wearing out-of-distribution pad."""
    spec = DatasetSpec(n_train=6, n_id=3, n_ood_slow=0, n_ood_fast=1)
    return make_dataset(atlas, spec, seed=11)


@pytest.fixture(scope="module")
def fitted(atlas: Atlas, dataset: Dataset) -> DigitalTwin:
    return DigitalTwin(atlas, TEST_CONFIG).fit(dataset.logs["train"])


@pytest.fixture(scope="module")
def id_predictions(fitted: DigitalTwin, dataset: Dataset) -> pd.DataFrame:
    return predict_log(fitted, dataset.logs["id"])
