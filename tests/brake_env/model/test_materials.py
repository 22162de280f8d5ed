import numpy as np
import pytest

from brake_env.model.materials import FrictionParams, HardnessParams, friction, hardness_mpa


def mu_by_hand(t: float) -> float:
    return 0.45 * (0.01 + 1.07 / ((0.0015 * (t - 250.0)) ** 2 + 1.0))


def h_by_hand(t: float) -> float:
    return 137.0 * (
        -0.93
        + 0.83 / ((0.00234 * (t - 546.0)) ** 2 + 1.0)
        + 2.02 / ((0.002 * (t - 233.0)) ** 2 + 1.0)
    )


@pytest.mark.parametrize("t", [20.0, 250.0, 400.0, 600.0, 800.0])
def test_friction_matches_hand_computation(t: float) -> None:
    assert friction(t) == pytest.approx(mu_by_hand(t), rel=1e-14)


def test_friction_values_quoted_in_design() -> None:
    # docs/model.md: 0.435 at 20 C, peak 0.486 at 250 C, 0.38 at 600 C, 0.29 at 800 C.
    np.testing.assert_allclose(
        friction([20, 250, 600, 800]), [0.435, 0.486, 0.38, 0.29], atol=0.006
    )
    t = np.linspace(0, 1000, 10001)
    assert t[np.argmax(friction(t))] == pytest.approx(250.0)


@pytest.mark.parametrize("t", [20.0, 315.0, 600.0, 800.0])
def test_hardness_matches_hand_computation(t: float) -> None:
    assert hardness_mpa(t) == pytest.approx(h_by_hand(t), rel=1e-14)


def test_hardness_values_quoted_in_design_and_floor() -> None:
    np.testing.assert_allclose(hardness_mpa([20, 600, 800]), [152, 164, 78], atol=1.5)
    t = np.linspace(0, 1000, 10001)
    assert 300 < t[np.argmax(hardness_mpa(t))] < 330
    assert hardness_mpa(t).max() == pytest.approx(230, abs=2)
    # The fit goes negative above ~1030 C; the floor keeps Archard's law finite, smoothly.
    assert h_by_hand(1100.0) < 0
    assert hardness_mpa(1100.0) == pytest.approx(HardnessParams().floor_mpa, rel=1e-6)
    t = np.linspace(900, 1200, 3001)
    h = hardness_mpa(t)
    assert np.all(h >= 1.0) and np.all(np.diff(h) <= 0)  # falling to the floor, never below
    assert np.all(np.abs(np.diff(h, 2)) < 0.05)  # no kink where the fit crosses the floor


def test_invalid_parameters_are_rejected_by_name() -> None:
    with pytest.raises(ValueError, match="mu3"):
        FrictionParams(mu3=-1.0)
    with pytest.raises(TypeError, match="h0"):
        HardnessParams(h0="137")  # type: ignore[arg-type]
