"""The TorchRL side of :mod:`agents.fleet.learning.marl`: the networks, the teacher's
recorded shifts, behaviour cloning and the PPO loop (TorchRL's multi-agent PPO tutorial:
``PettingZooWrapper``, ``MultiAgentMLP``, ``MaskedCategorical``, GAE, ``ClipPPOLoss``)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import torch
from numpy.typing import NDArray
from tensordict.nn import TensorDictModule
from torch import nn
from torchrl.collectors import Collector
from torchrl.data import LazyTensorStorage, ReplayBuffer, SamplerWithoutReplacement
from torchrl.envs import PettingZooWrapper, RewardScaling, TransformedEnv
from torchrl.modules import MaskedCategorical, MultiAgentMLP, ProbabilisticActor
from torchrl.objectives import ClipPPOLoss, ValueEstimators

from agents.fleet.settings import IMITATION_SEED0

if TYPE_CHECKING:  # marl imports this module where it trains: no import back at run time
    from agents.fleet.learning.marl import MarlTraining

GROUP = "vehicle"  # TorchRL's group of agents: every vehicle
OBS = (GROUP, "observation", "observation")  # where PettingZooWrapper puts a vehicle's view
LOG_PROB = (GROUP, "action_log_prob")


class Standardise(nn.Module):
    """``(x - loc) / scale`` with fixed statistics (saved with the network)."""

    def __init__(self, loc: NDArray[np.float32], scale: NDArray[np.float32]) -> None:
        super().__init__()
        self.loc: torch.Tensor
        self.scale: torch.Tensor
        self.register_buffer("loc", torch.as_tensor(loc, dtype=torch.float32))
        self.register_buffer("scale", torch.as_tensor(scale, dtype=torch.float32))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return (x - self.loc) / self.scale


@dataclass
class Networks:
    """The shared policy and the critic, as plain networks and as TorchRL modules."""

    actor_net: nn.Module
    critic_net: nn.Module
    policy: ProbabilisticActor
    critic: TensorDictModule


@dataclass
class Recorded:
    """Shifts of whole episodes: each vehicle's view (T, n, d), mask (T, n, 4), duty
    (T, n), the fleet's reward (T,), and where each episode starts."""

    views: NDArray[np.float32]
    masks: NDArray[np.bool_]
    actions: NDArray[np.int64]
    rewards: NDArray[np.float64]
    starts: list[int]


def _mlp(d: int, out: int, n: int, st: MarlTraining, centralised: bool) -> MultiAgentMLP:
    return MultiAgentMLP(
        n_agent_inputs=d, n_agent_outputs=out, n_agents=n, centralised=centralised,
        share_params=True, depth=st.depth, num_cells=st.hidden, activation_class=nn.Tanh,
    )  # fmt: skip


def make_networks(par: Any, st: MarlTraining, loc: NDArray[Any], scale: NDArray[Any]) -> Networks:
    """A shared policy (view -> 4 logits) and critic (MAPPO: every view -> each value); the
    view's width is the statistics' (the env's view, or more: the base rule's duty)."""
    torch.manual_seed(st.seed)
    n, d = par.n, len(loc)
    actor_net = nn.Sequential(Standardise(loc, scale), _mlp(d, 4, n, st, False))
    critic_net = nn.Sequential(Standardise(loc, scale), _mlp(d, 1, n, st, st.centralised_critic))
    module = TensorDictModule(actor_net, in_keys=[OBS], out_keys=[(GROUP, "logits")])
    policy = ProbabilisticActor(
        module, in_keys={"logits": (GROUP, "logits"), "mask": (GROUP, "action_mask")},
        out_keys=[(GROUP, "action")], distribution_class=MaskedCategorical,
        return_log_prob=True, log_prob_key=LOG_PROB,
    )  # fmt: skip
    critic = TensorDictModule(critic_net, in_keys=[OBS], out_keys=[(GROUP, "state_value")])
    return Networks(actor_net, critic_net, policy, critic)


def record(par: Any, teacher: Any, st: MarlTraining, random_shifts: int = 200) -> Recorded:
    """The teacher's ``imitation_episodes`` episodes (seeds ``IMITATION_SEED0 * (seed + 1)
    + k``; it acts on :meth:`state`, the single env's observation), or without a teacher
    ``random_shifts`` shifts of random allowed duties (for the input statistics)."""
    rng = np.random.default_rng(st.seed)
    views: list[NDArray[np.float32]] = []
    masks: list[NDArray[np.bool_]] = []
    actions: list[NDArray[np.int64]] = []
    rewards: list[float] = []
    starts: list[int] = []
    for k in range(max(st.imitation_episodes, 1)):
        obs, _ = par.reset(seed=IMITATION_SEED0 * (st.seed + 1) + k)
        starts.append(len(rewards))
        while par.agents and (teacher is not None or len(rewards) < random_shifts):
            m = np.stack([obs[a]["action_mask"] for a in par.vehicles]).astype(bool)
            if teacher is None:
                duty = np.array([rng.choice(np.flatnonzero(row)) for row in m])
            else:
                duty = np.asarray(teacher.predict(par.state(), deterministic=True)[0])[: par.n]
            views.append(np.stack([obs[a]["observation"] for a in par.vehicles]))
            masks.append(m)
            actions.append(duty)
            obs, rew, *_ = par.step({a: int(duty[v]) for v, a in enumerate(par.vehicles)})
            rewards.append(rew[par.vehicles[0]])
    return Recorded(np.stack(views), np.stack(masks), np.stack(actions).astype(np.int64),
                    np.array(rewards), starts)  # fmt: skip


def _returns(data: Recorded, gamma: float, scale: float) -> NDArray[np.float64]:
    """Discounted returns of each recorded shift within its episode (scaled rewards)."""
    out = np.zeros(len(data.rewards))
    ends = [*data.starts[1:], len(data.rewards)]
    for a, b in zip(data.starts, ends, strict=True):
        g = 0.0
        for t in range(b - 1, a - 1, -1):
            g = data.rewards[t] * scale + gamma * g
            out[t] = g
    return out


def fit_clone(nets: Networks, data: Recorded, st: MarlTraining) -> float:
    """Behaviour cloning: masked cross-entropy of the teacher's duties, the critic fitted to
    the recorded returns; the clone's agreement with the teacher on its shifts."""
    x = torch.as_tensor(data.views)
    mask, act = torch.as_tensor(data.masks), torch.as_tensor(data.actions)
    ret = torch.as_tensor(_returns(data, st.gamma, st.reward_scale), dtype=torch.float32)
    params = [*nets.actor_net.parameters(), *nets.critic_net.parameters()]
    opt = torch.optim.Adam(params, lr=st.imitation_lr)
    gen = torch.Generator().manual_seed(st.seed)
    for _ in range(st.imitation_epochs):
        for idx in torch.randperm(len(x), generator=gen).split(st.minibatch):
            logits = nets.actor_net(x[idx]).masked_fill(~mask[idx], -1e9)
            ce = nn.functional.cross_entropy(logits.reshape(-1, 4), act[idx].reshape(-1))
            value = nets.critic_net(x[idx]).squeeze(-1)
            loss = ce + nn.functional.mse_loss(value, ret[idx, None].expand_as(value))
            opt.zero_grad()
            loss.backward()
            opt.step()
    with torch.no_grad():
        pred = nets.actor_net(x).masked_fill(~mask, -1e9).argmax(-1)
    return float((pred == act).float().mean())


def torchrl_env(par: Any, st: MarlTraining) -> TransformedEnv:
    """The PettingZoo env through TorchRL (one group, the masks in the spec), rewards
    scaled."""
    env = PettingZooWrapper(
        par, categorical_actions=True, seed=st.seed, group_map={GROUP: list(par.vehicles)}
    )
    return TransformedEnv(
        env, RewardScaling(loc=0.0, scale=st.reward_scale, in_keys=[(GROUP, "reward")])
    )


def _loss(nets: Networks, st: MarlTraining) -> ClipPPOLoss:
    loss = ClipPPOLoss(
        actor_network=nets.policy, critic_network=nets.critic, clip_epsilon=st.clip,
        entropy_coeff=st.entropy, normalize_advantage=False,
    )  # fmt: skip
    loss.set_keys(
        reward=(GROUP, "reward"), action=(GROUP, "action"), value=(GROUP, "state_value"),
        done=(GROUP, "done"), terminated=(GROUP, "terminated"), sample_log_prob=LOG_PROB,
    )  # fmt: skip
    loss.make_value_estimator(ValueEstimators.GAE, gamma=st.gamma, lmbda=st.lmbda)
    return loss


def ppo(
    nets: Networks, make_env: Callable[[], Any], st: MarlTraining,
    log: Callable[[str], None] | None = None,
) -> list[dict[str, float]]:  # fmt: skip
    """``st.frames`` shifts of PPO from where the networks are; a history row per batch."""
    torch.manual_seed(st.seed)
    env = torchrl_env(make_env(), st)
    collector = Collector(
        env, nets.policy, frames_per_batch=st.frames_per_batch, total_frames=st.frames,
        device="cpu", auto_register_policy_transforms=False,
    )  # fmt: skip
    buffer = ReplayBuffer(
        storage=LazyTensorStorage(st.frames_per_batch), sampler=SamplerWithoutReplacement(),
        batch_size=st.minibatch,
    )  # fmt: skip
    loss = _loss(nets, st)
    opt = torch.optim.Adam(loss.parameters(), lr=st.learning_rate)
    history, frames = [], 0
    for batch in collector:
        with torch.no_grad():
            loss.value_estimator(batch, params=loss.critic_network_params,
                                 target_params=loss.target_critic_network_params)  # fmt: skip
        buffer.extend(batch.reshape(-1))
        parts: dict[str, list[float]] = {}
        for _ in range(st.n_epochs * (st.frames_per_batch // st.minibatch)):
            out = loss(buffer.sample())
            total = out["loss_objective"] + out["loss_critic"] + out["loss_entropy"]
            opt.zero_grad()
            total.backward()
            nn.utils.clip_grad_norm_(loss.parameters(), st.max_grad_norm)
            opt.step()
            for k in ("loss_objective", "loss_critic", "loss_entropy"):
                parts.setdefault(k, []).append(float(out[k].detach()))
        collector.update_policy_weights_()
        frames += batch.numel()
        reward = float(batch["next", GROUP, "reward"].mean()) / st.reward_scale
        means = {k: float(np.mean(v)) for k, v in parts.items()}
        history.append({"frames": frames, "reward": reward} | means)
        if log is not None:
            log(f"PPO {frames} shifts: reward/shift {reward:.1f}")
    collector.shutdown()
    return history
