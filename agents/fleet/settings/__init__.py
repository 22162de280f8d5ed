"""The fleet study's settings, at the bottom of ``agents.fleet`` (every other module imports
them, they import nothing of the package), one module per config and all importable from
here: :class:`FleetTraining` (an agent's training) and the episode seeds
(:mod:`~agents.fleet.settings.training`), :class:`FleetStudyConfig` (what ``brakewear
fleet-study`` runs; :mod:`~agents.fleet.settings.study`), :class:`DistilConfig` (what
``brakewear fleet-distil`` runs; :mod:`~agents.fleet.settings.distil`).

Episode seeds: evaluation 0..E-1, tuning from 10,000, learning curves from 20,000, agent
training from 30,000 + 100 x seed, the rollout planner's labels for its distillation from
500,000, the teachers' episodes of behaviour cloning from
``IMITATION_SEED0 * (seed + 1)``; none overlaps another. Predictors come from the registry
(:mod:`brake_env.prognostics.registry`; ``NAME+effect``: NAME made on the physics with the
study's effects), heuristics by the names of
:data:`agents.fleet.evaluation.tuning.SPACES` (``HEURISTICS`` here, tested equal).
"""

from agents.fleet.settings.distil import PPO_ONLY, DistilConfig
from agents.fleet.settings.study import (
    DEFAULT_HEURISTICS,
    FED_BACK,
    FIXED_INTERVAL,
    HEURISTICS,
    OBJECTIVES,
    SIZES,
    UNFITTED,
    FleetStudyConfig,
    Objective,
    check_model,
    study_predictor_names,
)
from agents.fleet.settings.training import (
    CURVE_SEED0,
    IMITATION_SEED0,
    LABEL_SEED0,
    TRAIN_SEED0,
    TUNE_SEED0,
    FleetTraining,
)

__all__ = [
    "CURVE_SEED0", "DEFAULT_HEURISTICS", "FED_BACK", "FIXED_INTERVAL", "HEURISTICS",
    "IMITATION_SEED0", "LABEL_SEED0", "OBJECTIVES", "PPO_ONLY", "SIZES", "TRAIN_SEED0",
    "TUNE_SEED0", "UNFITTED", "DistilConfig", "FleetStudyConfig", "FleetTraining", "Objective",
    "check_model", "study_predictor_names",
]  # fmt: skip
