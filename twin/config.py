"""Configuration of the digital twin and the calibration it learns from training runs."""

from __future__ import annotations

import math
from dataclasses import dataclass

from brake_env._validate import check_nonnegative, check_positive, check_range


@dataclass(frozen=True)
class TwinConfig:
    """Settings of :class:`twin.DigitalTwin`.

    Attributes:
        n_grid: Points of the log-spaced grid over the wear coefficient K [-].
        grid_factor: The grid spans ``[K_prior / grid_factor, K_prior * grid_factor]``
            around the prior median [-].
        outlier_weight: Prior weight of a broad log-normal component beside the Student-t
            fitted to the training runs: how much the twin believes a pad can wear unlike
            any training pad (out of distribution) [-].
        outlier_log_std: Standard deviation of log K of that broad component, centred on
            the training median (0.5: a factor 1.65 per standard deviation) [-].
        point_estimate: ``"mean"`` or ``"median"`` of the posterior RUL as ``rul_mean``
            (the median is robust to the long tail of slow-wear hypotheses early on).
        min_prior_log_std: Floor on the fitted spread of log K across training pads [-].
        min_temp_sigma_c: Floor on the fitted temperature noise [K].
        chunk_events: Events of a pad taken in and read out together where estimates are
            wanted at many of them (bounds memory to about ``chunk_events * n_grid * 8``
            bytes per array; rows taken in on the whole grid go in larger blocks,
            ``twin.fleet.TAKE_IN_ROWS``) [-].
        fit_max_events: Training events used to fit the noise model (evenly strided) [-].
    """

    n_grid: int = 768
    grid_factor: float = 8.0
    outlier_weight: float = 0.05
    outlier_log_std: float = 0.5
    point_estimate: str = "mean"
    min_prior_log_std: float = 0.02
    min_temp_sigma_c: float = 0.5
    chunk_events: int = 256
    fit_max_events: int = 400_000

    def __post_init__(self) -> None:
        for name, lo in (("n_grid", 16), ("chunk_events", 1), ("fit_max_events", 100)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < lo:
                raise ValueError(f"TwinConfig.{name} must be an int >= {lo}, got {v!r}")
        if self.point_estimate not in ("mean", "median"):
            raise ValueError(
                f"TwinConfig.point_estimate must be 'mean' or 'median', got {self.point_estimate!r}"
            )
        check_positive(
            self, "grid_factor", "outlier_log_std", "min_prior_log_std", "min_temp_sigma_c"
        )
        if self.grid_factor <= 1.0:
            raise ValueError(f"TwinConfig.grid_factor must be > 1, got {self.grid_factor}")
        check_range(self, "outlier_weight", 0.0, 0.5)


@dataclass(frozen=True)
class TwinCalibration:
    """What the twin learns from training runs (``DigitalTwin.fit``), or sets by hand.

    Attributes:
        k_log_mean: Mean of log K over training pads (K dimensionless) [-].
        k_log_scale: Scale of the Student-t prior on log K [-].
        prior_dof: Degrees of freedom of that Student-t (inf: Gaussian) [-].
        temp_bias_c: Mean of measured minus atlas temperature along the training paths [K].
        temp_sigma_c: Temperature noise not explained by the slope sensor [K].
        slope_sigma_rad: Slope-sensor noise, seen through the atlas's temperature-slope
            derivative [rad].
        n_runs: Training runs it came from (0 when set by hand) [-].
    """

    k_log_mean: float
    k_log_scale: float
    prior_dof: float = math.inf
    temp_bias_c: float = 0.0
    temp_sigma_c: float = 5.0
    slope_sigma_rad: float = 0.0
    n_runs: int = 0

    def __post_init__(self) -> None:
        if not math.isfinite(self.k_log_mean):
            raise ValueError(f"TwinCalibration.k_log_mean must be finite, got {self.k_log_mean}")
        check_positive(self, "k_log_scale", "temp_sigma_c")
        if not self.prior_dof > 0:  # inf allowed: a Gaussian prior
            raise ValueError(f"TwinCalibration.prior_dof must be > 0, got {self.prior_dof}")
        check_nonnegative(self, "slope_sigma_rad")
        if not math.isfinite(self.temp_bias_c):
            raise ValueError(f"TwinCalibration.temp_bias_c must be finite, got {self.temp_bias_c}")

    @property
    def k_median(self) -> float:
        """Prior median of K [-]."""
        return math.exp(self.k_log_mean)
