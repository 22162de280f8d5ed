"""Settings of the sim-to-real diagnosis (docs/results/sim2real.md)."""

from __future__ import annotations

from dataclasses import dataclass, field

from brake_env.model.simulator import SensorNoise


@dataclass(frozen=True)
class DiagnosisConfig:
    """Settings of the diagnosis.

    Attributes:
        noise: Sensor noise of the nominal model (residuals are in these units).
        calibration_fraction: Share of runs used to fit candidate parameters [-].
        fit_events_per_run: Events per run used to fit a pad's K [-].
        calibration_events_per_run: Events per calibration run scoring a parameter value [-].
        score_events_per_run: Events per held-out run scoring a model (and the gap) [-].
        max_localise_events: Cap on events replayed for the localisation maps [-].
        grid_points: Parameter values tried per candidate (plus the neutral one) [-].
        refine_evals: At most this many more values of the winner's parameter in its
            refinement (0: the coarse fit only, still with its interval) [-].
        refine_tol: The refinement's tolerance, as a share of the parameter's range [-].
        resamples: Bootstrap resamples (of calibration runs) of the winner's parameter [-].
        slope_nodes: Quadrature nodes over the slope reading's noise [-].
        gap_tolerance: Structured gap [noise units] below which a channel has no gap.
        win_z: Paired z a winner needs against the nominal model and the runner-up [-].
        close_fraction: Share of the structured gap the winner must remove [-].
        level: Interval level [-].
    """

    noise: SensorNoise = field(default_factory=SensorNoise)
    calibration_fraction: float = 0.5
    fit_events_per_run: int = 2000
    calibration_events_per_run: int = 3000
    score_events_per_run: int = 25_000
    max_localise_events: int = 300_000
    grid_points: int = 5
    refine_evals: int = 10
    refine_tol: float = 0.01
    resamples: int = 2000
    slope_nodes: int = 5
    gap_tolerance: float = 0.08
    win_z: float = 3.0
    close_fraction: float = 0.5
    level: float = 0.9

    def __post_init__(self) -> None:
        if not 0.1 <= self.calibration_fraction <= 0.9:
            raise ValueError("DiagnosisConfig.calibration_fraction must be in [0.1, 0.9]")
        for name in (
            "fit_events_per_run",
            "score_events_per_run",
            "grid_points",
            "slope_nodes",
            "resamples",
        ):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"DiagnosisConfig.{name} must be >= 1")
        if self.refine_evals < 0:
            raise ValueError("DiagnosisConfig.refine_evals must be >= 0")
        if not 0 < self.refine_tol < 0.5:
            raise ValueError("DiagnosisConfig.refine_tol must be in (0, 0.5)")
        if self.noise.temp_c <= 0 or self.noise.stop_dist_m <= 0:
            raise ValueError("DiagnosisConfig.noise: temperature and distance noise must be > 0")
