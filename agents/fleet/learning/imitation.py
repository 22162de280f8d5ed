"""Behaviour cloning for the fleet's MaskablePPO (the warm start of
:func:`~agents.fleet.learning.agent.train_fleet_agent`): a random initial policy sends
vehicles to service far too often and PPO spends its budget unlearning it, so the policy
is first fitted to a heuristic teacher's actions on the training envs (:func:`imitate`),
optionally with DAgger rounds in which the clone drives and the teacher labels its states.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from agents.fleet.settings import IMITATION_SEED0, FleetTraining


@dataclass(frozen=True)
class Demonstrations:
    """A teacher's episodes on the training envs (flat over shifts, episode by episode).

    Attributes:
        obs: Unnormalised observations, (steps, obs size).
        actions: The teacher's actions as the agent's action space has them, (steps, dims).
        masks: The env's action masks, (steps, mask size).
        rewards: The training env's rewards (scaled by ``reward_scale``), (steps,).
        starts: Index of each episode's first step.
        taken: The actions taken (the teacher's, or the DAgger actor's).
    """

    obs: NDArray[np.float64]
    actions: NDArray[np.int64]
    masks: NDArray[np.bool_]
    rewards: NDArray[np.float64]
    starts: NDArray[np.int64]
    taken: NDArray[np.int64]


@dataclass(frozen=True)
class Imitation:
    """How the cloning went (on the teacher's own data, after the last epoch).

    Attributes:
        episodes, rounds: Episodes recorded per round, DAgger rounds after the first.
        samples: Shifts recorded (all rounds).
        agreement: Fraction of those shifts on which the policy's deterministic action is
            the teacher's (every dimension).
        on_policy: The same fraction on the last DAgger round's shifts (the learner's own
            states) before its refit; nan without DAgger rounds.
        nll: Mean negative log-likelihood of the teacher's actions.
        seconds: Wall time of recording and cloning.
    """

    episodes: int
    rounds: int
    samples: int
    agreement: float
    on_policy: float
    nll: float
    seconds: float


def _allowed(action: NDArray[np.int64], mask: NDArray[np.bool_], nvec: NDArray[Any]) -> bool:
    offsets = np.concatenate([[0], np.cumsum(nvec)[:-1]])
    return bool(mask[offsets + action].all())


def record(
    env: gym.Env[Any, Any], teacher: Any, seeds: list[int], drop_order: bool,
    actor: Callable[[NDArray[Any], NDArray[np.bool_]], NDArray[np.int64]] | None = None,
) -> Demonstrations:  # fmt: skip
    """Label an episode from each seed on ``env`` (a training copy: its rewards scaled, its
    ``action_masks``) with ``teacher``'s actions (SB3's ``predict`` on the unnormalised
    observation); with ``drop_order`` the teacher's order quantity is dropped
    (:class:`ReorderBy`). The teacher acts, or ``actor(obs, mask)`` if given (DAgger: the
    learner's states, the teacher's labels; the rewards are then the actor's)."""
    nvec = np.asarray(env.action_space.nvec)  # type: ignore[attr-defined]
    obs_l: list[NDArray[np.float64]] = []
    act_l: list[NDArray[np.int64]] = []
    taken: list[NDArray[np.int64]] = []
    mask_l: list[NDArray[np.bool_]] = []
    rew_l: list[float] = []
    starts: list[int] = []
    for seed in seeds:
        starts.append(len(obs_l))
        obs, _ = env.reset(seed=seed)
        done = False
        while not done:
            mask = np.asarray(env.get_wrapper_attr("action_masks")(), dtype=bool)
            action, _ = teacher.predict(obs, deterministic=True)
            action = np.asarray(action, dtype=np.int64).ravel()
            if drop_order:
                action = action[:-1]
            if action.shape != nvec.shape or not _allowed(action, mask, nvec):
                at = len(obs_l) - starts[-1]
                raise ValueError(f"teacher {teacher!r} broke the action space or the mask at"
                                 f" shift {at} of seed {seed}: {action}")  # fmt: skip
            obs_l.append(np.asarray(obs, dtype=np.float64))
            act_l.append(action)
            mask_l.append(mask)
            if actor is not None:
                action = np.asarray(actor(obs, mask), dtype=np.int64)
            taken.append(action)
            obs, reward, terminated, truncated, _ = env.step(action)
            rew_l.append(float(reward))
            done = bool(terminated or truncated)
    return Demonstrations(
        np.stack(obs_l), np.stack(act_l), np.stack(mask_l), np.array(rew_l),
        np.array(starts, dtype=np.int64), np.stack(taken),
    )  # fmt: skip


def discounted_returns(
    demo: Demonstrations, gamma: float, venv: Any, normalize_reward: bool
) -> NDArray[np.float64]:
    """Discounted returns of the teacher's (normalised, if VecNormalize does) rewards; an
    episode's truncation is bootstrapped with the mean reward's return r / (1 - gamma), as
    PPO bootstraps truncated episodes. Updates VecNormalize's return statistics first."""
    ends = np.append(demo.starts[1:], len(demo.rewards))
    if normalize_reward:  # VecNormalize's running discounted sums, then its scaling
        running = np.empty_like(demo.rewards)
        for a, b in zip(demo.starts, ends, strict=True):
            acc = 0.0
            for i in range(a, b):
                acc = acc * gamma + demo.rewards[i]
                running[i] = acc
        venv.ret_rms.update(running)
    r = np.asarray(venv.normalize_reward(demo.rewards), dtype=np.float64)
    tail = float(r.mean()) / (1.0 - gamma) if gamma < 1.0 else 0.0
    out = np.empty_like(r)
    for a, b in zip(demo.starts, ends, strict=True):
        acc = tail
        for i in range(b - 1, a - 1, -1):
            acc = r[i] + gamma * acc
            out[i] = acc
    return out


def imitate(
    model: Any, venv: Any, demo: Demonstrations, returns: NDArray[np.float64],
    settings: FleetTraining, seed: int,
) -> tuple[float, float]:  # fmt: skip
    """Behaviour cloning: minimise -log p(teacher's action | obs, mask) under the masked
    policy, the observations normalised by ``venv``'s current statistics (Adam, minibatches
    of ``batch_size``, ``imitation_epochs`` passes shuffled from ``seed``; with
    ``imitation_value`` plus the value head's squared error to ``returns``). Returns the
    (agreement, mean negative log-likelihood) on ``demo`` afterwards."""
    import torch as th

    s = settings
    obs = th.as_tensor(np.asarray(venv.normalize_obs(demo.obs), dtype=np.float32))
    acts = th.as_tensor(demo.actions)
    masks = th.as_tensor(demo.masks)
    target = th.as_tensor(returns, dtype=th.float32)
    policy = model.policy
    discrete = isinstance(model.action_space, gym.spaces.Discrete)

    def flat(a: Any) -> Any:  # a Discrete policy takes (batch,) actions, not (batch, 1)
        return a[:, 0] if discrete else a

    def evaluate(o: Any, a: Any, m: Any) -> tuple[Any, Any]:  # (values, log-probability)
        if hasattr(policy, "evaluate_labels"):  # the vehicle network's fast path
            return policy.evaluate_labels(o, a, m)
        values, log_prob, _ = policy.evaluate_actions(o, flat(a), action_masks=m)
        return values, log_prob

    policy.set_training_mode(True)
    params = [
        p for name, p in policy.named_parameters() if s.imitation_value or "value" not in name
    ]
    opt = th.optim.Adam(params, lr=s.imitation_lr)
    rng = np.random.default_rng(seed)
    n = len(obs)
    for _ in range(s.imitation_epochs):
        for idx in np.array_split(rng.permutation(n), max(1, n // s.batch_size)):
            i = th.as_tensor(idx)
            values, log_prob = evaluate(obs[i], acts[i], masks[i])
            loss = -log_prob.mean()
            if s.imitation_value:
                loss = loss + 0.5 * th.nn.functional.mse_loss(values.flatten(), target[i])
            opt.zero_grad()
            loss.backward()
            opt.step()
    policy.set_training_mode(False)
    with th.no_grad():
        _, log_prob, _ = policy.evaluate_actions(obs, flat(acts), action_masks=masks)
        dist = policy.get_distribution(obs, action_masks=demo.masks)
        mode = dist.get_actions(deterministic=True).reshape(acts.shape)
    return float((mode == acts).all(dim=1).float().mean()), float(-log_prob.mean())


Actor = Callable[[NDArray[Any], NDArray[np.bool_]], NDArray[np.int64]]


def clone(
    model: Any, venv: Any, teacher: Any, s: FleetTraining, t0: float, *,
    actor_for: Callable[[Any], Actor] | None = None,
    samples: Callable[[Demonstrations], Demonstrations] | None = None,
    reward_scale: float = 1.0,
) -> Imitation:  # fmt: skip
    """Clone ``teacher`` into ``model``'s policy: its episodes on the training envs
    (``venv.venv.envs``), then ``imitation_rounds`` DAgger rounds (see
    :func:`~agents.fleet.learning.agent.train_fleet_agent`).

    The parameter-shared agent (:mod:`.fleet_shared`) records on fleet envs but learns
    from vehicles: ``samples`` turns fleet shifts into the policy's samples, ``actor_for(env)``
    is the DAgger actor on a copy (the clone's duties and the store's rule), and
    ``reward_scale`` scales the recorded rewards (its copies' rewards are unscaled; the
    central agent's copies scale them)."""
    k = s.imitation_episodes

    def central(env: Any) -> Actor:
        def actor(obs: NDArray[Any], mask: NDArray[np.bool_]) -> NDArray[np.int64]:
            z = np.asarray(venv.normalize_obs(obs), dtype=np.float32)
            return np.asarray(model.predict(z, action_masks=mask, deterministic=True)[0])

        return actor

    actor_for = actor_for or central
    envs = venv.venv.envs  # the training copies
    demo, returns, on_policy = None, np.zeros(0), float("nan")
    for r in range(s.imitation_rounds + 1):  # round 0: the teacher acts; then DAgger
        seed0 = IMITATION_SEED0 * (s.seed + 1) + r * k
        fleet = concat([
            record(envs[i], teacher, list(range(seed0 + i, seed0 + k, s.n_envs)),
                   s.reorder is not None, None if r == 0 else actor_for(envs[i]))
            for i in range(min(s.n_envs, k))
        ])  # fmt: skip
        fleet = replace(fleet, rewards=fleet.rewards * reward_scale)
        new = fleet if samples is None else samples(fleet)
        if r > 0:  # the learner's agreement on its own states, before refitting
            on_policy = float((new.taken == new.actions).all(axis=1).mean())
        venv.obs_rms.update(new.obs)  # statistics first: the policy sees them
        per_shift = len(new.rewards) // len(fleet.rewards)  # samples per fleet shift
        ret = discounted_returns(fleet, s.gamma, venv, s.normalize_reward)
        returns = np.concatenate([returns, np.repeat(ret, per_shift)])
        demo = new if demo is None else concat([demo, new])
        agreement, nll = imitate(model, venv, demo, returns, s, s.seed + r)
    assert demo is not None
    return Imitation(k, s.imitation_rounds, len(demo.rewards), agreement, on_policy, nll,
                     time.perf_counter() - t0)  # fmt: skip


def concat(parts: list[Demonstrations]) -> Demonstrations:
    """Demonstrations one after another (episode starts re-indexed)."""
    offsets = np.cumsum([0] + [len(p.rewards) for p in parts[:-1]])
    return Demonstrations(
        np.concatenate([p.obs for p in parts]),
        np.concatenate([p.actions for p in parts]),
        np.concatenate([p.masks for p in parts]),
        np.concatenate([p.rewards for p in parts]),
        np.concatenate([p.starts + o for p, o in zip(parts, offsets, strict=True)]),
        np.concatenate([p.taken for p in parts]),
    )
