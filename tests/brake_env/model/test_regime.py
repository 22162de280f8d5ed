"""The wear regime: means of each label, truncation at K = 0, validation."""

from __future__ import annotations

import numpy as np
import pytest

from brake_env.model.regime import WearRegime


def test_means_shift_by_sigmas() -> None:
    w = WearRegime(2e-6, 2e-7, 6.0)
    assert w.mean("id") == 2e-6
    assert w.mean("ood-slow") == pytest.approx(2e-6 - 1.2e-6, rel=1e-12)
    assert w.mean("ood-fast") == pytest.approx(2e-6 + 1.2e-6, rel=1e-12)
    with pytest.raises(ValueError, match="label"):
        w.mean("slow")  # type: ignore[arg-type]


def test_draw_is_the_seeded_normal_and_never_non_positive() -> None:
    w = WearRegime(2e-6, 2e-7)
    k = w.draw(np.random.default_rng(3), "ood-fast", 1000)
    ref = np.random.default_rng(3).normal(w.mean("ood-fast"), 2e-7, 1000)
    np.testing.assert_array_equal(k, ref)  # no draw was <= 0: the plain normal stream
    wide = WearRegime(1e-6, 1e-6, 0.0)  # half its mass below 0 without the redraw
    assert (wide.draw(np.random.default_rng(0), "id", 5000) > 0).all()


def test_validation() -> None:
    with pytest.raises(ValueError, match="k_mean"):
        WearRegime(k_mean=-1.0)
    with pytest.raises(ValueError, match="ood_shift_sigma"):
        WearRegime(ood_shift_sigma=-1.0)
    with pytest.raises(ValueError, match="slow OOD mean"):
        WearRegime(2e-6, 2e-7, 8.0).check_ood()  # slow mean 4e-7 = 2 sigma above 0
    WearRegime(2e-6, 2e-7, 6.0).check_ood()  # 4 sigma above 0: fine
