"""MaskablePPO (sb3-contrib) on BrakeWearFleet-v0, the centralised env: one policy decides
every vehicle's duty and the reorder each shift, with the env's action mask.

The agent sees the fleet observation with a RUL appended per vehicle (the closed-form
oracle's, :class:`~agents.policies.fleet_view.ExpectedRULObservation`, or any predictor's
through :class:`~brake_env.env.fleet.wrappers.FleetRULObservation`), normalised by running
statistics frozen at the end of training (SB3's ``VecNormalize``). Rewards are scaled by
``reward_scale`` (a shift costs tens to thousands; PPO's value loss wants O(1)). Nothing is
simulated ahead: the env runs with ``truth=False`` unless the RUL wrapper needs it.

:class:`FleetAgent` has SB3's ``predict`` and rebuilds the mask from the observation
(:meth:`~agents.policies.fleet_view.FleetView.mask`), so it runs wherever the fleet rules
run (``agents.study.fleet_costs.run_episodes``) and is compared with them on the same
episodes.

A warm start by behaviour cloning (``teacher`` of :func:`train_fleet_agent`, e.g. a tuned
:class:`~agents.policies.fleet.FleetRule`): a random initial policy sends vehicles to
service far too often and PPO spends its budget unlearning it, so the policy can first be
fitted to a heuristic's actions (:mod:`agents.learning.fleet_imitation`), then
fine-tuned by PPO.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from agents.learning.fleet_imitation import IMITATION_SEED0, Imitation, clone
from agents.policies.fleet import reorder
from agents.policies.fleet_view import ExpectedRULObservation, FleetLayout, FleetView
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.shop import SERVICE
from brake_env.model.atlas import Atlas

F32 = NDArray[np.float32]


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


def oracle_fleet_env(config: FleetConfig, atlas: Atlas | None = None) -> gym.Env[Any, Any]:
    """The fleet env with the closed-form oracle RUL appended (a reference's information
    on the pads in service; for the twin's RUL wrap with ``FleetRULObservation``)."""
    return ExpectedRULObservation(BrakeWearFleetEnv(config, atlas=atlas))


class ReorderBy(gym.ActionWrapper[Any, NDArray[np.int64], NDArray[np.int64]]):
    """The agent decides duties only; spares are reordered by (s, S) on the inventory
    position after this shift's service requests (:func:`agents.policies.fleet.reorder`).

    Args:
        env: BrakeWearFleet-v0 (possibly wrapped).
        s, S: Reorder point and order-up-to level.
    """

    def __init__(self, env: gym.Env[Any, NDArray[np.int64]], s: int, S: int) -> None:
        super().__init__(env)
        self.s, self.S = s, S
        nvec = env.action_space.nvec  # type: ignore[attr-defined]
        self.n = len(nvec) - 1
        self.action_space = gym.spaces.MultiDiscrete(nvec[:-1])

    def action(self, action: NDArray[np.int64]) -> NDArray[np.int64]:
        base: Any = self.env.unwrapped
        fits = int((np.asarray(action) == SERVICE).sum())
        q = reorder(base.shop.stock, base.shop.in_transit, fits, self.s, self.S,
                    base.config.max_order)  # fmt: skip
        return np.append(np.asarray(action, dtype=np.int64), q)

    def action_masks(self) -> NDArray[np.bool_]:
        return self.env.unwrapped.action_masks()[: 4 * self.n]  # type: ignore[attr-defined]


class FrozenAgent:
    """A trained MaskablePPO and its observation statistics, frozen at the end of training
    (SB3's ``VecNormalize``: ``(obs - mean) / sqrt(var + 1e-8)``, clipped).

    Args:
        model: The MaskablePPO.
        layout: Where the mask's inputs are in the (unnormalised) fleet observation.
        obs_mean, obs_var: Frozen running statistics of the policy's observation.
        clip: VecNormalize's clip of normalised observations.
    """

    def __init__(
        self, model: Any, layout: FleetLayout, obs_mean: F32, obs_var: F32, clip: float = 10.0
    ) -> None:
        self.model, self.layout, self.clip = model, layout, clip
        self.mean, self.std = obs_mean, np.sqrt(obs_var + 1e-8)
        self.imitation: Imitation | None = None  # set by the trainer with a teacher

    def normalize(self, obs: NDArray[Any]) -> F32:
        return np.clip((obs - self.mean) / self.std, -self.clip, self.clip).astype(np.float32)


class FleetAgent(FrozenAgent):
    """A trained MaskablePPO with frozen observation statistics; SB3's ``predict``.

    Args:
        model, layout, obs_mean, obs_var, clip: As :class:`FrozenAgent`'s.
        reorder: The (s, S) it was trained with (:class:`ReorderBy`), if any.
    """

    def __init__(
        self, model: Any, layout: FleetLayout, obs_mean: F32, obs_var: F32, clip: float = 10.0,
        reorder: tuple[int, int] | None = None,
    ) -> None:  # fmt: skip
        super().__init__(model, layout, obs_mean, obs_var, clip)
        self.reorder = reorder
        self.name = "MaskablePPO"

    def predict(
        self,
        observation: NDArray[Any],
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[NDArray[np.int64], Any]:
        obs = np.asarray(observation, dtype=np.float64)
        view = FleetView.read(obs, self.layout)
        mask = view.mask(self.layout.max_order)
        if self.reorder is not None:
            mask = mask[: 4 * self.layout.n_vehicles]
        action, _ = self.model.predict(
            self.normalize(obs), action_masks=mask, deterministic=deterministic
        )
        action = np.asarray(action, dtype=np.int64)
        if self.reorder is not None:
            fits = int((action == SERVICE).sum())
            s, S = self.reorder
            q = reorder(view.stock, view.transit, fits, s, S, self.layout.max_order)
            action = np.append(action, q)
        return action, state

    def __repr__(self) -> str:
        return f"FleetAgent({self.name})"


def train_fleet_agent(
    make_env: Callable[[], gym.Env[Any, Any]],
    layout: FleetLayout,
    settings: FleetTraining,
    callback: Any = None,
    teacher: Any = None,
) -> FleetAgent:
    """Train MaskablePPO on ``settings.n_envs`` copies of ``make_env()``.

    Each copy is masked by its base env's :meth:`action_masks`, its rewards are scaled and
    its observations normalised (running statistics, frozen into the returned agent).
    Episode seeds come from ``settings.seed`` (SB3 seeds env i with seed + i).

    With ``settings.imitation_episodes`` > 0 the policy is first cloned from ``teacher``
    (SB3's ``predict`` on the unnormalised observation, e.g. a tuned
    :class:`~agents.policies.fleet.FleetRule`): its episodes are recorded on the training
    copies (seeds :data:`IMITATION_SEED0` * (seed + 1) + k, round robin over the copies),
    the observation statistics are updated with them, and the policy is fitted to them
    (:mod:`~agents.learning.fleet_imitation`); each of ``imitation_rounds`` DAgger rounds
    then records as many episodes driven by the clone, labelled by the teacher, and refits
    on all the data; then PPO fine-tunes for ``settings.timesteps`` (none if 0). The
    agent's ``imitation`` says how the cloning went.
    """
    from sb3_contrib import MaskablePPO  # heavy optional dependencies (the fleet extra)
    from sb3_contrib.common.wrappers import ActionMasker
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    s = settings
    if (teacher is None) != (s.imitation_episodes == 0):
        raise ValueError(
            "train_fleet_agent: a teacher needs settings.imitation_episodes > 0 and"
            f" imitation_episodes > 0 needs a teacher (got {s.imitation_episodes}"
            f" episodes, teacher {teacher!r})"
        )
    t0 = time.perf_counter()

    def one() -> gym.Env[Any, Any]:
        env = make_env()
        if s.reorder is not None:
            env = ReorderBy(env, *s.reorder)
        env = gym.wrappers.TransformReward(env, lambda r: float(r) * s.reward_scale)
        return ActionMasker(env, lambda e: e.get_wrapper_attr("action_masks")())

    envs = DummyVecEnv([one] * s.n_envs)
    venv = VecNormalize(envs, norm_obs=True, norm_reward=s.normalize_reward, gamma=s.gamma)
    model = MaskablePPO(
        "MlpPolicy", venv, learning_rate=s.learning_rate, n_steps=s.n_steps,
        batch_size=s.batch_size, n_epochs=s.n_epochs, ent_coef=s.ent_coef, gamma=s.gamma,
        clip_range=s.clip_range, policy_kwargs={"net_arch": list(s.net_arch)}, seed=s.seed,
        verbose=0, device="cpu",
    )  # fmt: skip
    imitation = None if teacher is None else clone(model, venv, teacher, s, t0)
    if s.timesteps > 0:
        model.learn(total_timesteps=s.timesteps, callback=callback)
    rms: Any = venv.obs_rms  # one RunningMeanStd: the observation is a Box
    mean, var = rms.mean.astype(np.float32), rms.var.astype(np.float32)
    agent = FleetAgent(model, layout, mean, var, reorder=s.reorder)
    agent.imitation = imitation
    return agent
