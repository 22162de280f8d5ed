"""Small truth datasets shared by the sim2real tests."""

from __future__ import annotations

import pytest

from brake_env.data.datasets import DatasetSpec
from brake_env.model.atlas import Atlas, AtlasSpec, cached_atlas
from brake_env.model.regime import WearRegime

SMALL = AtlasSpec(n_speed=6, n_mass=3, n_slope=5)


def short_runs(n: int = 4, k: float = 4e-5) -> DatasetSpec:
    """``n`` short runs to failure (K 20x the paper's: ~6000 events each)."""
    return DatasetSpec(n_train=n, n_id=0, n_ood_slow=0, n_ood_fast=0, wear=WearRegime(k, 0.1 * k))


@pytest.fixture(scope="session")
def s2r_atlas() -> Atlas:
    """The small atlas, through the (test-isolated) cache the truth simulator uses."""
    return cached_atlas(SMALL)
