"""MaskablePPO (sb3-contrib) on BrakeWearFleet-v0, the centralised env: one policy decides
every vehicle's duty and the reorder each shift, with the env's action mask.

The agent sees the fleet observation with a RUL appended per vehicle (the closed-form
oracle's, :class:`~brake_env.env.fleet.wrappers.ExpectedRULObservation`, or any predictor's
through :class:`~brake_env.env.fleet.wrappers.FleetRULObservation`), normalised by running
statistics frozen at the end of training (SB3's ``VecNormalize``). Rewards are scaled by
``reward_scale`` (a shift costs tens to thousands; PPO's value loss wants O(1)). Nothing is
simulated ahead: the env runs with ``truth=False`` unless the RUL wrapper needs it.

:class:`FleetAgent` has SB3's ``predict`` and rebuilds the mask from the observation
(:meth:`~agents.fleet.policies.view.FleetView.mask`), so it runs wherever the fleet rules
run (``agents.fleet.evaluation.costs.run_episodes``) and is compared with them on the same
episodes.

A warm start by behaviour cloning (``teacher`` of :func:`train_fleet_agent`, e.g. a tuned
:class:`~agents.fleet.policies.rules.FleetRule`): a random initial policy sends vehicles to
service far too often and PPO spends its budget unlearning it, so the policy can first be
fitted to a heuristic's actions (:mod:`agents.fleet.learning.imitation`), then
fine-tuned by PPO.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from agents.fleet.learning.dispatch import (
    DUTIES,
    BaseDuties,
    CoverNeeds,
    cover_needs,
    with_base_duties,
)
from agents.fleet.learning.imitation import (
    Demonstrations,
    Imitation,
    clone,
    discounted_returns,
    imitate,
)
from agents.fleet.policies.rules import reorder
from agents.fleet.policies.view import FleetLayout, FleetView
from agents.fleet.settings import FleetTraining
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.family import make_env
from brake_env.env.fleet.shop import SERVICE
from brake_env.env.fleet.wrappers import ExpectedRULObservation
from brake_env.model.atlas import Atlas

F32 = NDArray[np.float32]
I64 = NDArray[np.int64]


def oracle_fleet_env(config: FleetConfig, atlas: Atlas | None = None) -> gym.Env[Any, Any]:
    """The fleet env with the closed-form oracle RUL appended (a reference's information
    on the pads in service; for the twin's RUL wrap with ``FleetRULObservation``)."""
    return ExpectedRULObservation(make_env(config, atlas))


class ReorderBy(gym.ActionWrapper[Any, NDArray[np.int64], NDArray[np.int64]]):
    """The agent decides duties only; spares are reordered by (s, S) on the inventory
    position after this shift's service requests (:func:`agents.fleet.policies.rules.reorder`).

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
        self.mean, self.var, self.std = obs_mean, obs_var, np.sqrt(obs_var + 1e-8)
        self.imitation: Imitation | None = None  # set by the trainer with a teacher

    def normalize(self, obs: NDArray[Any]) -> F32:
        return np.clip((obs - self.mean) / self.std, -self.clip, self.clip).astype(np.float32)


class FleetAgent(FrozenAgent):
    """A trained MaskablePPO with frozen observation statistics; SB3's ``predict``.

    Args:
        model, layout, obs_mean, obs_var, clip: As :class:`FrozenAgent`'s.
        reorder: The (s, S) it was trained with (:class:`ReorderBy`), if any.
        cover: Whether its duties go through :func:`cover_needs` (as in training).
        base: The rule whose duties its input carries (:class:`BaseDuties`), if any.
    """

    def __init__(
        self, model: Any, layout: FleetLayout, obs_mean: F32, obs_var: F32, clip: float = 10.0,
        *, reorder: tuple[int, int] | None = None, cover: bool = False, base: Any = None,
    ) -> None:  # fmt: skip
        super().__init__(model, layout, obs_mean, obs_var, clip)
        self.reorder, self.cover, self.base = reorder, cover, base
        self.name = "MaskablePPO"

    def predict(
        self,
        observation: NDArray[Any],
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[NDArray[np.int64], Any]:
        obs = np.asarray(observation, dtype=np.float64)
        view, n = FleetView.read(obs, self.layout), self.layout.n_vehicles
        mask = view.mask(self.layout.max_order)
        if self.reorder is not None:
            mask = mask[: 4 * n]
        x = obs if self.base is None else with_base_duties(obs, self.base, n, view)
        if deterministic:
            action = self.mode(self.normalize(x), mask)
        else:
            action, _ = self.model.predict(self.normalize(x), action_masks=mask)
        action = np.asarray(action, dtype=np.int64)
        if self.cover:
            action = np.concatenate([cover_needs(self.layout.config, action[:n], view),
                                     action[n:]])  # fmt: skip
        if self.reorder is not None:
            fits = int((action == SERVICE).sum())
            s, S = self.reorder
            q = reorder(view.stock, view.transit, fits, s, S, self.layout.max_order)
            action = np.append(action, q)
        return action, state

    def mode(self, z: F32, mask: NDArray[np.bool_]) -> I64:
        """The deterministic action for a normalised observation: each dimension's allowed
        action of highest logit, SB3's ``predict(deterministic=True)`` without its per-call
        overhead (tested equal). The vehicle network runs in numpy with its weights taken at
        the first call: the agent is frozen (a new one is made for each curve point)."""
        import torch as th

        from agents.fleet.learning.vehicle_net import VehiclePolicy, numpy_actor

        policy = self.model.policy
        nvec = np.asarray(policy.action_space.nvec)
        if isinstance(policy, VehiclePolicy):  # the weights as they are now: frozen
            self._actor = getattr(self, "_actor", None) or numpy_actor(policy)
            logits = self._actor(z).reshape(len(nvec), -1)
            return np.where(mask.reshape(logits.shape), logits, -np.inf).argmax(axis=1)
        with th.no_grad():
            features = policy.extract_features(th.as_tensor(z[None]), policy.pi_features_extractor)
            logits = policy.action_net(policy.mlp_extractor.forward_actor(features))[0].numpy()
        cuts = np.cumsum(nvec)[:-1]
        pairs = zip(np.split(logits, cuts), np.split(mask, cuts), strict=True)
        return np.array([int(np.argmax(np.where(m, lg, -np.inf))) for lg, m in pairs])

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
    :class:`~agents.fleet.policies.rules.FleetRule`): its episodes are recorded on the training
    copies (seeds :data:`IMITATION_SEED0` * (seed + 1) + k, round robin over the copies),
    the observation statistics are updated with them, and the policy is fitted to them
    (:mod:`~agents.fleet.learning.imitation`); each of ``imitation_rounds`` DAgger rounds
    then records as many episodes driven by the clone, labelled by the teacher, and refits
    on all the data; then PPO fine-tunes for ``settings.timesteps`` (none if 0). The
    agent's ``imitation`` says how the cloning went.
    """
    s = settings
    if s.vehicle_net:
        raise ValueError("train_fleet_agent: vehicle_net needs pooled statistics; train it"
                         " with train_on_labels")  # fmt: skip
    if (teacher is None) != (s.imitation_episodes == 0):
        raise ValueError(
            "train_fleet_agent: a teacher needs settings.imitation_episodes > 0 and"
            f" imitation_episodes > 0 needs a teacher (got {s.imitation_episodes}"
            f" episodes, teacher {teacher!r})"
        )
    t0 = time.perf_counter()
    model, venv = build_model(make_env, s, layout)
    imitation = None if teacher is None else clone(model, venv, teacher, s, t0)
    return _finish(model, venv, layout, s, callback, imitation)


def build_model(
    make_env: Callable[[], gym.Env[Any, Any]], settings: FleetTraining, layout: FleetLayout,
    base: Any = None,
) -> tuple[Any, Any]:  # fmt: skip
    """MaskablePPO on ``settings.n_envs`` training copies of ``make_env()`` (each masked by
    its base env's :meth:`action_masks`, rewards scaled, spares by ``settings.reorder`` if
    set, needs covered if ``settings.cover_needs``), under SB3's ``VecNormalize``: (model,
    venv)."""
    from sb3_contrib import MaskablePPO  # heavy optional dependencies (the fleet extra)
    from sb3_contrib.common.wrappers import ActionMasker
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    s = settings

    def one() -> gym.Env[Any, Any]:
        env = make_env()
        if s.cover_needs:
            env = CoverNeeds(env, layout)
        if s.reorder is not None:
            env = ReorderBy(env, *s.reorder)
        if base is not None:
            env = BaseDuties(env, base)
        env = gym.wrappers.TransformReward(env, lambda r: float(r) * s.reward_scale)
        return ActionMasker(env, lambda e: e.get_wrapper_attr("action_masks")())

    envs = DummyVecEnv([one] * s.n_envs)
    venv = VecNormalize(envs, norm_obs=True, norm_reward=s.normalize_reward, gamma=s.gamma)
    policy: Any = "MlpPolicy"
    kwargs: dict[str, Any] = {"net_arch": list(s.net_arch)}
    if s.vehicle_net:
        from agents.fleet.learning.vehicle_net import VehicleLayout, VehiclePolicy

        if s.reorder is None:
            raise ValueError("build_model: vehicle_net decides duties only; set reorder")
        policy = VehiclePolicy
        extra = 0 if base is None else DUTIES
        kwargs = {"vehicles": VehicleLayout.of(layout, extra), "hidden": s.net_arch[-1]}
    model = MaskablePPO(
        policy, venv, learning_rate=s.learning_rate, n_steps=s.n_steps,
        batch_size=s.batch_size, n_epochs=s.n_epochs, ent_coef=s.ent_coef, gamma=s.gamma,
        clip_range=s.clip_range, policy_kwargs=kwargs, seed=s.seed, verbose=0, device="cpu",
    )  # fmt: skip
    return model, venv


def train_on_labels(
    make_env: Callable[[], gym.Env[Any, Any]], layout: FleetLayout, settings: FleetTraining,
    labels: Demonstrations, callback: Any = None, *, base: Any = None,
) -> FleetAgent:  # fmt: skip
    """MaskablePPO cloned from ``labels`` recorded once elsewhere (an expert's actions on
    states that any actor reached, the env's rewards unscaled:
    :func:`~agents.fleet.learning.imitation.record`), then
    fine-tuned by PPO for ``settings.timesteps`` shifts (none if 0). The observation
    statistics start from the labelled states; the cloning is ``settings``'
    (``imitation_epochs``, ``imitation_lr``, ``imitation_value``) from ``settings.seed``, so
    seeds differ in the network's start and the order of the minibatches only. With
    ``settings.vehicle_net`` the observation statistics are pooled over vehicles and frozen
    (:mod:`~agents.fleet.learning.vehicle_net`). With a ``base`` rule its duties are part of
    the input (:class:`BaseDuties`): the policy learns where the expert departs from it."""
    t0 = time.perf_counter()
    model, venv = build_model(make_env, settings, layout, base)
    labels = replace(labels, rewards=labels.rewards * settings.reward_scale)
    if base is not None:
        n = layout.n_vehicles
        labels = replace(labels, obs=np.stack([with_base_duties(o, base, n) for o in labels.obs]))
    venv.obs_rms.update(labels.obs)
    if settings.vehicle_net:  # ranks compare vehicles: one scale per feature, kept in PPO
        from agents.fleet.learning.vehicle_net import VehicleLayout, pool_vehicle_stats

        lay = VehicleLayout.of(layout, 0 if base is None else DUTIES)
        pool_vehicle_stats(venv.obs_rms.mean, venv.obs_rms.var, lay)
        venv.training = False
    returns = discounted_returns(labels, settings.gamma, venv, settings.normalize_reward)
    agreement, nll = imitate(model, venv, labels, returns, settings, settings.seed)
    episodes = len(labels.starts)
    done = Imitation(episodes, 0, len(labels.rewards), agreement, float("nan"), nll,
                     time.perf_counter() - t0)  # fmt: skip
    return _finish(model, venv, layout, settings, callback, done, base=base)


def _finish(
    model: Any, venv: Any, layout: FleetLayout, s: FleetTraining, callback: Any,
    imitation: Imitation | None, *, base: Any = None,
) -> FleetAgent:  # fmt: skip
    """PPO for ``s.timesteps`` shifts, then the agent with its statistics frozen."""
    if s.timesteps > 0:
        model.learn(total_timesteps=s.timesteps, callback=callback)
    rms: Any = venv.obs_rms  # one RunningMeanStd: the observation is a Box
    mean, var = rms.mean.astype(np.float32), rms.var.astype(np.float32)
    agent = FleetAgent(model, layout, mean, var, reorder=s.reorder, cover=s.cover_needs, base=base)
    agent.imitation = imitation
    return agent
