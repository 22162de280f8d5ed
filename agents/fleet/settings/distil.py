"""What ``brakewear fleet-distil`` runs on a finished study (:class:`DistilConfig`)."""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field
from typing import Any

from agents.fleet.settings.training import LABEL_SEED0, FleetTraining
from brake_env._validate import whole


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
        who = "DistilConfig"
        for name, lo, hi in (("label_episodes", 1, 999), ("label_chunk", 1, None),
                             ("label_rounds", 0, 999), ("seeds", 0, 10_000),
                             ("shared_seeds", 0, 10_000)):  # fmt: skip
            object.__setattr__(self, name, whole(who, name, getattr(self, name), lo, hi))
        if self.seeds + self.shared_seeds < 1:
            raise ValueError(f"DistilConfig: seeds and shared_seeds must be >= 0, one of them"
                             f" >= 1, got {self.seeds} and {self.shared_seeds}")  # fmt: skip
        if not isinstance(self.predictor, str) or not isinstance(self.base_input, bool):
            raise ValueError(f"DistilConfig: predictor must be a name and base_input a bool,"
                             f" got {self.predictor!r} and {self.base_input!r}")  # fmt: skip

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> DistilConfig:
        """The config :func:`dataclasses.asdict` gave (``distil.json``'s ``distil``)."""
        tr = dict(d["training"])
        tr["net_arch"] = tuple(tr["net_arch"])
        if tr.get("reorder") is not None:
            tr["reorder"] = tuple(tr["reorder"])
        return cls(**{**d, "training": FleetTraining(**tr)})

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
