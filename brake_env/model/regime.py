"""The wear regime: how the Archard coefficient K of a new pad is distributed (paper 2.1.6).

In-distribution pads have ``K ~ N(k_mean, k_std^2)``; out-of-distribution pads have the
mean shifted by ``-/+ ood_shift_sigma * k_std`` (slow and fast wear). One type for the
datasets, the environment, the cost study and the command line, so that they cannot
disagree on the distribution, its validation or what happens to a non-positive draw.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from brake_env._validate import check_nonnegative, check_positive, plain_numbers

Label = Literal["id", "ood-slow", "ood-fast"]
LABELS: tuple[Label, ...] = ("id", "ood-slow", "ood-fast")
# A slow-OOD mean closer to 0 than this many standard deviations truncates the normal
# visibly (P(K <= 0) > 0.13%): the regime is then refused rather than silently distorted.
MIN_SIGMAS_ABOVE_ZERO = 3.0


@dataclass(frozen=True)
class WearRegime:
    """Distribution of the Archard coefficient K of new pads.

    Attributes:
        k_mean: Mean K of in-distribution pads [-].
        k_std: Standard deviation of K around its mean [-].
        ood_shift_sigma: OOD mean shift in units of ``k_std`` [-].
    """

    k_mean: float = 2e-6
    k_std: float = 2e-7
    ood_shift_sigma: float = 6.0

    def __post_init__(self) -> None:
        plain_numbers(self)
        check_positive(self, "k_mean", "k_std")
        check_nonnegative(self, "ood_shift_sigma")

    def mean(self, label: Label) -> float:
        """Mean K of pads of ``label``."""
        if label not in LABELS:
            raise ValueError(f"wear regime label must be one of {list(LABELS)}, got {label!r}")
        sign = {"id": 0.0, "ood-slow": -1.0, "ood-fast": 1.0}[label]
        return self.k_mean + sign * self.ood_shift_sigma * self.k_std

    def env_kwargs(self) -> dict[str, float]:
        """The regime as BrakeWear-v0's flat keyword arguments (``gym.make``, RL Zoo)."""
        return {"k_mean": self.k_mean, "k_std": self.k_std, "ood_shift_sigma": self.ood_shift_sigma}

    def check_ood(self) -> None:
        """Raise unless slow-OOD pads can be drawn without a visible truncation at K = 0."""
        if self.mean("ood-slow") - MIN_SIGMAS_ABOVE_ZERO * self.k_std <= 0:
            raise ValueError(
                f"wear regime: the slow OOD mean k_mean - {self.ood_shift_sigma:g} k_std ="
                f" {self.mean('ood-slow'):.3g} is within {MIN_SIGMAS_ABOVE_ZERO:g} k_std of"
                " K = 0; lower k_std or ood_shift_sigma"
            )

    def draw(self, rng: np.random.Generator, label: Label, size: int) -> NDArray[np.float64]:
        """``size`` coefficients of pads of ``label``, in draw order.

        A normal draw can in principle be <= 0 (never in practice once :meth:`check_ood`
        passes); it is drawn again, so K is the normal truncated at 0.
        """
        mean = self.mean(label)
        k = rng.normal(mean, self.k_std, size)
        while (bad := k <= 0).any():
            k[bad] = rng.normal(mean, self.k_std, int(bad.sum()))
        return k
