"""The closed-form twin against the paper's literal iterative procedure."""

from __future__ import annotations

import numpy as np
import pytest

from brake_env.data.datasets import Dataset
from brake_env.model.atlas import Atlas
from brake_env.model.wear import WearModel
from brake_env.prognostics.protocol import iter_runs
from twin import DigitalTwin
from twin.reference import ReferenceTwin, identify_k_iterative, rul_iterative


@pytest.mark.parametrize(
    ("volume", "n_events", "k"), [(0.9, 12_000, 2e-6), (0.5, 60_000, 2.5e-6), (0.3, 30_000, 7e-6)]
)
def test_closed_form_matches_iterative_search(
    atlas: Atlas, volume: float, n_events: int, k: float
) -> None:
    wm = WearModel.from_atlas(atlas)
    k_it = identify_k_iterative(atlas, volume, n_events, 2e-6, seed=0)
    assert k_it == pytest.approx(float(wm.identify_k(volume, n_events)), rel=0.01)
    rul_it = rul_iterative(atlas, volume, k, seed=1)
    assert abs(rul_it - float(wm.rul(volume, k))) < 0.02 * float(wm.life(k))


def test_twin_and_reference_agree_on_rul(
    atlas: Atlas, dataset: Dataset, fitted: DigitalTwin
) -> None:
    k_prior = fitted.calibration.k_median if fitted.calibration else 2e-6
    runs = [next(iter_runs(dataset.logs["id"])), next(iter_runs(dataset.logs["ood"]))]
    for run_id, ev in runs:
        fitted.reset()
        est = fitted.update(ev)
        n = len(ev)
        for frac in (0.5, 0.7, 0.9):
            i = int(frac * n)
            ref = ReferenceTwin(atlas, update_every=i + 1, window=2000)
            ref.k_prior = k_prior
            ref.reset()
            r = ref.update(ev[: i + 1])
            assert abs(r.rul_mean[-1] - est.rul_mean[i]) < 0.02 * n, (run_id, frac)
            assert abs(r.rul_mean[-1] - ev.rul_events[i]) < 0.03 * n, (run_id, frac)


def test_reference_counts_down_between_updates(atlas: Atlas, dataset: Dataset) -> None:
    ref = ReferenceTwin(atlas, update_every=10**9)
    ref.k_prior = 2e-6
    ref.reset()
    _, ev = next(iter_runs(dataset.logs["id"]))
    est = ref.update(ev[:100])
    np.testing.assert_allclose(np.diff(est.rul_mean), -1.0)
    with pytest.raises(RuntimeError, match="fit"):
        ReferenceTwin(atlas).update(ev[:1])
