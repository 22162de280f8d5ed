"""What the fleet study runs (issue 21): :class:`FleetStudyConfig`, the env each policy
acts on (:func:`rul_env`), and episode costs as unit results.

Episode seeds: evaluation 0..E-1, tuning from 10,000, learning curves from 20,000, agent
training from 30,000 + 100 x seed; none overlaps another. The env runs with ``truth=False``
(nothing simulated ahead). The oracle's RUL is the closed-form expected RUL on the hot
route from the pad's true volume and K
(:class:`~agents.policies.fleet_view.ExpectedRULObservation`), which the simulated-ahead
oracle predictor matches up to the noise of the wear to come, at ~20x the cost.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field
from typing import Any, Literal

import numpy as np

from agents.learning.fleet_agent import FleetTraining
from agents.policies.fleet_view import ExpectedRULObservation, FleetLayout
from agents.study.fleet_costs import EpisodeCost
from agents.study.fleet_tuning import SPACES
from brake_env.env.fleet.config import SMALL_FLEET, FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.wrappers import FleetRULObservation
from brake_env.model.atlas import Atlas
from brake_env.prognostics.protocol import Predictor

TUNE_SEED0, CURVE_SEED0, TRAIN_SEED0 = 10_000, 20_000, 30_000
ORACLE = "oracle"
SIZES = ("small", "default")
FLEET_PREDICTORS = ("none", "physics", "data", "twin", "window", ORACLE)
FLEET_HEURISTICS = ("threshold", "(n, N)", "best combination")


@dataclass(frozen=True)
class FleetStudyConfig:
    """What the fleet study runs.

    Attributes:
        size: ``small`` (SMALL_FLEET: 2 vehicles, the reference's size) or ``default``
            (the env's 12 vehicles; no reference).
        shifts: Shifts an episode.
        predictors: Predictors whose RUL the heuristics (and agents) act on.
        heuristics: Heuristics tuned per predictor (keys of ``fleet_tuning.SPACES``).
        trials: Optuna trials per heuristic; ``trials_best`` for the best combination
            (8 parameters, not 1-3).
        tune_episodes: Tuning episodes (seeds from 10,000).
        eval_episodes: Evaluation episodes (seeds 0..), the same for every policy.
        n_train_runs: Run-to-failure pads the predictors are fitted on.
        agent_predictors: Predictors given a MaskablePPO agent.
        agent_seeds: Training seeds per agent predictor.
        shared_seeds: Training seeds of the parameter-shared PPO (one policy per vehicle,
            :mod:`agents.learning.fleet_shared`; spares by the teacher's (s, S)) per agent
            predictor; 0: none.
        training: The agents' settings (its ``seed`` is replaced by each training seed);
            with ``imitation_episodes`` > 0 each agent starts by cloning its predictor's
            best tuned heuristic (behaviour cloning, then PPO).
        curve_episodes, curve_every: The learning curve: cost on that many episodes
            (seeds from 20,000) every ``curve_every`` shifts of training.
        tail: Shifts beyond the episode the reference's program looks ahead.
        seed: Seed of the predictors' fits and of the tuning samplers.
    """

    size: Literal["small", "default"] = "small"
    shifts: int = 365
    predictors: tuple[str, ...] = FLEET_PREDICTORS
    heuristics: tuple[str, ...] = FLEET_HEURISTICS
    trials: int = 15
    trials_best: int = 45
    tune_episodes: int = 3
    eval_episodes: int = 40
    n_train_runs: int = 10
    agent_predictors: tuple[str, ...] = ()
    agent_seeds: int = 10
    shared_seeds: int = 0
    training: FleetTraining = field(default_factory=FleetTraining)
    curve_episodes: int = 2
    curve_every: int = 20_000
    tail: int = 200
    seed: int = 0

    def __post_init__(self) -> None:
        if self.size not in SIZES:
            raise ValueError(f"FleetStudyConfig: size must be one of {SIZES}, got {self.size!r}")
        bad = [h for h in self.heuristics if h not in SPACES]
        if bad or not self.heuristics:
            raise ValueError(f"FleetStudyConfig: unknown heuristic(s) {bad}; known {list(SPACES)}")
        missing = [p for p in self.agent_predictors if p not in self.predictors]
        if missing:
            raise ValueError(
                f"FleetStudyConfig: agent predictor(s) {missing} are not among the predictors"
                f" {self.predictors} (an agent is compared with its predictor's heuristics)"
            )
        for name in ("shifts", "trials", "trials_best", "tune_episodes", "n_train_runs",
                     "curve_episodes", "curve_every"):  # fmt: skip
            if int(getattr(self, name)) < 1:
                raise ValueError(
                    f"FleetStudyConfig: {name} must be >= 1, got {getattr(self, name)}"
                )
        if min(self.agent_seeds, self.shared_seeds) < 0:
            raise ValueError(f"FleetStudyConfig: agent_seeds and shared_seeds must be >= 0, got"
                             f" {self.agent_seeds} and {self.shared_seeds}")  # fmt: skip
        if self.eval_episodes < 2:
            raise ValueError(
                f"FleetStudyConfig: eval_episodes must be >= 2 (paired intervals),"
                f" got {self.eval_episodes}"
            )

    @property
    def fleet(self) -> FleetConfig:
        small: dict[str, Any] = dict(SMALL_FLEET) if self.size == "small" else {}
        return FleetConfig(**small, episode_shifts=self.shifts, truth=False)

    @property
    def has_reference(self) -> bool:
        return self.size == "small"

    def eval_seeds(self) -> list[int]:
        return list(range(self.eval_episodes))

    def tune_seeds(self) -> list[int]:
        return list(range(TUNE_SEED0, TUNE_SEED0 + self.tune_episodes))

    def curve_seeds(self) -> list[int]:
        return list(range(CURVE_SEED0, CURVE_SEED0 + self.curve_episodes))

    def settings(self) -> dict[str, Any]:
        """What every unit's result depends on (the unit store refuses other settings);
        each unit's own parameters are in its key."""
        return {"size": self.size, "shifts": self.shifts, "eval_episodes": self.eval_episodes,
                "tune_episodes": self.tune_episodes, "n_train_runs": self.n_train_runs,
                "seed": self.seed}  # fmt: skip

    def trials_of(self, heuristic: str) -> int:
        return self.trials_best if heuristic == "best combination" else self.trials

    def heuristic_key(self, predictor: str, heuristic: str) -> str:
        return f"heuristic-{predictor}-{heuristic}-t{self.trials_of(heuristic)}"

    def agent_runs(self) -> list[tuple[str, str, int]]:
        """(kind, predictor, seed) of every agent: ``central`` then ``shared``."""
        return [(kind, p, s) for kind, n in (("central", self.agent_seeds),
                                             ("shared", self.shared_seeds))
                for p in self.agent_predictors for s in range(n)]  # fmt: skip

    def reference_key(self) -> str:
        return f"reference-tail{self.tail}"

    def agent_key(self, predictor: str, seed: int, kind: str = "central") -> str:
        spec = {"training": asdict(self.training),
                "curve": [self.curve_episodes, self.curve_every]}  # fmt: skip
        digest = hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()[:10]
        prefix = "agent" if kind == "central" else f"agent-{kind}"
        return f"{prefix}-{predictor}-seed{seed}-{digest}"


def rul_env(
    config: FleetStudyConfig, atlas: Atlas, predictor: str, fitted: Predictor | None
) -> Any:
    """The fleet env with ``predictor``'s RUL appended (``rul_mean`` per vehicle)."""
    env = BrakeWearFleetEnv(config.fleet, atlas=atlas)
    if predictor == ORACLE:
        return ExpectedRULObservation(env)
    assert fitted is not None, f"predictor {predictor!r} needs a fitted predictor"
    return FleetRULObservation(env, fitted, fields=("rul_mean",))


def layout(config: FleetStudyConfig) -> FleetLayout:
    return FleetLayout.of(config.fleet)


def episodes_dict(eps: list[EpisodeCost]) -> dict[str, Any]:
    """Episode costs as a unit result (arrays; :func:`episodes_of` reads them back)."""
    terms, counts = list(eps[0].terms), sorted({k for e in eps for k in e.counts})
    return {
        "seed": np.array([e.seed for e in eps]),
        "vehicles": eps[0].vehicles,
        "shifts": np.array([e.shifts for e in eps]),
        "pad_price": eps[0].pad_price,
        "terms": {t: np.array([e.terms[t] for e in eps]) for t in terms},
        "counts": {c: np.array([e.counts.get(c, 0.0) for e in eps], dtype=float) for c in counts},
    }


def episodes_of(d: dict[str, Any]) -> list[EpisodeCost]:
    """:func:`episodes_dict` read back."""
    n = len(d["seed"])
    return [
        EpisodeCost(int(d["seed"][i]), int(d["vehicles"]), int(d["shifts"][i]),
                    {t: float(v[i]) for t, v in d["terms"].items()},
                    {c: float(v[i]) for c, v in d["counts"].items()}, float(d["pad_price"]))
        for i in range(n)
    ]  # fmt: skip


def rebuild_rule(config: FleetStudyConfig, heuristic: str, params: dict[str, Any]) -> Any:
    """A tuned heuristic from its parameters (as :func:`heuristic_unit` saved them)."""
    import optuna

    w = config.fleet.window_period
    return SPACES[heuristic](optuna.trial.FixedTrial(params), layout(config), w)
