"""The fleet study's settings, at the bottom of ``agents.fleet`` (every other module imports
them, they import nothing of the package): :class:`FleetTraining` (an agent's training),
:class:`FleetStudyConfig` (what ``brakewear fleet-study`` runs) and the episode seeds.

Episode seeds: evaluation 0..E-1, tuning from 10,000, learning curves from 20,000, agent
training from 30,000 + 100 x seed, the rollout planner's labels for its distillation from
500,000, the teachers' episodes of behaviour cloning from
``IMITATION_SEED0 * (seed + 1)``; none overlaps another. Predictors come from the registry
(:mod:`brake_env.prognostics.registry`), heuristics by the names of
:data:`agents.fleet.evaluation.tuning.SPACES` (``HEURISTICS`` here, tested equal).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field
from typing import Any, Literal

from brake_env.env.fleet.config import SMALL_FLEET, FleetConfig
from brake_env.prognostics.registry import predictor_names

TUNE_SEED0, CURVE_SEED0, TRAIN_SEED0 = 10_000, 20_000, 30_000
IMITATION_SEED0 = 1_000_000
LABEL_SEED0 = 500_000
"""The distilled planner's labelled episodes: ``LABEL_SEED0 + 1000 x round + k``."""
"""The teacher's episode seeds: ``IMITATION_SEED0 * (settings.seed + 1) + k`` for episode k,
apart from the evaluation (0..), tuning (10,000..) and curve (20,000..) seeds."""
SIZES = ("small", "default")
# The heuristics of agents.fleet.evaluation.tuning.SPACES, in its order (tested equal), so
# that the settings and the parser need not import the tuning (Optuna, scipy).
# What the heuristics are tuned on, their best chosen on and the predictors ranked by:
# the headline cost per vehicle-shift, or the net cost (less the pad life left at the end;
# agents.fleet.evaluation.costs.figures).
Objective = Literal["cost", "net"]
OBJECTIVES: tuple[Objective, ...] = ("cost", "net")
HEURISTICS = ("threshold", "time-to-window", "(n, N)", "capacity greedy", "duty rule",
              "(s, S)", "standby", "best combination")  # fmt: skip
DEFAULT_HEURISTICS = ("threshold", "(n, N)", "best combination")


@dataclass(frozen=True)
class FleetTraining:
    """MaskablePPO settings (SB3's defaults unless said; not tuned on evaluation episodes).

    Attributes:
        timesteps: Shifts of experience in total (all envs).
        n_envs: Parallel envs (DummyVecEnv).
        seed: Seed of the model, the envs' episode seeds and the normalisation.
        learning_rate, n_steps, batch_size, n_epochs, ent_coef, clip_range: PPO's.
        gamma: Discount per shift: 0.995 looks ~200 shifts ahead, a pad's life on the ramp
            (a replacement's consequences reach that far).
        reward_scale: Rewards times this during training.
        net_arch: Hidden layers of the policy and value networks.
        normalize_reward: Scale rewards by a running estimate of the return's spread
            (SB3's ``VecNormalize(norm_reward=True)``), on top of ``reward_scale``.
        reorder: (s, S) to reorder spares by rule (the agent then decides duties only;
            :class:`ReorderBy`), or None for the agent to choose the order quantity too.
        imitation_episodes: Episodes of the teacher recorded for the warm start (needs a
            ``teacher``; 0: none). ``timesteps`` may then be 0 (the cloned policy alone).
        imitation_epochs: Passes of behaviour cloning over the teacher's data.
        imitation_lr: Adam's learning rate for the cloning (minibatches of ``batch_size``).
        imitation_value: Also fit the value head to the discounted returns of the recorded
            episodes (so that PPO's first advantages are not those of a random critic).
        imitation_rounds: DAgger rounds after the teacher's episodes: the clone drives
            ``imitation_episodes`` more episodes, the teacher labels its states, and the
            policy is refitted on all the data (the clone's own mistakes lead to states
            the teacher never visits, e.g. a pad near failure).
        cover_needs: Cover each shift's needs from idle vehicles after the agent's duties
            (:func:`~agents.fleet.learning.dispatch.cover_needs`), in training and when it acts.
        vehicle_net: One network shared by the vehicles, each reading its own values, the
            fleet's and its rank (:mod:`~agents.fleet.learning.vehicle_net`; ``net_arch[-1]``
            units a layer); needs ``reorder``.
    """

    timesteps: int = 200_000
    n_envs: int = 4
    seed: int = 0
    learning_rate: float = 3e-4
    n_steps: int = 512
    batch_size: int = 256
    n_epochs: int = 10
    ent_coef: float = 0.01
    gamma: float = 0.995
    reward_scale: float = 1e-3
    net_arch: tuple[int, ...] = (128, 128)
    normalize_reward: bool = False
    reorder: tuple[int, int] | None = None
    clip_range: float = 0.2
    imitation_episodes: int = 0
    imitation_epochs: int = 20
    imitation_lr: float = 1e-3
    imitation_value: bool = True
    imitation_rounds: int = 0
    cover_needs: bool = False
    vehicle_net: bool = False

    def __post_init__(self) -> None:
        for name in ("n_envs", "n_steps", "batch_size", "n_epochs", "imitation_epochs"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"FleetTraining: {name} must be >= 1, got {getattr(self, name)}")
        if self.imitation_rounds < 0 or self.imitation_episodes < 0:
            raise ValueError(f"FleetTraining: imitation_episodes and imitation_rounds must be"
                             f" >= 0, got {self.imitation_episodes}"
                             f" and {self.imitation_rounds}")  # fmt: skip
        if self.imitation_episodes * (self.imitation_rounds + 1) >= IMITATION_SEED0:
            raise ValueError(f"FleetTraining: imitation_episodes x (imitation_rounds + 1) must"
                             f" be < {IMITATION_SEED0}")  # fmt: skip
        if self.timesteps < (0 if self.imitation_episodes else 1):
            raise ValueError(f"FleetTraining: timesteps must be >= 1 (>= 0 with"
                             f" imitation_episodes), got {self.timesteps}")  # fmt: skip
        if self.seed < 0:
            raise ValueError(f"FleetTraining: seed must be >= 0, got {self.seed}")
        for name in ("clip_range", "imitation_lr", "learning_rate"):
            if not float(getattr(self, name)) > 0:
                raise ValueError(f"FleetTraining: {name} must be > 0, got {getattr(self, name)}")
        if not 0.0 < self.gamma <= 1.0:
            raise ValueError(f"FleetTraining: gamma must be in (0, 1], got {self.gamma}")
        if self.reorder is not None and not 0 <= self.reorder[0] <= self.reorder[1]:
            raise ValueError(
                f"FleetTraining: reorder must be (s, S), 0 <= s <= S, got {self.reorder}"
            )
        if not self.reward_scale > 0:
            raise ValueError(f"FleetTraining: reward_scale must be > 0, got {self.reward_scale}")


@dataclass(frozen=True)
class FleetStudyConfig:
    """What the fleet study runs.

    Attributes:
        size: ``small`` (SMALL_FLEET: 2 vehicles, the reference's size) or ``default``
            (the env's 12 vehicles; no reference).
        shifts: Shifts an episode.
        predictors: Predictors whose RUL the heuristics (and agents) act on (names of the
            registry, :func:`~brake_env.prognostics.registry.predictor_names`; all by default).
        heuristics: Heuristics tuned per predictor (:data:`HEURISTICS`).
        trials: Optuna trials per heuristic; ``trials_best`` for the best combination
            (8 parameters, not 1-3).
        tune_episodes: Tuning episodes (seeds from 10,000).
        eval_episodes: Evaluation episodes (seeds 0..), the same for every policy.
        n_train_runs: Run-to-failure pads the predictors are fitted on.
        agent_predictors: Predictors given a MaskablePPO agent.
        agent_seeds: Training seeds per agent predictor.
        shared_seeds: Training seeds of the parameter-shared PPO (one policy per vehicle,
            :mod:`agents.fleet.learning.shared`; spares by the teacher's (s, S)) per agent
            predictor; 0: none.
        training: The agents' settings (its ``seed`` is replaced by each training seed);
            with ``imitation_episodes`` > 0 each agent starts by cloning its predictor's
            best tuned heuristic (behaviour cloning, then PPO).
        curve_episodes, curve_every: The learning curve: cost on that many episodes
            (seeds from 20,000) every ``curve_every`` shifts of training.
        tail: Shifts beyond the episode the reference's program looks ahead.
        seed: Seed of the predictors' fits and of the tuning samplers.
        rollout_predictors: Predictors given the rollout planner on their best tuned
            heuristic (:mod:`agents.fleet.policies.rollout`); its evaluation episodes run
            as units of ``rollout_chunk`` episodes.
        rollout_horizon, rollout_samples: The planner's shifts simulated per candidate and
            sampled futures.
        rollout_chunk: Evaluation episodes per rollout unit.
        bound_iterations: Price vectors the Lagrangian bound's search tries (0: no bound);
            with the bound, the price-directed policy runs on the evaluation episodes too.
        objective: What the heuristics are tuned on, the best heuristic is chosen on, the
            predictors are ranked by and the rollout is compared with its base on:
            ``cost`` (the headline) or ``net`` (:data:`OBJECTIVES`). Every row reports both.
    """

    size: Literal["small", "default"] = "small"
    shifts: int = 365
    predictors: tuple[str, ...] = field(default_factory=predictor_names)
    heuristics: tuple[str, ...] = DEFAULT_HEURISTICS
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
    rollout_predictors: tuple[str, ...] = ()
    rollout_horizon: int = 28
    rollout_samples: int = 16
    rollout_chunk: int = 5
    bound_iterations: int = 0
    objective: Objective = "cost"

    def __post_init__(self) -> None:
        if self.size not in SIZES:
            raise ValueError(f"FleetStudyConfig: size must be one of {SIZES}, got {self.size!r}")
        bad = [h for h in self.heuristics if h not in HEURISTICS]
        if bad or not self.heuristics:
            raise ValueError(
                f"FleetStudyConfig: unknown heuristic(s) {bad}; known {list(HEURISTICS)}"
            )
        known = predictor_names()
        bad = [p for p in self.predictors if p not in known]
        if bad or not self.predictors:
            raise ValueError(
                f"FleetStudyConfig: predictors must be among {list(known)},"
                f" got {list(self.predictors)}"
            )
        missing = [p for p in self.agent_predictors + self.rollout_predictors
                   if p not in self.predictors]  # fmt: skip
        if missing:
            raise ValueError(
                f"FleetStudyConfig: agent or rollout predictor(s) {missing} are not among the"
                f" predictors {self.predictors} (each is compared with its predictor's"
                " heuristics)"
            )
        for name in ("shifts", "trials", "trials_best", "tune_episodes", "n_train_runs",
                     "curve_episodes", "curve_every", "rollout_horizon", "rollout_samples",
                     "rollout_chunk"):  # fmt: skip
            if int(getattr(self, name)) < 1:
                raise ValueError(
                    f"FleetStudyConfig: {name} must be >= 1, got {getattr(self, name)}"
                )
        if min(self.agent_seeds, self.shared_seeds, self.bound_iterations) < 0:
            raise ValueError(f"FleetStudyConfig: agent_seeds, shared_seeds and bound_iterations"
                             f" must be >= 0, got {self.agent_seeds}, {self.shared_seeds} and"
                             f" {self.bound_iterations}")  # fmt: skip
        if self.objective not in OBJECTIVES:
            raise ValueError(
                f"FleetStudyConfig: objective must be one of {OBJECTIVES}, got {self.objective!r}"
            )
        if self.eval_episodes < 2:
            raise ValueError(
                f"FleetStudyConfig: eval_episodes must be >= 2 (paired intervals),"
                f" got {self.eval_episodes}"
            )

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> FleetStudyConfig:
        """The config a study wrote (``costs.json``'s ``config``: :func:`dataclasses.asdict`
        with the derived ``fleet``)."""
        d = {k: v for k, v in d.items() if k != "fleet"}
        tr = dict(d.get("training", {}))
        if "net_arch" in tr:
            tr["net_arch"] = tuple(tr["net_arch"])
        if tr.get("reorder") is not None:
            tr["reorder"] = tuple(tr["reorder"])
        tuples = ("predictors", "heuristics", "agent_predictors", "rollout_predictors")
        return cls(**{**d, **{k: tuple(d[k]) for k in tuples if k in d},
                      "training": FleetTraining(**tr)})  # fmt: skip

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
                "seed": self.seed, "objective": self.objective}  # fmt: skip

    def trials_of(self, heuristic: str) -> int:
        return self.trials_best if heuristic == "best combination" else self.trials

    def heuristic_key(self, predictor: str, heuristic: str) -> str:
        return f"heuristic-{predictor}-{heuristic}-t{self.trials_of(heuristic)}"

    def agent_runs(self) -> list[tuple[str, str, int]]:
        """(kind, predictor, seed) of every agent: ``central`` then ``shared``."""
        return [(kind, p, s) for kind, n in (("central", self.agent_seeds),
                                             ("shared", self.shared_seeds))
                for p in self.agent_predictors for s in range(n)]  # fmt: skip

    def rollout_chunks(self) -> list[list[int]]:
        """The evaluation seeds, ``rollout_chunk`` to a rollout unit."""
        seeds, k = self.eval_seeds(), self.rollout_chunk
        return [seeds[i : i + k] for i in range(0, len(seeds), k)]

    def rollout_key(self, predictor: str, chunk: int) -> str:
        """A rollout unit's key; its base (the best heuristic) depends on which were tuned."""
        base = json.dumps([sorted(self.heuristics), self.trials, self.trials_best])
        digest = hashlib.sha256(base.encode()).hexdigest()[:8]
        return (f"rollout-{predictor}-h{self.rollout_horizon}-s{self.rollout_samples}"
                f"-c{self.rollout_chunk}-{chunk}-{digest}")  # fmt: skip

    def bound_key(self) -> str:
        return f"bound-i{self.bound_iterations}"

    def reference_key(self) -> str:
        return f"reference-tail{self.tail}"

    def agent_key(self, predictor: str, seed: int, kind: str = "central") -> str:
        spec = {"training": asdict(self.training),
                "curve": [self.curve_episodes, self.curve_every]}  # fmt: skip
        digest = hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()[:10]
        prefix = "agent" if kind == "central" else f"agent-{kind}"
        return f"{prefix}-{predictor}-seed{seed}-{digest}"


@dataclass(frozen=True)
class DistilConfig:
    """What ``brakewear fleet-distil`` runs on a finished study: the rollout planner on the
    predictor's best tuned heuristic labels shifts once (DAgger, shared by every seed), then
    each training seed clones the labels and optionally fine-tunes by PPO.

    Attributes:
        predictor: Whose RUL the planner and the policy read (one of the study's).
        seeds: Training seeds of the central policy.
        shared_seeds: Training seeds of the policy shared by the vehicles, cloned from the
            same labels through TorchRL (:mod:`agents.fleet.study.distil_shared`).
        label_episodes: Episodes labelled per round.
        label_rounds: DAgger rounds after the planner's own episodes: a clone of every
            label so far (fitted from ``LABEL_SEED0``) drives, the planner labels.
        label_chunk: Episodes per labelling unit.
        base_input: The base rule's duties are part of the policy's input (residual
            learning: it learns where the planner departs from the rule, which it does on
            about one shift in thirteen; :class:`~agents.fleet.learning.dispatch.BaseDuties`);
            for the shared policy, each vehicle's view ends with the rule's duty for it
            (:func:`~agents.fleet.learning.marl.shared_views`).
        training: Each seed's cloning (``imitation_*``, ``net_arch``, ``batch_size``) and
            PPO after it (``timesteps``, 0: the clone alone); its ``reorder`` is set from the
            base rule's (s, S), the planner's own order rule.
    """

    predictor: str = "twin"
    seeds: int = 10
    shared_seeds: int = 0
    label_episodes: int = 16
    label_rounds: int = 2
    label_chunk: int = 8
    base_input: bool = True
    training: FleetTraining = field(
        default_factory=lambda: FleetTraining(
            timesteps=0, imitation_episodes=1, imitation_epochs=120, imitation_lr=3e-3,
            batch_size=128, normalize_reward=True, cover_needs=True, vehicle_net=True,
            net_arch=(128, 128),
        )
    )  # fmt: skip

    def __post_init__(self) -> None:
        for name in ("label_episodes", "label_chunk"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"DistilConfig: {name} must be >= 1, got {getattr(self, name)}")
        if min(self.seeds, self.shared_seeds) < 0 or self.seeds + self.shared_seeds < 1:
            raise ValueError(f"DistilConfig: seeds and shared_seeds must be >= 0, one of them"
                             f" >= 1, got {self.seeds} and {self.shared_seeds}")  # fmt: skip
        if not 0 <= self.label_rounds < 1000 or self.label_episodes >= 1000:
            raise ValueError(f"DistilConfig: label_rounds must be in [0, 1000) and"
                             f" label_episodes < 1000, got {self.label_rounds} and"
                             f" {self.label_episodes}")  # fmt: skip

    def label_seeds(self, round_: int) -> list[int]:
        return [LABEL_SEED0 + 1000 * round_ + k for k in range(self.label_episodes)]

    def label_chunks(self, round_: int) -> list[list[int]]:
        seeds, k = self.label_seeds(round_), self.label_chunk
        return [seeds[i : i + k] for i in range(0, len(seeds), k)]

    def digest(self, ppo: bool = True) -> str:
        """What a unit depends on besides the study: the labels, the rounds and the cloning
        (the labelling clone's); a seed, PPO's settings too (``ppo``), so that a rerun with
        another PPO budget reuses the labels."""
        training = asdict(self.training)
        if not ppo:
            for name in PPO_ONLY:
                training.pop(name)
        spec = {"rounds": self.label_rounds, "episodes": self.label_episodes,
                "training": training, "base_input": self.base_input}  # fmt: skip
        return hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()[:10]


# FleetTraining's fields that only PPO reads (the labelling clone runs none)
PPO_ONLY = ("timesteps", "n_envs", "learning_rate", "n_steps", "n_epochs", "ent_coef",
            "clip_range")  # fmt: skip
