"""Physics-based RUL baseline (paper 2.3): Archard wear without temperature, a straight line.

The model the paper sets against the digital twin, with the assumptions it names:

- Archard wear with the hardness at 20 C and no temperature dependence,
  ``dV = K * F_N * s_slide / H(20 C)`` per event;
- the vehicle response of an unworn brake: the sliding distance per event is its mean over
  the operating envelope on the atlas's fresh layer (uniform operating conditions, exact
  for the trilinear atlas), whatever the wear;
- one wear coefficient ``K_avg``, the mean of the per-run coefficients calibrated on the
  training runs, never updated in service.

Each training run i failed after ``N_i`` events; under this model its coefficient is the
one that wears ``1 - V_fail`` of the pad in ``N_i`` mean events,
``K_i = (1 - V_fail) V_0 / (N_i w20)`` with ``w20 = F_N E[s_slide] / H(20 C)``. The
forward simulation of the paper (sampling operating conditions until the threshold) is
replaced by its expectation, so the predicted life is
``N_fail = (1 - V_fail) V_0 / (K_avg w20)`` (the harmonic mean of the training lives),
and the RUL after event k is ``max(N_fail - 1 - k, 0)``: a straight line, whatever the
sensors say. ``V_fail`` is the atlas's failure volume; it cancels out of ``N_fail``. The
event index counts from installation, so a log that starts mid-life gets the same line.

Pads removed before failure (docs/results/prognostics.md) are used, never by taking their length as
a life: a run removed after ``c + 1`` events had ``K < (1 - V_fail) V_0 / ((c + 1) w20)``,
and a remaining volume ``V`` measured after ``n`` events reads, on this model's straight
line, ``K = (1 - V) V_0 / (n w20)`` with the gauge's noise. ``K_avg`` is then the mean of
a normal population of K fitted to failures, bounds and readings by maximum likelihood
(:mod:`baselines._censoring`); without censored runs it is the paper's plain mean.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from baselines._censoring import Evidence, fit_normal
from baselines._runs import TrainingRuns, training_runs
from brake_env._validate import check_state
from brake_env.model.atlas import Atlas
from brake_env.model.materials import hardness_mpa
from brake_env.model.wear import WearModel
from brake_env.prognostics.fleet import RowFleet
from brake_env.prognostics.protocol import EventBatch, Predictor, RULEstimate

ROOM_TEMP_C = 20.0


class PhysicsPredictor(Predictor):
    """Archard wear at room-temperature hardness with a fixed, calibrated K (paper 2.3).

    Args:
        atlas: Gives the brake (clamp force, pad volume, hardness law), the fresh-pad
            vehicle response and the failure volume.
        volume_noise: Relative standard deviation of a measured pad volume [-].

    Attributes:
        wear_per_k_m3: Wear per event per unit K under this model, ``F_N E[s_slide] / H(20)``
            [m^3].
        wear: This model's wear clock: one layer from a fresh pad to the atlas's failure
            volume, worn at ``wear_per_k_m3`` per event per unit K.
        k_runs: Calibrated coefficient of each training run (set by ``fit``): from its
            life, from its measured volumes if it was removed before failure, else NaN [-].
        k_avg: The mean of the training runs' K, the model's coefficient [-].
        k_std: The standard deviation of the training runs' K [-].
        life_events: Predicted events to failure of every pad, ``N_fail``.
    """

    name = "physics"

    def __init__(self, atlas: Atlas, volume_noise: float = 0.02) -> None:
        super().__init__()
        if not volume_noise > 0:
            raise ValueError(f"physics: volume_noise must be > 0, got {volume_noise}")
        self.volume_noise = float(volume_noise)
        self.failure_volume = float(atlas.failure_volume)
        model = atlas.spec.model
        h20 = float(hardness_mpa(ROOM_TEMP_C, model.hardness))
        slide = float(atlas.expected("sliding_dist_m")[0])  # unworn brake, uniform conditions
        # Same units as the atlas's wear_per_k_m3: force [N] * 1e-6 / hardness [MPa] -> m^3.
        self.wear_per_k_m3 = model.brake.normal_force_n * 1e-6 * slide / h20
        self.wear = WearModel.from_layer_wear(
            np.array([1.0]),
            np.array([atlas.failure_volume]),
            np.array([self.wear_per_k_m3]),
            model.brake.pad_volume_m3,
        )
        self.k_runs: pd.Series | None = None
        self.k_avg: float | None = None
        self.k_std: float | None = None
        self.life_events: float | None = None

    def k_for_life(self, life_events: float | np.ndarray) -> np.ndarray:
        """The coefficient K under which a pad lasts ``life_events`` mean events."""
        life = np.asarray(life_events, dtype=np.float64)
        if np.any(life <= 0):
            raise ValueError("lives must be > 0 events")
        return self.wear.life_work / life

    def set_k(self, k_avg: float) -> None:
        """Fix the model's coefficient (``fit`` does this from training runs)."""
        if not k_avg > 0:
            raise ValueError(f"physics: K must be > 0, got {k_avg}")
        self.k_avg = float(k_avg)
        self.life_events = float(self.wear.life(self.k_avg))

    def _fit(self, train_log: pd.DataFrame) -> None:
        runs = training_runs(train_log)
        k = np.full(len(runs.names), np.nan)
        known = ~runs.censored
        k[known] = self.k_for_life(runs.life[known])
        ev = self._evidence(runs, k)
        try:
            mean, std = fit_normal(ev)
        except ValueError as e:
            raise ValueError(
                f"physics: training run(s) {runs.describe(runs.censored)} were removed before"
                f" failure; {e}"
            ) from None
        self.k_runs = pd.Series(k, index=pd.Index(runs.names, name="run_id"), name="k")
        self.k_std = std
        self.set_k(mean)

    def _evidence(self, runs: TrainingRuns, k: NDArray[np.float64]) -> Evidence:
        """Failures, survival bounds and volume readings of K; fills ``k`` for measured runs."""
        cens = runs.censored
        measured = cens[runs.meas_run]  # a failed run's life says more than its volumes
        run, done, vol = (
            runs.meas_run[measured],
            runs.meas_done[measured],
            runs.meas_volume[measured],
        )
        # This model's straight line: V = 1 - (1 - V_fail) K n / life_work.
        slope = self.wear.life_work / ((1.0 - self.failure_volume) * done)
        read = (1.0 - vol) * slope
        weight = 1.0 / (self.volume_noise * np.maximum(vol, 0.01) * slope) ** 2
        n = len(runs.names)
        w_run = np.bincount(run, weight, n)
        has = w_run > 0
        k[has] = np.bincount(run, weight * read, n)[has] / w_run[has]
        upper = np.asarray(self.wear.life_work / (runs.last_event + 1.0), dtype=np.float64)
        return Evidence(
            exact=k[~cens],
            upper=upper[cens & ~has],
            measured=k[has],
            measured_sd=1.0 / np.sqrt(w_run[has]),
            measured_upper=upper[has],
        )

    def _estimate(self, event: NDArray[np.int64]) -> RULEstimate:
        if self.life_events is None or self.k_avg is None:
            raise RuntimeError("physics: call fit() (or set_k()) before update()")
        done = event.astype(np.float64) + 1.0  # events completed after each event
        return RULEstimate(
            rul_mean=np.maximum(self.life_events - done, 0.0),
            volume_frac=self.wear.volume_at_work(self.k_avg * done),
        )

    def _update(self, events: EventBatch) -> RULEstimate:
        return self._estimate(events.event)

    def fleet(self, n_pads: int) -> RowFleet:
        """All pads in one call: the line depends on the event index only."""
        self._estimate(np.zeros(1, dtype=np.int64))  # fitted?
        return RowFleet(self.name, n_pads, self._at_rows)

    def _at_rows(self, events: EventBatch, want: NDArray[np.bool_]) -> RULEstimate:
        return self._estimate(events.event[want])

    def fitted_wear_coeff(self) -> float | None:
        return self.k_avg

    def get_state(self) -> tuple[dict[str, Any], dict[str, NDArray[Any]]]:
        if self.k_avg is None:
            raise RuntimeError("physics: nothing to save, call fit() or set_k() first")
        meta: dict[str, Any] = {
            "k_avg": self.k_avg,
            "k_std": self.k_std,
            "volume_noise": self.volume_noise,
        }
        arrays: dict[str, NDArray[Any]] = {}
        if self.k_runs is not None:
            arrays["run_ids"] = np.asarray(self.k_runs.index.astype(str), dtype=np.str_)
            arrays["k_runs"] = self.k_runs.to_numpy(dtype=np.float64)
        return meta, arrays

    def set_state(self, meta: Mapping[str, Any], arrays: Mapping[str, NDArray[Any]]) -> None:
        check_state(
            "physics",
            meta,
            arrays,
            meta_keys=("k_avg", "k_std", "volume_noise"),
            optional_arrays=("run_ids", "k_runs"),
            finite=("k_avg", "k_std", "volume_noise"),  # k_runs: NaN for a censored run
        )
        if ("run_ids" in arrays) != ("k_runs" in arrays):
            raise ValueError(
                "physics: the saved arrays need both 'run_ids' and 'k_runs', or neither"
            )
        self.volume_noise = float(meta["volume_noise"])
        self.k_std = None if meta.get("k_std") is None else float(meta["k_std"])
        self.k_runs = None
        if "k_runs" in arrays:
            index = pd.Index([str(r) for r in arrays["run_ids"]], name="run_id")
            self.k_runs = pd.Series(np.asarray(arrays["k_runs"], np.float64), index=index, name="k")
        self.set_k(float(meta["k_avg"]))


def make_physics(atlas: Atlas, seed: int = 0) -> PhysicsPredictor:
    """Registry factory (``brakewear.predictors``); the model draws no random numbers."""
    return PhysicsPredictor(atlas)
