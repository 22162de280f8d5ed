"""Temperature-dependent friction and hardness of the pad material (paper Tables 1 and 3).

The paper's PDF extraction lost the brackets; the correct reading keeps the coefficient
inside the square (docs/model.md):

    mu(T) = mu0 * (mu1 + mu2 / ((mu3 * (T - mu4))**2 + 1))
    H(T)  = H0 * (H1 + H2 / ((H3 * (T - H4))**2 + 1) + H5 / ((H6 * (T - H7))**2 + 1))

with T in degrees Celsius and H in MPa. H goes negative above ~1030 C, so it is floored,
smoothly (softplus over ``floor_mpa``): a hard max() puts a kink in the wear rate that the
fixed-step integrator crosses in the hottest events, costing it 0.6% of their wear.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from brake_env._validate import check_finite, check_positive, plain_numbers


@dataclass(frozen=True)
class FrictionParams:
    """Yevtushenko friction law, paper Table 1.

    Attributes:
        mu0: Scale of the friction coefficient [-].
        mu1: Offset far from the peak [-].
        mu2: Height of the peak [-].
        mu3: Inverse width of the peak [1/K].
        mu4: Temperature of the peak [deg C].
    """

    mu0: float = 0.45
    mu1: float = 0.01
    mu2: float = 1.07
    mu3: float = 0.0015
    mu4: float = 250.0

    def __post_init__(self) -> None:
        plain_numbers(self)
        check_positive(self, "mu0", "mu2", "mu3")
        check_finite(self, "mu1", "mu4")


@dataclass(frozen=True)
class HardnessParams:
    """Yevtushenko hot-hardness law, paper Table 3.

    Attributes:
        h0: Scale [MPa].
        h1: Offset [-].
        h2, h5: Heights of the two peaks [-].
        h3, h6: Inverse widths of the two peaks [1/K].
        h4, h7: Temperatures of the two peaks [deg C].
        floor_mpa: Smooth lower bound of H, and the width of its transition [MPa]; the fit
            goes negative above ~1030 C. Values more than ~20 floors above it are unchanged.
    """

    h0: float = 137.0
    h1: float = -0.93
    h2: float = 0.83
    h3: float = 0.00234
    h4: float = 546.0
    h5: float = 2.02
    h6: float = 0.002
    h7: float = 233.0
    floor_mpa: float = 1.0

    def __post_init__(self) -> None:
        plain_numbers(self)
        check_positive(self, "h0", "h3", "h6", "floor_mpa")
        check_finite(self, "h1", "h2", "h4", "h5", "h7")


def friction(temp_c: ArrayLike, p: FrictionParams | None = None) -> NDArray[np.float64]:
    """Friction coefficient mu(T) [-] at temperature ``temp_c`` [deg C]."""
    p = p or FrictionParams()
    t = np.asarray(temp_c, dtype=np.float64)
    return p.mu0 * (p.mu1 + p.mu2 / ((p.mu3 * (t - p.mu4)) ** 2 + 1.0))


def hardness_mpa(temp_c: ArrayLike, p: HardnessParams | None = None) -> NDArray[np.float64]:
    """Hot hardness H(T) [MPa] at temperature ``temp_c`` [deg C], smoothly floored."""
    p = p or HardnessParams()
    t = np.asarray(temp_c, dtype=np.float64)
    h = p.h0 * (
        p.h1 + p.h2 / ((p.h3 * (t - p.h4)) ** 2 + 1.0) + p.h5 / ((p.h6 * (t - p.h7)) ** 2 + 1.0)
    )
    # Softplus floor, evaluated only near the floor: 35 widths above it, it equals the fit
    # to within exp(-35) ~ 6e-16 relative, and exp/log on every element would cost 40% of
    # an atlas build.
    s = p.floor_mpa
    h = np.atleast_1d(h)
    x = (h - s) / s
    near = x < 35.0
    if np.any(near):
        h[near] = s + s * np.logaddexp(0.0, x[near])
    return h.reshape(t.shape)
