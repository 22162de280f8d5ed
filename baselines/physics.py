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
sensors say. ``V_fail`` is the atlas's failure volume; it cancels out of ``N_fail``.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from baselines._runs import run_lives
from brake_env.model.atlas import Atlas
from brake_env.model.materials import hardness_mpa
from brake_env.model.wear import WearModel
from brake_env.prognostics.protocol import EventBatch, Predictor, RULEstimate

ROOM_TEMP_C = 20.0


class PhysicsPredictor(Predictor):
    """Archard wear at room-temperature hardness with a fixed, calibrated K (paper 2.3).

    Args:
        atlas: Gives the brake (clamp force, pad volume, hardness law), the fresh-pad
            vehicle response and the failure volume.

    Attributes:
        wear_per_k_m3: Wear per event per unit K under this model, ``F_N E[s_slide] / H(20)``
            [m^3].
        wear: This model's wear clock: one layer from a fresh pad to the atlas's failure
            volume, worn at ``wear_per_k_m3`` per event per unit K.
        k_runs: Calibrated coefficient of each training run (set by ``fit``) [-].
        k_avg: Their mean, the model's coefficient [-].
        life_events: Predicted events to failure of every pad, ``N_fail``.
    """

    name = "physics"

    def __init__(self, atlas: Atlas) -> None:
        super().__init__()
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
        lives = run_lives(train_log)
        self.k_runs = pd.Series(self.k_for_life(lives.to_numpy()), index=lives.index, name="k")
        self.set_k(float(self.k_runs.mean()))

    def _update(self, events: EventBatch) -> RULEstimate:
        if self.life_events is None or self.k_avg is None:
            raise RuntimeError("physics: call fit() (or set_k()) before update()")
        done = events.event.astype(np.float64) + 1.0  # events completed after each event
        return RULEstimate(
            rul_mean=np.maximum(self.life_events - done, 0.0),
            volume_frac=self.wear.volume_at_work(self.k_avg * done),
        )


def make_physics(atlas: Atlas, seed: int = 0) -> PhysicsPredictor:
    """Registry factory (``brakewear.predictors``); the model draws no random numbers."""
    return PhysicsPredictor(atlas)
