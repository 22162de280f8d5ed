"""A shared policy for every vehicle, trained with TorchRL (MAPPO or IPPO) on the PettingZoo
fleet env, masks intact.

The env is :class:`~brake_env.env.fleet.parallel.BrakeWearFleetParallelEnv` with a predictor
(each vehicle sees its RUL and its rank by RUL) and ``spares=(s, S)`` (no store agent: every
agent a vehicle with the same spaces), wrapped by TorchRL's ``PettingZooWrapper`` (one group,
``vehicle``; each agent's ``action_mask`` read into the spec). As TorchRL's multi-agent PPO
tutorial has it: a ``MultiAgentMLP`` policy with shared parameters, a masked categorical
(``MaskedCategorical``) over the four duties, a ``MultiAgentMLP`` critic (centralised over
every vehicle's view: MAPPO; or per vehicle: IPPO), GAE and ``ClipPPOLoss``.

Inputs are standardised by fixed statistics (:class:`Standardise`, from the teacher's
recorded views, or a random rollout's), kept in the networks. With a teacher (a fleet rule
with SB3's ``predict`` on the single env's RUL-wrapped observation, which
:meth:`~BrakeWearFleetParallelEnv.state` is) the policy is first cloned from its duties
(masked cross-entropy; the critic fitted to the recorded discounted returns), then PPO
fine-tunes. :class:`MarlFleetPolicy` runs the trained policy wherever the fleet rules run
(SB3's ``predict`` on the single env's observation), so it is evaluated by the same
function on the same episodes (``agents.fleet.evaluation.costs.run_episodes``).

Needs torch and torchrl (the ``dev`` extra), imported when used.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.fleet.learning.dispatch import DUTIES, cover_needs
from agents.fleet.policies.view import FleetLayout, FleetView
from brake_env.env.fleet.agent_view import vehicle_views
from brake_env.env.fleet.spaces import FLEET_FEATURES, N_VF
from brake_env.env.fleet.spares import SparesRule


@dataclass(frozen=True)
class MarlTraining:
    """Settings of :func:`train_marl` (TorchRL's tutorial values unless said).

    Attributes:
        frames: Shifts of PPO experience (each shift one step of every vehicle; 0: the
            clone alone).
        frames_per_batch: Shifts collected between updates.
        n_epochs: Passes over each batch.
        minibatch: Shifts per minibatch.
        learning_rate, clip, entropy, max_grad_norm: PPO's.
        gamma, lmbda: GAE's (0.995 looks ~200 shifts ahead, a pad's life on the ramp).
        hidden, depth: Each network's hidden layers.
        centralised_critic: MAPPO (the critic sees every vehicle's view) or IPPO.
        reward_scale: Rewards times this.
        imitation_episodes: The teacher's episodes to clone first (0: none).
        imitation_epochs, imitation_lr: The cloning's passes and Adam's rate.
        seed: Seeds torch, the collector's env and the episodes.
    """

    frames: int = 20_000
    frames_per_batch: int = 1_000
    n_epochs: int = 4
    minibatch: int = 250
    learning_rate: float = 3e-4
    clip: float = 0.2
    entropy: float = 1e-3
    max_grad_norm: float = 1.0
    gamma: float = 0.995
    lmbda: float = 0.95
    hidden: int = 64
    depth: int = 2
    centralised_critic: bool = True
    reward_scale: float = 1e-3
    imitation_episodes: int = 0
    imitation_epochs: int = 30
    imitation_lr: float = 1e-3
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("frames", "imitation_episodes", "seed"):
            if getattr(self, name) < 0:
                raise ValueError(f"MarlTraining: {name} must be >= 0, got {getattr(self, name)}")
        for name in ("frames_per_batch", "n_epochs", "minibatch", "hidden", "depth"):
            if getattr(self, name) < 1:
                raise ValueError(f"MarlTraining: {name} must be >= 1, got {getattr(self, name)}")
        if self.minibatch > self.frames_per_batch:
            raise ValueError(f"MarlTraining: minibatch {self.minibatch} is more than"
                             f" frames_per_batch {self.frames_per_batch}")  # fmt: skip
        for name in ("learning_rate", "clip", "reward_scale", "imitation_lr", "max_grad_norm"):
            if not getattr(self, name) > 0:
                raise ValueError(f"MarlTraining: {name} must be > 0, got {getattr(self, name)}")
        if not (0 < self.gamma <= 1 and 0 <= self.lmbda <= 1 and self.entropy >= 0):
            raise ValueError(
                f"MarlTraining: need 0 < gamma <= 1, 0 <= lmbda <= 1 and entropy >= 0,"
                f" got {self.gamma}, {self.lmbda}, {self.entropy}"
            )
        if self.frames == 0 and self.imitation_episodes == 0:
            raise ValueError("MarlTraining: nothing to train (frames and imitation_episodes 0)")


@dataclass
class MarlResult:
    """What :func:`train_marl` gives back.

    Attributes:
        policy: The trained :class:`MarlFleetPolicy`.
        history: Per PPO batch: frames so far, mean reward per shift (unscaled), losses.
        imitation_agreement: Share of the teacher's duties the clone reproduces on its
            recorded shifts (None without a teacher).
        seconds: Wall time of the cloning and of PPO.
    """

    policy: MarlFleetPolicy
    history: list[dict[str, float]] = field(default_factory=list)
    imitation_agreement: float | None = None
    seconds: dict[str, float] = field(default_factory=dict)


class MarlFleetPolicy:
    """The shared policy on the single env's RUL-wrapped observation (SB3's ``predict``):
    every vehicle's view (:func:`~brake_env.env.fleet.agent_view.vehicle_views`, with the
    base rule's duty for it when there is one), its mask rebuilt from the observation (the
    env's rule), the most likely allowed duty (``deterministic``) or a sample, then the
    spares by the env's (s, S) rule.

    Args:
        actor: The policy network (views (n, d) in, logits (n, 4) out).
        config: The env's :class:`~brake_env.env.fleet.config.FleetConfig`.
        spares: The (s, S) rule it was trained with.
        cover: The vehicles' duties go through the fleet's dispatch repair
            (:func:`~agents.fleet.learning.dispatch.cover_needs`, the central policy's)
            before the env: decided apart, made feasible together.
        base: A fleet rule whose duty for each vehicle is appended to that vehicle's view,
            one-hot (:func:`with_base_duty`): the dispatcher's default, which the policy
            learns where to leave (residual input, as the central policy's ``BaseDuties``).
        layout: Where the RUL is in the observation (default: the hot route's mean alone,
            the PettingZoo env's view); a base rule may read more (its interval).
    """

    def __init__(
        self, actor: Any, config: Any, spares: SparesRule, cover: bool = False,
        base: Any = None, layout: FleetLayout | None = None,
    ) -> None:  # fmt: skip
        self.actor, self.config, self.spares, self.cover = actor, config, spares, cover
        self.base = base
        parts = [", base rule's duty in view"] if base is not None else []
        parts += [", needs covered"] if cover else []
        self.name = "shared MAPPO (TorchRL)" + "".join(parts)
        hot = FleetLayout.of(config, fields=("rul_mean",), routes=("hot",))
        self._layout = hot if layout is None else layout
        if self._layout.column("hot", "rul_mean") is None:
            raise ValueError(f"MarlFleetPolicy: the layout has no hot-route RUL mean:"
                             f" {self._layout}")  # fmt: skip

    def logits(
        self, obs: NDArray[Any], view: FleetView | None = None
    ) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
        """(logits (n, 4), mask (n, 4)) for one observation (``view``: it read already)."""
        import torch

        n = self.config.n_vehicles
        view = FleetView.read(obs, self._layout) if view is None else view
        mask = view.mask(self.config.max_order)
        views = torch.as_tensor(shared_views(obs, self.config, self._layout, self.base, view))
        with torch.no_grad():
            logits = self.actor(views.unsqueeze(0))[0].numpy()
        return logits, mask[: 4 * n].reshape(n, 4)

    def predict(
        self, observation: NDArray[Any], state: Any = None, episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[NDArray[np.int64], Any]:  # fmt: skip
        obs = np.asarray(observation, dtype=np.float64)
        if obs.ndim == 2:
            return np.stack([self.predict(o, deterministic=deterministic)[0] for o in obs]), state
        view = FleetView.read(obs, self._layout)  # read once: mask, base rule, repair, order
        logits, mask = self.logits(obs, view)
        masked = np.where(mask, logits, -np.inf)
        if deterministic:
            duties = masked.argmax(axis=1)
        else:
            p = np.exp(masked - masked.max(axis=1, keepdims=True))
            p /= p.sum(axis=1, keepdims=True)
            duties = np.array([np.random.default_rng().choice(4, p=row) for row in p])
        if self.cover:
            duties = cover_needs(self.config, duties, view)
        fits = int((duties == 3).sum())
        q = self.spares.order(view.stock, view.transit, fits, self.config.max_order)
        return np.append(duties, q).astype(np.int64), state

    def __repr__(self) -> str:
        return f"MarlFleetPolicy({self.name}, {self.spares})"


def hot_rul_observation(obs: NDArray[Any], layout: FleetLayout) -> NDArray[np.float64]:
    """The fleet's observation (RUL as ``layout`` says) with only the hot-route RUL mean
    appended per vehicle: what the PettingZoo env's views are made from."""
    n, k = layout.n_vehicles, layout.per_vehicle
    col = layout.column("hot", "rul_mean")
    assert col is not None
    o = np.asarray(obs, dtype=np.float64)
    if k == 1:
        return o
    head = n * N_VF + len(FLEET_FEATURES)
    return np.concatenate([o[:head], o[head:].reshape(n, k)[:, col]])


def shared_views(
    obs: NDArray[Any], config: Any, layout: FleetLayout, base: Any = None,
    view: FleetView | None = None,
) -> NDArray[np.float32]:  # fmt: skip
    """(n, d): every vehicle's view of ``obs`` (RUL as ``layout`` says), with ``base``'s
    duty for it last when a base rule is given (:class:`MarlFleetPolicy`; ``view``: the
    observation read already)."""
    views = vehicle_views(hot_rul_observation(obs, layout), config, True)
    if base is None:
        return views
    view = FleetView.read(obs, layout) if view is None else view
    return with_base_duty(views, base.act(view)[: config.n_vehicles])


def with_base_duty(views: NDArray[Any], duty: NDArray[Any]) -> NDArray[np.float32]:
    """(n, d + 4): each vehicle's view with a duty for it appended, one-hot."""
    onehot = np.eye(DUTIES, dtype=np.float32)[np.asarray(duty, dtype=np.int64)]
    return np.concatenate([np.asarray(views, dtype=np.float32), onehot], axis=1)


def standardise_stats(views: NDArray[np.floating]) -> tuple[NDArray[np.float32], ...]:
    """(loc, scale) per feature of (..., d) views; a feature that hardly varies keeps a
    scale of 1% of its size (or 1), so a rare value (a window's zero need) stays finite."""
    x = np.asarray(views, dtype=np.float64).reshape(-1, views.shape[-1])
    loc, std = x.mean(axis=0), x.std(axis=0)
    scale = np.maximum(std, 1e-2 * np.maximum(np.abs(loc), 1.0))
    return loc.astype(np.float32), scale.astype(np.float32)


def train_marl(
    make_env: Callable[[], Any], settings: MarlTraining, teacher: Any = None,
    log: Callable[[str], None] | None = None,
) -> MarlResult:  # fmt: skip
    """Train one shared policy on ``make_env()`` (a :class:`BrakeWearFleetParallelEnv` with
    a predictor and a spares rule) through TorchRL: cloned from ``teacher`` first when
    ``settings.imitation_episodes`` > 0, then ``settings.frames`` shifts of PPO (MAPPO, or
    IPPO without the centralised critic). Deterministic for a seed on one thread."""
    from agents.fleet.learning.marl_torch import fit_clone, make_networks, ppo, record

    st = settings
    if (teacher is None) != (st.imitation_episodes == 0):
        raise ValueError(
            f"train_marl: a teacher needs imitation_episodes > 0 and the reverse"
            f" (got {st.imitation_episodes} episodes, teacher {teacher!r})"
        )
    par = make_env()
    if not getattr(par, "with_rul", False) or getattr(par, "spares", None) is None:
        raise ValueError("train_marl: the env needs predictor= (the view's RUL) and spares="
                         " (every agent a vehicle)")  # fmt: skip
    import torch

    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # tiny networks: threads only contend (9 ms a layer on 2 cores)
    try:
        t0 = time.perf_counter()
        data = record(par, teacher, st)
        nets = make_networks(par, st, *standardise_stats(data.views))
        agreement = fit_clone(nets, data, st) if teacher is not None else None
        t1 = time.perf_counter()
        history = ppo(nets, make_env, st, log) if st.frames > 0 else []
    finally:
        torch.set_num_threads(threads)
    policy = MarlFleetPolicy(nets.actor_net, par.base.config, par.spares)
    seconds = {"imitation": t1 - t0, "ppo": time.perf_counter() - t1}
    return MarlResult(policy, history, agreement, seconds)
