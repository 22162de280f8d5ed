"""The pads of the cost study and what every predictor estimated at their decision points
(docs/results/single-pad.md).

Actions cannot change how a pad wears (its events depend only on its K and its random
stream), so neither its events nor a predictor's estimates depend on the policy. Each pad
is therefore simulated once, run once through each predictor's fleet, and only the
estimates at its decision points are kept: a :class:`PadSet`. Any stateless policy is then
evaluated on it without simulating again (:mod:`agents.study.outcomes`), and every policy meets
the same pads under the same operating conditions (common random numbers).

The decision points are the env's: a pad installed at a decision point is decided on after
every ``decision_interval`` of its events, with the latest measured event, its age and the
predictor's estimate after that event.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
from numpy.typing import NDArray

from brake_env.data.datasets import measure
from brake_env.env.config import EnvConfig, PadRegime
from brake_env.model.atlas import Atlas
from brake_env.model.regime import LABELS, Label
from brake_env.model.simulator import simulate_runs
from brake_env.prognostics.fleet import Fleet
from brake_env.prognostics.protocol import MEASURED, EventBatch, Predictor

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
ESTIMATES = ("rul_mean", "rul_lower")  # the fields a threshold policy or an agent reads
GROUP = 8  # pads simulated together: enough runs per layer to fill the simulator's batches


def regime_weights(regime: PadRegime) -> dict[Label, float]:
    """Share of each wear-regime label among the regime's new pads (labels it never draws
    left out): :meth:`~brake_env.env.config.PadRegime.shares`."""
    return regime.shares()


@dataclass(frozen=True)
class PadDraws:
    """Which pads: K, wear-regime label and seed of each, in the order they are studied.

    A pad ``(K, label, entropy)`` has BrakeWear-v0's pad of the same K, label and
    ``SeedSequence(entropy)``'s operating conditions, true responses and life, bit for bit.
    Its sensor noise is drawn from the same seed through one stream for all channels
    (:func:`brake_env.data.datasets.measure`), not the env's per-channel streams, so the
    logged readings differ from the env's pad by independent noise of the same law.

    Attributes:
        wear_coeff: Archard coefficient K of each pad [-].
        label: Wear regime of each pad (``id``, ``ood-slow`` or ``ood-fast``).
        entropy: Seed of each pad's operating conditions and sensor noise.
        weights: Share of each label in the regime studied; the pads of a label stand for
            that share of a fleet's pads (stratified sampling).
    """

    wear_coeff: F64
    label: NDArray[np.str_]
    entropy: I64
    weights: dict[str, float]

    def __post_init__(self) -> None:
        n = len(self.wear_coeff)
        if len(self.label) != n or len(self.entropy) != n:
            raise ValueError("PadDraws: give one label and one entropy per wear coefficient")
        missing = [k for k, w in self.weights.items() if w > 0 and not np.any(self.label == k)]
        if missing or not self.weights:
            raise ValueError(f"PadDraws: no pads of label(s) {missing} that have a weight")

    @classmethod
    def stratified(cls, regime: PadRegime, per_label: int, seed: int | Sequence[int]) -> PadDraws:
        """``per_label`` pads of every label the regime draws, K from its distribution."""
        if per_label < 1:
            raise ValueError(f"PadDraws: per_label must be >= 1, got {per_label}")
        rng = np.random.default_rng(seed)
        weights = regime_weights(regime)
        ks, labels, entropy = [], [], []
        for label in weights:
            ks.append(regime.wear.draw(rng, label, per_label))
            labels.append(np.full(per_label, label))
            entropy.append(rng.integers(2**63, size=per_label, dtype=np.int64))
        return cls(
            np.concatenate(ks),
            np.concatenate(labels),
            np.concatenate(entropy),
            {str(k): w for k, w in weights.items()},
        )

    def __len__(self) -> int:
        return len(self.wear_coeff)

    def subset(self, index: NDArray[np.intp]) -> PadDraws:
        """Pads ``index``, with the study's label weights (a part of a study)."""
        return PadDraws.from_tree(
            {
                "wear_coeff": self.wear_coeff[index],
                "label": self.label[index],
                "entropy": self.entropy[index],
                "weights": self.weights,
            }
        )

    def to_tree(self) -> dict[str, Any]:
        """The draws as arrays and numbers (a unit's result in a
        :class:`~brake_env.runner.UnitStore`)."""
        return {f.name: getattr(self, f.name) for f in fields(self)} | {"weights": {**self.weights}}

    @classmethod
    def from_tree(cls, tree: Mapping[str, Any]) -> PadDraws:
        """The draws of :meth:`to_tree`, exactly; a part of a study (no label check)."""
        pads = PadDraws.__new__(PadDraws)  # a part need not hold every weighted label
        for f in fields(cls):
            value = dict(tree[f.name]) if f.name == "weights" else np.asarray(tree[f.name])
            object.__setattr__(pads, f.name, value)
        return pads


@dataclass(frozen=True)
class PadSet:
    """Every pad's life and, at each of its decision points, what a policy can see.

    A pad's decision points are its ages ``first + k * decision_interval`` (k = 0, 1, ...)
    up to its life; its rows are ``starts[i]:starts[i + 1]`` of the per-row arrays.

    Attributes:
        draws: The pads.
        decision_interval: Braking events between decisions [events].
        first: Age of each pad at its first decision [events].
        life: Events each pad completes before the next one fails it [events].
        starts: Offsets of each pad's rows (length ``len(draws) + 1``).
        measured: The latest measured event at each decision point (rows x ``MEASURED``).
        estimates: Predictor name -> estimate field (``rul_mean``, ``rul_lower``) -> value
            after the latest event at each decision point [events]. ``oracle`` is the true
            RUL.
        seconds: Wall time of simulating and of each predictor [s].
    """

    draws: PadDraws
    decision_interval: int
    first: I64
    life: I64
    starts: I64
    measured: F64
    estimates: dict[str, dict[str, F64]]
    seconds: dict[str, float] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.life)

    @property
    def n_decisions(self) -> I64:
        """Decision points of each pad."""
        return np.diff(self.starts)

    @property
    def pad_of_row(self) -> NDArray[np.intp]:
        return np.repeat(np.arange(len(self), dtype=np.intp), self.n_decisions)

    @property
    def age(self) -> I64:
        """The pad's age at each decision point [events]."""
        k = np.arange(self.starts[-1]) - np.repeat(self.starts[:-1], self.n_decisions)
        return np.repeat(self.first, self.n_decisions) + k * self.decision_interval

    def strata(self) -> dict[str, NDArray[np.intp]]:
        """Pads of each label that has a weight."""
        return {k: np.flatnonzero(self.draws.label == k) for k in self.draws.weights}

    def to_tree(self) -> dict[str, Any]:
        """The pad set as arrays, numbers and dicts (a unit's result,
        :class:`~brake_env.runner.UnitStore`); :meth:`from_tree` gives it back exactly."""
        tree = {f.name: getattr(self, f.name) for f in fields(self)}
        tree["draws"] = self.draws.to_tree()
        return tree

    @classmethod
    def from_tree(cls, tree: Mapping[str, Any]) -> PadSet:
        """The pad set of :meth:`to_tree`."""
        return cls(
            draws=PadDraws.from_tree(tree["draws"]),
            decision_interval=int(tree["decision_interval"]),
            first=np.asarray(tree["first"]),
            life=np.asarray(tree["life"]),
            starts=np.asarray(tree["starts"]),
            measured=np.asarray(tree["measured"]),
            estimates={
                n: {f: np.asarray(v) for f, v in e.items()} for n, e in tree["estimates"].items()
            },
            seconds={k: float(v) for k, v in tree["seconds"].items()},
        )


def concat_pad_sets(parts: Sequence[PadSet]) -> PadSet:
    """The pads of several sets of the same study, one set after the other."""
    if not parts:
        raise ValueError("concat_pad_sets: nothing to join")
    p0 = parts[0]
    draws = PadDraws(
        np.concatenate([p.draws.wear_coeff for p in parts]),
        np.concatenate([p.draws.label for p in parts]),
        np.concatenate([p.draws.entropy for p in parts]),
        p0.draws.weights,
    )
    offsets = np.cumsum([0] + [int(p.starts[-1]) for p in parts[:-1]])
    return PadSet(
        draws=draws,
        decision_interval=p0.decision_interval,
        first=np.concatenate([p.first for p in parts]),
        life=np.concatenate([p.life for p in parts]),
        starts=np.r_[0, *[p.starts[1:] + o for p, o in zip(parts, offsets, strict=True)]],
        measured=np.concatenate([p.measured for p in parts]),
        estimates={
            name: {f: np.concatenate([p.estimates[name][f] for p in parts]) for f in fields}
            for name, fields in p0.estimates.items()
        },
        seconds={k: sum(p.seconds.get(k, 0.0) for p in parts) for k in p0.seconds},
    )


def decision_rows(life: int, first: int, interval: int) -> I64:
    """Event index after which each decision of a pad is taken (age - 1)."""
    if life < first:
        return np.empty(0, dtype=np.int64)
    return np.arange(first - 1, life, interval, dtype=np.int64)


def collect_pads(
    draws: PadDraws,
    atlas: Atlas,
    config: EnvConfig,
    predictors: Mapping[str, Predictor],
    first: Sequence[int] | I64 | None = None,
    progress: Callable[[int], object] | None = None,
) -> PadSet:
    """Simulate every pad's whole life and run every predictor's fleet over it, keeping the
    estimates at its decision points.

    Args:
        draws: The pads.
        atlas: The atlas of the env.
        config: The env's config (decision interval, sensor noise, layer blending).
        predictors: Fitted predictors by name; ``oracle`` is read from the truth.
        first: Age of each pad at its first decision; default one decision interval (a
            pad installed at a decision point).
        progress: Called with the number of pads done after each group.
    """
    n, d = len(draws), config.decision_interval
    first_a = np.full(n, d, dtype=np.int64) if first is None else np.asarray(first, np.int64)
    if first_a.shape != (n,) or np.any(first_a < 1):
        raise ValueError(f"collect_pads: give a first decision age >= 1 for each of {n} pads")
    life = np.empty(n, dtype=np.int64)
    parts: list[tuple[I64, F64, dict[str, dict[str, F64]]]] = []
    seconds = dict.fromkeys(("simulate", *predictors), 0.0)
    fleets = {name: p.fleet(GROUP) for name, p in predictors.items() if name != "oracle"}
    for g0 in range(0, n, GROUP):
        idx = np.arange(g0, min(g0 + GROUP, n))
        t0 = time.perf_counter()
        batch, slots = _simulate_group(draws, idx, atlas, config)
        seconds["simulate"] += time.perf_counter() - t0
        lives = np.bincount(slots, minlength=idx.size)
        life[idx] = lives
        rows = [decision_rows(int(lives[j]), int(first_a[i]), d) for j, i in enumerate(idx)]
        offsets = np.r_[0, np.cumsum(lives)[:-1]]
        at = np.concatenate([r + o for r, o in zip(rows, offsets, strict=True)])
        measured = np.stack([getattr(batch, c)[at] for c in MEASURED], axis=1)
        est: dict[str, dict[str, F64]] = {}
        for name, fleet in fleets.items():
            t0 = time.perf_counter()
            est[name] = _fleet_estimates(fleet, idx.size, slots, batch, at)
            seconds[name] += time.perf_counter() - t0
        if "oracle" in predictors:  # the true RUL after event a - 1 is life - a
            est["oracle"] = {"rul_mean": (life[idx][slots[at]] - 1 - batch.event[at]) * 1.0}
        parts.append((np.array([r.size for r in rows]), measured, est))
        if progress:
            progress(idx.size)
    return _assemble(draws, d, first_a, life, parts, seconds)


def _simulate_group(
    draws: PadDraws, idx: NDArray[np.intp], atlas: Atlas, config: EnvConfig
) -> tuple[EventBatch, NDArray[np.intp]]:
    """The whole lives of pads ``idx``, concatenated, and the slot (0, 1, ...) of each row.

    The conditions and lives of :func:`brake_env.env.pads.simulate_pad` (the env's pad of
    that K and seed), with the runs simulated together; the noise as in :class:`PadDraws`."""
    seeds = [np.random.SeedSequence(int(draws.entropy[i])).spawn(2) for i in idx]
    trajectories = simulate_runs(
        atlas, draws.wear_coeff[idx], [s[0] for s in seeds], None, config.interpolate_layers
    )
    sizes = [t.n_events for t in trajectories]
    measured = np.empty((len(MEASURED), sum(sizes)))
    events = []
    o = 0
    for t, (_, noise_seed), size in zip(trajectories, seeds, sizes, strict=True):
        cols = dict(zip(MEASURED, measured[:, o : o + size], strict=True))
        measure(t, config.noise, np.random.default_rng(noise_seed), out=cols)
        events.append(np.arange(size, dtype=np.int64))
        o += size
    slots = np.repeat(np.arange(len(idx), dtype=np.intp), sizes)
    batch = EventBatch(np.concatenate(events), *measured)
    return batch, slots


def _fleet_estimates(
    fleet: Fleet, n: int, slots: NDArray[np.intp], batch: EventBatch, at: I64
) -> dict[str, F64]:
    """The fleet's estimates at rows ``at`` of the group's events (new pads in its slots)."""
    fleet.reset(np.arange(n))
    want = np.zeros(len(batch), dtype=bool)
    want[at] = True
    est = fleet.update(slots, batch, want)
    return {f: np.asarray(getattr(est, f)) for f in ESTIMATES if getattr(est, f) is not None}


def _assemble(
    draws: PadDraws,
    interval: int,
    first: I64,
    life: I64,
    parts: list[tuple[I64, F64, dict[str, dict[str, F64]]]],
    seconds: dict[str, float],
) -> PadSet:
    counts = np.concatenate([p[0] for p in parts])
    names = parts[0][2].keys() if parts else ()
    estimates = {
        n: {f: np.concatenate([p[2][n][f] for p in parts]) for f in parts[0][2][n]} for n in names
    }
    return PadSet(
        draws=draws,
        decision_interval=interval,
        first=first,
        life=life,
        starts=np.r_[0, np.cumsum(counts)].astype(np.int64),
        measured=np.concatenate([p[1] for p in parts]),
        estimates=estimates,
        seconds=seconds,
    )


__all__ = ["LABELS", "PadDraws", "PadSet", "collect_pads", "decision_rows", "regime_weights"]
