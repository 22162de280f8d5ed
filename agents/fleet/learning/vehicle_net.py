"""A central fleet policy that decides each vehicle with one shared network (MaskablePPO's
policy for ``FleetTraining(vehicle_net=True)``).

A flat MLP over the fleet observation has to learn "a pad near its end goes to the shop at
the window" once for every vehicle slot, from the few shifts where that slot's pad was
near its end; twelve vehicles, twelve times the data. Here each vehicle is read by the
same network (permutation-equivariant, as in Deep Sets): its own features and RUL, the
fleet's features (shift, window, stock, bays), and where it stands in the fleet (the share
of vehicles with less hot-route and less mild-route life, the ranking a dispatcher uses).
A second layer sees the vehicle's first-layer features beside their mean over the fleet;
one shared linear head gives its four duty logits. The critic pools the vehicles' features
by their mean.

The ranks compare vehicles, so the observation's statistics must be the same for every
vehicle's copy of a feature: :func:`pool_vehicle_stats` pools them (SB3's
``VecNormalize`` keeps one mean and variance per dimension).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray
from sb3_contrib.common.maskable.policies import MaskableActorCriticPolicy
from torch import nn

from agents.fleet.policies.view import FleetLayout
from brake_env.env.fleet.spaces import FLEET_FEATURES, N_VF


@dataclass(frozen=True)
class VehicleLayout:
    """Where each vehicle's values are in the flat observation (plain ints, picklable).

    Attributes:
        n: Vehicles.
        k: Values appended per vehicle (the RUL fields).
        hot, mild: Columns of the hot- and mild-route RUL among the appended values.
        extra: Values per vehicle after those (the base rule's duty, one-hot:
            :class:`~agents.fleet.learning.dispatch.BaseDuties`), at the observation's end.
    """

    n: int
    k: int
    hot: int
    mild: int
    extra: int = 0

    @classmethod
    def of(cls, layout: FleetLayout, extra: int = 0) -> VehicleLayout:
        hot, mild = layout.column("hot", layout.rul_field), layout.column("mild", layout.rul_field)
        assert hot is not None, "the layout has no hot-route RUL"
        return cls(layout.n_vehicles, layout.per_vehicle, hot, hot if mild is None else mild,
                   extra)  # fmt: skip

    @property
    def nf(self) -> int:
        return len(FLEET_FEATURES)

    def split(self, x: torch.Tensor) -> tuple[torch.Tensor, ...]:
        """(vehicle features (B, n, N_VF), fleet features (B, nf), appended (B, n, k), extra
        (B, n, extra))."""
        a, b = self.n * N_VF, self.n * N_VF + self.nf
        c = b + self.n * self.k
        n, rows = self.n, x.shape[0]
        return (x[:, :a].reshape(rows, n, N_VF), x[:, a:b], x[:, b:c].reshape(rows, n, self.k),
                x[:, c:].reshape(rows, n, self.extra))  # fmt: skip


def _share_below(x: torch.Tensor) -> torch.Tensor:
    """(B, n) -> the share of the other vehicles with a smaller value, in [0, 1]."""
    n = x.shape[1]
    return (x[:, :, None] > x[:, None, :]).sum(-1).to(x.dtype) / max(n - 1, 1)


class VehicleExtractor(nn.Module):
    """SB3's ``mlp_extractor`` for the fleet: latent_pi (B, n x hidden), latent_vf (B, hidden)."""

    def __init__(self, lay: VehicleLayout, hidden: int) -> None:
        super().__init__()
        self.lay, self.hidden = lay, hidden
        d = N_VF + lay.k + lay.nf + 2 + lay.extra

        def net() -> nn.ModuleList:
            first = nn.Sequential(nn.Linear(d, hidden), nn.Tanh())
            return nn.ModuleList([first, nn.Sequential(nn.Linear(2 * hidden, hidden), nn.Tanh())])

        self.pi, self.vf = net(), net()
        self.latent_dim_pi, self.latent_dim_vf = lay.n * hidden, hidden

    def _vehicles(self, x: torch.Tensor, layers: nn.ModuleList) -> torch.Tensor:
        own, fleet, app, extra = self.lay.split(x)
        ranks = torch.stack([_share_below(app[..., self.lay.hot]),
                             _share_below(app[..., self.lay.mild])], dim=-1)  # fmt: skip
        fleet = fleet[:, None, :].expand(-1, self.lay.n, -1)
        h = layers[0](torch.cat([own, app, fleet, ranks, extra], dim=-1))
        return layers[1](torch.cat([h, h.mean(dim=1, keepdim=True).expand_as(h)], dim=-1))

    def forward_actor(self, x: torch.Tensor) -> torch.Tensor:
        return self._vehicles(x, self.pi).flatten(1)

    def forward_critic(self, x: torch.Tensor) -> torch.Tensor:
        return self._vehicles(x, self.vf).mean(dim=1)

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return self.forward_actor(x), self.forward_critic(x)


class VehicleHead(nn.Module):
    """Each vehicle's ``actions`` logits from its latent, by one shared linear layer."""

    def __init__(self, n: int, hidden: int, actions: int) -> None:
        super().__init__()
        self.n, self.hidden = n, hidden
        self.linear = nn.Linear(hidden, actions)

    def forward(self, latent: torch.Tensor) -> torch.Tensor:
        return self.linear(latent.reshape(-1, self.n, self.hidden)).flatten(1)


class VehiclePolicy(MaskableActorCriticPolicy):
    """MaskablePPO's policy with :class:`VehicleExtractor` and :class:`VehicleHead`; the
    action space must be the duties alone (``FleetTraining.reorder`` set).

    Args:
        vehicles: Where each vehicle's values are.
        hidden: Units of each layer.
    """

    def __init__(self, *args: Any, vehicles: VehicleLayout, hidden: int = 64, **kw: Any) -> None:
        self.vehicles, self.hidden = vehicles, hidden
        super().__init__(*args, **kw)

    def evaluate_labels(
        self, obs: torch.Tensor, actions: torch.Tensor, masks: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """(values, log-probability of ``actions``): SB3's ``evaluate_actions`` without
        building one masked distribution per vehicle (tested equal), for cloning."""
        n = self.vehicles.n
        features: Any = self.extract_features(obs, self.pi_features_extractor)
        logits = self.action_net(self.mlp_extractor.forward_actor(features)).reshape(-1, n, 4)
        logits = logits.masked_fill(~masks.reshape(-1, n, 4).bool(), -1e8)  # as SB3 masks
        log_prob = torch.log_softmax(logits, -1).gather(-1, actions.long()[..., None])
        vf: Any = self.extract_features(obs, self.vf_features_extractor)
        values = self.value_net(self.mlp_extractor.forward_critic(vf))
        return values, log_prob.squeeze(-1).sum(-1)

    def _build_mlp_extractor(self) -> None:
        self.mlp_extractor = VehicleExtractor(self.vehicles, self.hidden)  # type: ignore[assignment]

    def _build(self, lr_schedule: Any) -> None:
        super()._build(lr_schedule)
        nvec = np.asarray(self.action_space.nvec)  # type: ignore[attr-defined]
        if len(nvec) != self.vehicles.n or len(set(nvec.tolist())) != 1:
            raise ValueError(f"VehiclePolicy: needs one duty per vehicle ({self.vehicles.n}),"
                             f" got action dimensions {nvec.tolist()} (set reorder)")  # fmt: skip
        self.action_net = VehicleHead(self.vehicles.n, self.hidden, int(nvec[0]))
        self.action_net.apply(lambda m: self.init_weights(m, gain=0.01))
        self.optimizer = self.optimizer_class(  # as SB3's _build makes it
            self.parameters(),
            lr=lr_schedule(1),
            **self.optimizer_kwargs,  # type: ignore[call-arg]
        )


def numpy_actor(policy: VehiclePolicy) -> Callable[[NDArray[np.float32]], NDArray[np.float32]]:
    """The actor's logits for one normalised observation, in numpy with the weights as they
    are now (a frozen policy): the same numbers as the torch modules (tested), without
    torch's per-operation overhead (about 5x faster)."""
    ext, head = policy.mlp_extractor, policy.action_net
    assert isinstance(ext, VehicleExtractor) and isinstance(head, VehicleHead)

    def weights(layer: Any) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        lin: Any = layer[0] if isinstance(layer, nn.Sequential) else layer
        return lin.weight.detach().numpy().T.copy(), lin.bias.detach().numpy().copy()

    (w1, b1), (w2, b2), (wh, bh) = weights(ext.pi[0]), weights(ext.pi[1]), weights(head.linear)
    lay, h = ext.lay, ext.hidden
    a, b = lay.n * N_VF, lay.n * N_VF + lay.nf
    c = b + lay.n * lay.k
    # The first layer's input is [own, appended, fleet, ranks, extra]: the fleet's block (the
    # same for every vehicle) goes into the bias once a decision, the others into one
    # product; the ranks' scale is folded into their weights. All in float32: an int or
    # float64 operand would make every product float64 (2.4x slower).
    r0 = N_VF + lay.k + lay.nf
    w_fleet = w1[N_VF + lay.k : r0]
    scale = np.float32(1.0 / max(lay.n - 1, 1))
    w_in = np.concatenate([w1[: N_VF + lay.k], w1[r0 : r0 + 2] * scale, w1[r0 + 2 :]])
    w2_own, w2_mean = w2[:h], w2[h:]

    def logits(z: NDArray[np.float32]) -> NDArray[np.float32]:
        app = z[b:c].reshape(lay.n, lay.k)
        hot, mild = app[:, lay.hot], app[:, lay.mild]
        below = [(x[:, None] > x).sum(1, keepdims=True, dtype=np.float32) for x in (hot, mild)]
        x = np.concatenate([z[:a].reshape(lay.n, N_VF), app, *below,
                            z[c:].reshape(lay.n, lay.extra)], axis=1)  # fmt: skip
        h1 = np.tanh(x @ w_in + (z[a:b] @ w_fleet + b1))
        h2 = np.tanh(h1 @ w2_own + (h1.mean(0) @ w2_mean + b2))
        return (h2 @ wh + bh).ravel()

    return logits


def pool_vehicle_stats(mean: NDArray[Any], var: NDArray[Any], lay: VehicleLayout) -> None:
    """In place: every vehicle's copy of a feature gets the pooled mean and variance of all
    copies (the mean of the means; the mean variance plus the variance of the means), so
    that normalised values compare across vehicles."""
    a, b = lay.n * N_VF, lay.n * N_VF + lay.nf
    c = b + lay.n * lay.k
    for lo, hi, width in ((0, a, N_VF), (b, c, lay.k), (c, len(mean), lay.extra)):
        if width == 0:
            continue
        m = mean[lo:hi].reshape(lay.n, width).copy()  # copies: the slices are overwritten
        v = var[lo:hi].reshape(lay.n, width).copy()
        mean[lo:hi] = np.tile(m.mean(axis=0), lay.n)
        var[lo:hi] = np.tile(v.mean(axis=0) + m.var(axis=0), lay.n)
