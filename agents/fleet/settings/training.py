"""An agent's training settings (:class:`FleetTraining`) and the episode seeds of the fleet
study (:mod:`agents.fleet.settings`)."""

from __future__ import annotations

from dataclasses import dataclass

TUNE_SEED0, CURVE_SEED0, TRAIN_SEED0 = 10_000, 20_000, 30_000
IMITATION_SEED0 = 1_000_000
LABEL_SEED0 = 500_000
"""The distilled planner's labelled episodes: ``LABEL_SEED0 + 1000 x round + k``."""
"""The teacher's episode seeds: ``IMITATION_SEED0 * (settings.seed + 1) + k`` for episode k,
apart from the evaluation (0..), tuning (10,000..) and curve (20,000..) seeds."""


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
