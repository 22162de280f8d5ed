"""Parameter-shared MaskablePPO on BrakeWearFleet-v0: one small policy, run by every vehicle
on its own view, instead of one policy over the whole fleet (:mod:`.fleet_agent`).

SuperSuit is not a dependency, so :class:`SharedFleetVecEnv` is the adapter its
``pettingzoo_env_to_vec_env`` would give for the PettingZoo version
(:class:`~brake_env.env.fleet.parallel.BrakeWearFleetParallelEnv`), written against the
single env: ``k`` copies of the (RUL-wrapped) fleet env become ``k * n_vehicles`` SB3
sub-envs, one per vehicle (sub-env ``c * n_vehicles + v`` is vehicle ``v`` of copy ``c``).
A vehicle sees the parallel env's view (its own ``VEHICLE_FEATURES``, then the
``FLEET_FEATURES``) with its RUL field(s) between the two, chooses its duty
(``Discrete(4)``) under its slice of the env's mask, and gets the fleet's reward (one bill:
the game is cooperative). The parallel env's ``store`` agent is replaced by a fixed (s, S)
rule (:func:`agents.fleet.policies.rules.reorder`, as :class:`~.fleet_agent.ReorderBy`): the one
shared decision has no vehicle to own it, and a second policy would need a second learner.
What the vehicles ask jointly (two services, one bay; more services than spares) is
settled by the env's deferral rule (:mod:`brake_env.env.fleet.shop`), as in the parallel
env; each vehicle's mask is its slice of the single env's mask, never a joint one.

Sharing makes the learner see ``n_vehicles`` samples per shift and its size independent of
the fleet's, but a vehicle sees no other vehicle: who goes on the ramp when ``hot_need`` <
``n_vehicles`` can only be decided from each vehicle's own state (its RUL), not by a
ranking (FleetRule's ``duty="rul"``). ``agent_indicator`` (SuperSuit's
``agent_indicator_v0``) appends a one-hot vehicle index, so that fixed roles (a roster) can
be learnt.

:class:`SharedFleetAgent` has SB3's ``predict`` on the FULL fleet observation (splits it per
vehicle, rebuilds each vehicle's mask with :meth:`~agents.fleet.policies.view.FleetView.mask`
and appends the (s, S) order), so it runs wherever the fleet rules and :class:`FleetAgent`
run (``agents.fleet.evaluation.costs.run_episodes``).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray
from stable_baselines3.common.env_util import is_wrapped
from stable_baselines3.common.vec_env import VecEnv
from stable_baselines3.common.vec_env.base_vec_env import VecEnvIndices, VecEnvStepReturn

from agents.fleet.learning.agent import FleetTraining, FrozenAgent
from agents.fleet.learning.imitation import Demonstrations, Imitation, clone
from agents.fleet.policies.rules import reorder
from agents.fleet.policies.view import FleetLayout, FleetView
from brake_env.env.fleet.shop import SERVICE
from brake_env.env.fleet.spaces import FLEET_FEATURES, N_VF

F32 = NDArray[np.float32]
_NF = len(FLEET_FEATURES)


def vehicle_observations(
    obs: NDArray[Any], n_vehicles: int, agent_indicator: bool = False
) -> NDArray[np.float32]:
    """(n_vehicles, d): each vehicle's features, its RUL field(s), the fleet's features (and
    with ``agent_indicator`` its one-hot index), from a RUL-wrapped fleet observation (the
    vehicles' features, the fleet's, then the RUL fields vehicle by vehicle)."""
    o = np.asarray(obs, dtype=np.float32)
    n = n_vehicles
    n_fields, rest = divmod(o.shape[-1] - n * N_VF - _NF, n)
    if o.ndim != 1 or rest or n_fields < 1:
        raise ValueError(f"vehicle_observations: not a RUL-wrapped observation of {n} vehicles:"
                         f" shape {o.shape}")  # fmt: skip
    veh = o[: n * N_VF].reshape(n, N_VF)
    fleet = np.broadcast_to(o[n * N_VF : n * N_VF + _NF], (n, _NF))
    est = o[n * N_VF + _NF :].reshape(n, n_fields)
    parts = [veh, est, fleet] + ([np.eye(n, dtype=np.float32)] if agent_indicator else [])
    return np.concatenate(parts, axis=1)


def _order(base: Any, duties: NDArray[np.int64], s: int, S: int) -> int:
    fits = int((duties == SERVICE).sum())
    return reorder(base.shop.stock, base.shop.in_transit, fits, s, S, base.config.max_order)


class SharedFleetVecEnv(VecEnv):
    """SB3 VecEnv of one sub-env per vehicle over ``n_copies`` copies of ``make_env()``
    (module docstring). Vehicle actions are collected per copy into the single env's
    MultiDiscrete action, the order by (s, S) appended; rewards are the fleet's times
    ``reward_scale``. A copy's episode end is every one of its vehicles' end: each gets its
    ``terminal_observation`` (and ``TimeLimit.truncated``, and an ``episode`` entry with the
    fleet's unscaled return, as SB3's Monitor gives) and the copy is reset. Copy ``c`` is
    reset with seed ``seed + c`` after :meth:`seed` (SB3 seeds a VecEnv once, at the
    model's creation). ``action_masks`` (``env_method``/``get_attr``, as sb3-contrib's
    ``get_action_masks`` asks) gives each vehicle's slice of its copy's mask.

    Args:
        make_env: Makes one RUL-wrapped fleet env (e.g. ``oracle_fleet_env``).
        n_copies: Fleet envs stepped in turn.
        s, S: Reorder point and order-up-to level of the store's rule.
        reward_scale: Rewards times this.
        agent_indicator: Append each vehicle's one-hot index to its observation.
    """

    def __init__(
        self, make_env: Callable[[], gym.Env[Any, Any]], n_copies: int, s: int, S: int,
        reward_scale: float = 1.0, agent_indicator: bool = False,
    ) -> None:  # fmt: skip
        if n_copies < 1 or not 0 <= s <= S:
            raise ValueError(f"SharedFleetVecEnv: need n_copies >= 1 and 0 <= s <= S, got"
                             f" {n_copies}, ({s}, {S})")  # fmt: skip
        self.envs = [make_env() for _ in range(n_copies)]
        self.n = int(self.envs[0].unwrapped.config.n_vehicles)  # type: ignore[attr-defined]
        self.s, self.S, self.reward_scale = s, S, reward_scale
        self.agent_indicator = agent_indicator
        box = self.envs[0].observation_space
        if not isinstance(box, spaces.Box):
            raise ValueError(f"SharedFleetVecEnv needs a Box observation, got {box}")
        low = self._split(box.low).min(axis=0)  # the indicator's rows differ
        high = self._split(box.high).max(axis=0)
        super().__init__(
            n_copies * self.n, spaces.Box(low, high, dtype=np.float32), spaces.Discrete(4)
        )
        self._fleet_seeds: list[int | None] = [None] * n_copies
        self._actions = np.zeros(self.num_envs, dtype=np.int64)
        self._returns = np.zeros(n_copies)
        self._lengths = np.zeros(n_copies, dtype=np.int64)
        self._t0 = time.perf_counter()

    def _split(self, obs: NDArray[Any]) -> F32:
        return vehicle_observations(obs, self.n, self.agent_indicator)

    def _vehicle_infos(self, info: dict[str, Any]) -> list[dict[str, Any]]:
        veh = info.get("vehicles", {})
        return [{k: x[v] for k, x in veh.items()} for v in range(self.n)]

    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        if seed is None:
            seed = int(np.random.default_rng().integers(np.iinfo(np.uint32).max))  # as SB3
        self._fleet_seeds = [seed + c for c in range(len(self.envs))]
        return self._fleet_seeds

    def reset(self) -> F32:
        out = []
        for c, env in enumerate(self.envs):
            obs, info = env.reset(seed=self._fleet_seeds[c])
            self.reset_infos[c * self.n : (c + 1) * self.n] = self._vehicle_infos(info)
            out.append(self._split(obs))
        self._fleet_seeds = [None] * len(self.envs)
        self._returns[:], self._lengths[:] = 0.0, 0
        return np.concatenate(out)

    def step_async(self, actions: NDArray[Any]) -> None:
        self._actions = np.asarray(actions, dtype=np.int64).reshape(self.num_envs)

    def step_wait(self) -> VecEnvStepReturn:
        n = self.n
        obs_l, rew_l, done_l, infos = [], [], [], []
        for c, env in enumerate(self.envs):
            duties = self._actions[c * n : (c + 1) * n]
            joint = np.append(duties, _order(env.unwrapped, duties, self.s, self.S))
            obs, reward, terminated, truncated, info = env.step(joint)
            self._returns[c] += float(reward)
            self._lengths[c] += 1
            done = bool(terminated or truncated)
            v_infos = self._vehicle_infos(info)
            if done:
                last = self._split(obs)
                episode = {"r": self._returns[c], "l": int(self._lengths[c]),
                           "t": round(time.perf_counter() - self._t0, 6)}  # fmt: skip
                for v, vi in enumerate(v_infos):
                    vi["terminal_observation"] = last[v]
                    vi["TimeLimit.truncated"] = bool(truncated and not terminated)
                    vi["episode"] = dict(episode)
                obs, reset_info = env.reset()
                self.reset_infos[c * n : (c + 1) * n] = self._vehicle_infos(reset_info)
                self._returns[c], self._lengths[c] = 0.0, 0
            obs_l.append(self._split(obs))
            rew_l.append(np.full(n, float(reward) * self.reward_scale, dtype=np.float32))
            done_l.append(np.full(n, done))
            infos += v_infos
        return np.concatenate(obs_l), np.concatenate(rew_l), np.concatenate(done_l), infos

    def action_masks(self) -> NDArray[np.bool_]:
        """(num_envs, 4): each vehicle's slice of its copy's mask."""
        n = self.n
        rows: list[NDArray[np.bool_]] = [
            env.unwrapped.action_masks()[: 4 * n].reshape(n, 4)  # type: ignore[attr-defined]
            for env in self.envs
        ]
        return np.concatenate(rows).astype(bool, copy=False)

    def _indices(self, indices: VecEnvIndices) -> list[int]:
        if indices is None:
            return list(range(self.num_envs))
        if isinstance(indices, int):
            return [indices]
        return [int(i) for i in indices]

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        idx = self._indices(indices)
        if attr_name == "action_masks":
            return [lambda i=i: self.action_masks()[i] for i in idx]
        return [self.envs[i // self.n].get_wrapper_attr(attr_name) for i in idx]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        for c in sorted({i // self.n for i in self._indices(indices)}):
            self.envs[c].set_wrapper_attr(attr_name, value)

    def env_method(
        self, method_name: str, *method_args: Any, indices: VecEnvIndices = None,
        **method_kwargs: Any,
    ) -> list[Any]:  # fmt: skip
        """``action_masks``: each vehicle's mask; any other method is called once per copy
        of the vehicles given, and its result repeated for each of them."""
        idx = self._indices(indices)
        if method_name == "action_masks":
            masks = self.action_masks()
            return [masks[i] for i in idx]
        done: dict[int, Any] = {}
        for c in sorted({i // self.n for i in idx}):
            fn = self.envs[c].get_wrapper_attr(method_name)
            done[c] = fn(*method_args, **method_kwargs)
        return [done[i // self.n] for i in idx]

    def env_is_wrapped(
        self, wrapper_class: type[gym.Wrapper[Any, Any, Any, Any]], indices: VecEnvIndices = None
    ) -> list[bool]:
        return [is_wrapped(self.envs[i // self.n], wrapper_class) for i in self._indices(indices)]

    def get_images(self) -> Sequence[NDArray[Any] | None]:
        return [self.envs[i // self.n].render() for i in range(self.num_envs)]  # type: ignore[misc]

    def close(self) -> None:
        for env in self.envs:
            env.close()


class SharedFleetAgent(FrozenAgent):
    """A trained shared MaskablePPO with frozen observation statistics (a vehicle's); SB3's
    ``predict`` on the fleet observation (module docstring).

    Args:
        model: The MaskablePPO (one vehicle's observation in, its duty out).
        layout, obs_mean, obs_var, clip: As :class:`~.fleet_agent.FrozenAgent`'s.
        s, S: The store's (s, S) rule it was trained with.
        agent_indicator: Whether it sees its one-hot vehicle index.
    """

    def __init__(
        self, model: Any, layout: FleetLayout, obs_mean: F32, obs_var: F32, *, s: int, S: int,
        clip: float = 10.0, agent_indicator: bool = False,
    ) -> None:  # fmt: skip
        super().__init__(model, layout, obs_mean, obs_var, clip)
        self.s, self.S, self.agent_indicator = s, S, agent_indicator
        self.name = "shared MaskablePPO"

    def predict(
        self,
        observation: NDArray[Any],
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[NDArray[np.int64], Any]:
        """The single env's action (each vehicle's duty, then the (s, S) order) for one
        fleet observation, or a batch of them (one row each)."""
        obs = np.asarray(observation, dtype=np.float64)
        if obs.ndim == 2:
            return np.stack([self.predict(o, deterministic=deterministic)[0] for o in obs]), state
        n = self.layout.n_vehicles
        view = FleetView.read(obs, self.layout)
        mask = view.mask(self.layout.max_order)[: 4 * n].reshape(n, 4)
        own = self.normalize(vehicle_observations(obs, n, self.agent_indicator))
        duties, _ = self.model.predict(own, action_masks=mask, deterministic=deterministic)
        duties = np.asarray(duties, dtype=np.int64).reshape(n)
        q = reorder(view.stock, view.transit, int((duties == SERVICE).sum()), self.s, self.S,
                    self.layout.max_order)  # fmt: skip
        return np.append(duties, q), state

    def __repr__(self) -> str:
        return f"SharedFleetAgent({self.name}, s={self.s}, S={self.S})"


def vehicle_samples(demo: Demonstrations, n: int, agent_indicator: bool) -> Demonstrations:
    """A fleet's recorded shifts as the shared policy's samples: each shift becomes its
    ``n`` vehicles' rows (observation, duty, mask slice, the fleet's reward), in order."""
    obs = np.concatenate([vehicle_observations(o, n, agent_indicator) for o in demo.obs])
    return Demonstrations(
        obs.astype(np.float64), demo.actions[:, :n].reshape(-1, 1),
        demo.masks[:, : 4 * n].reshape(-1, 4), np.repeat(demo.rewards, n), demo.starts * n,
        demo.taken[:, :n].reshape(-1, 1),
    )  # fmt: skip


def _clone(model: Any, venv: Any, teacher: Any, st: FleetTraining, t0: float) -> Imitation:
    """Behaviour cloning of ``teacher`` (its duties, vehicle by vehicle) and DAgger rounds
    in which the shared clone drives, the store ordering by (s, S)."""
    envs: SharedFleetVecEnv = venv.venv

    def actor_for(env: Any) -> Callable[[NDArray[Any], NDArray[np.bool_]], NDArray[np.int64]]:
        def actor(obs: NDArray[Any], mask: NDArray[np.bool_]) -> NDArray[np.int64]:
            own = venv.normalize_obs(envs._split(obs)).astype(np.float32)
            m = mask[: 4 * envs.n].reshape(envs.n, 4)
            duties = np.asarray(model.predict(own, action_masks=m, deterministic=True)[0])
            duties = duties.astype(np.int64).reshape(envs.n)
            return np.append(duties, _order(env.unwrapped, duties, envs.s, envs.S))

        return actor

    return clone(
        model, venv, teacher, replace(st, reorder=None), t0, actor_for=actor_for,
        samples=lambda d: vehicle_samples(d, envs.n, envs.agent_indicator),
        reward_scale=st.reward_scale,
    )  # fmt: skip


def train_shared_agent(
    make_env: Callable[[], gym.Env[Any, Any]],
    layout: FleetLayout,
    settings: FleetTraining,
    *,
    s: int,
    S: int,
    callback: Any = None,
    agent_indicator: bool = False,
    teacher: Any = None,
) -> SharedFleetAgent:
    """Train one MaskablePPO shared by every vehicle on ``settings.n_envs`` copies of
    ``make_env()`` (:class:`SharedFleetVecEnv`, spares by (s, S)).

    ``settings.timesteps`` counts fleet shifts, as for :func:`~.fleet_agent.train_fleet_agent`
    (SB3 counts ``n_vehicles`` samples per shift); ``n_steps`` is shifts per copy per
    rollout (``n_steps * n_envs * n_vehicles`` samples, minibatches of ``batch_size``
    samples). Observations are normalised (VecNormalize, statistics frozen into the agent),
    rewards scaled by ``reward_scale`` and, with ``normalize_reward``, by the return's
    running spread. ``settings.reorder`` is not used (the order is (s, S)). With
    ``settings.imitation_episodes`` > 0 the policy is first cloned from ``teacher``'s
    duties, vehicle by vehicle, with DAgger rounds (as the central agent's warm start,
    :func:`~agents.fleet.learning.imitation.clone`); a vehicle sees only itself, so a
    teacher that ranks the vehicles can be cloned only as far as a vehicle's own state
    tells its rank. Copy i's episodes start from seed ``settings.seed + i``.
    """
    from sb3_contrib import MaskablePPO  # heavy optional dependencies (the fleet extra)
    from stable_baselines3.common.vec_env import VecNormalize

    st = settings
    if (teacher is None) != (st.imitation_episodes == 0):
        raise ValueError("train_shared_agent: a teacher needs settings.imitation_episodes > 0"
                         f" and the reverse (got {st.imitation_episodes} episodes, teacher"
                         f" {teacher!r})")  # fmt: skip
    t0 = time.perf_counter()
    envs = SharedFleetVecEnv(make_env, st.n_envs, s, S, st.reward_scale, agent_indicator)
    if envs.n != layout.n_vehicles:
        raise ValueError(f"train_shared_agent: layout has {layout.n_vehicles} vehicles, the env"
                         f" {envs.n}")  # fmt: skip
    venv = VecNormalize(envs, norm_obs=True, norm_reward=st.normalize_reward, gamma=st.gamma)
    model = MaskablePPO(
        "MlpPolicy", venv, learning_rate=st.learning_rate, n_steps=st.n_steps,
        batch_size=st.batch_size, n_epochs=st.n_epochs, ent_coef=st.ent_coef, gamma=st.gamma,
        clip_range=st.clip_range, policy_kwargs={"net_arch": list(st.net_arch)}, seed=st.seed,
        verbose=0, device="cpu",
    )  # fmt: skip
    imitation = None if teacher is None else _clone(model, venv, teacher, st, t0)
    if st.timesteps > 0:
        model.learn(total_timesteps=st.timesteps * envs.n, callback=callback)
    rms: Any = venv.obs_rms
    mean, var = rms.mean.astype(np.float32), rms.var.astype(np.float32)
    agent = SharedFleetAgent(model, layout, mean, var, s=s, S=S, agent_indicator=agent_indicator)
    agent.imitation = imitation
    return agent
