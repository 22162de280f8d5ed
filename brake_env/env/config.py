"""Configuration of BrakeWear-v0: cost weights, the wear regime of new pads, episode shape.

Frozen, validated dataclasses. ``EnvConfig.from_kwargs`` is how ``gym.make`` keyword
arguments arrive: an unknown name or a value out of range raises one ``ValueError`` that
names it, instead of being silently accepted.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from brake_env._validate import check_nonnegative, check_range, plain_numbers
from brake_env.env.shared import check_choice, check_int_fields, check_types, config_from_kwargs
from brake_env.model.regime import Label, WearRegime
from brake_env.model.simulator import SensorNoise

ENV_ID = "BrakeWear-v0"
REGIMES = ("id", "ood", "mixed")
PRESETS = ("hot-duty", "cold-start")
MAX_DECISION_INTERVAL = 10_000  # well below the shortest pad life (~7e4 events at +6 sigma)


@dataclass(frozen=True)
class CostWeights:
    """Cost of each maintenance outcome, in currency units; the keys of ``info["costs"]``.

    The reward of a step is ``revenue`` minus the sum of the other terms.

    Attributes:
        planned_replacement: Parts and labour of a replacement the policy asks for.
        corrective_replacement: Parts and labour of a replacement forced by a failure.
        downtime: Lost production while the failed vehicle waits for repair.
        damage: Secondary damage of a brake failure (disc, caliper, safety incident).
        revenue: Operating revenue per braking event (0: pure cost minimisation).
    """

    planned_replacement: float = 1000.0
    corrective_replacement: float = 1000.0
    downtime: float = 4000.0
    damage: float = 5000.0
    revenue: float = 0.0

    def __post_init__(self) -> None:
        plain_numbers(self)
        check_nonnegative(self, *(f.name for f in dataclasses.fields(self)))

    @property
    def failure(self) -> float:
        """Total cost of one failure."""
        return self.corrective_replacement + self.downtime + self.damage

    @property
    def failure_to_planned(self) -> float:
        return self.failure / self.planned_replacement if self.planned_replacement else np.inf

    @classmethod
    def with_ratio(cls, failure_to_planned: float, planned: float = 1000.0) -> CostWeights:
        """Weights whose failure costs ``failure_to_planned`` planned replacements, split like
        the defaults (1 : 4 : 5 between corrective replacement, downtime and damage)."""
        if not failure_to_planned >= 1.0:
            raise ValueError(f"failure_to_planned must be >= 1, got {failure_to_planned}")
        total = failure_to_planned * planned
        return cls(planned, 0.1 * total, 0.4 * total, 0.5 * total)


@dataclass(frozen=True)
class PadRegime:
    """Which wear regime each new pad comes from (paper 2.1.6).

    Attributes:
        kind: ``id`` (in-distribution K), ``ood`` (slow or fast OOD wear with equal odds) or
            ``mixed`` (OOD with probability ``ood_share``, else ID).
        ood_share: Probability that a new pad is OOD in the ``mixed`` regime [-].
        wear: The distribution of K of each label.
    """

    kind: Literal["id", "ood", "mixed"] = "id"
    ood_share: float = 0.5
    wear: WearRegime = field(default_factory=WearRegime)

    def __post_init__(self) -> None:
        plain_numbers(self)
        if self.kind not in REGIMES:
            raise ValueError(f"regime must be one of {list(REGIMES)}, got {self.kind!r}")
        check_range(self, "ood_share", 0.0, 1.0)
        if self.kind != "id":
            self.wear.check_ood()

    def shares(self) -> dict[Label, float]:
        """Share of each label among new pads, as :meth:`draw` draws them (labels it never
        draws left out)."""
        s = {"id": 0.0, "ood": 1.0, "mixed": self.ood_share}[self.kind]
        shares: dict[Label, float] = {"id": 1.0 - s, "ood-slow": s / 2, "ood-fast": s / 2}
        return {k: v for k, v in shares.items() if v > 0}

    def components(self) -> list[tuple[float, float]]:
        """(share, mean K) of each label new pads are drawn from (:meth:`shares`)."""
        return [(s, self.wear.mean(label)) for label, s in self.shares().items()]

    def draw(self, rng: np.random.Generator) -> tuple[float, Label]:
        """K of one new pad and its label (``id``, ``ood-slow`` or ``ood-fast``)."""
        ood = self.kind == "ood" or (self.kind == "mixed" and rng.random() < self.ood_share)
        label: Label = "id"
        if ood:
            label = "ood-fast" if rng.random() < 0.5 else "ood-slow"
        return float(self.wear.draw(rng, label, 1)[0]), label


class RegimeFields:
    """The wear regime of new pads, as every env's config holds it (fields ``regime``,
    ``ood_share``, ``k_mean``, ``k_std``, ``ood_shift_sigma``)."""

    regime: Literal["id", "ood", "mixed"]
    ood_share: float
    k_mean: float
    k_std: float
    ood_shift_sigma: float

    @property
    def pad_regime(self) -> PadRegime:
        return PadRegime(self.regime, self.ood_share, self.wear)

    @property
    def wear(self) -> WearRegime:
        return WearRegime(self.k_mean, self.k_std, self.ood_shift_sigma)


@dataclass(frozen=True)
class EnvConfig(RegimeFields):
    """Everything BrakeWear-v0 can be configured with (the keyword arguments of ``gym.make``).

    Attributes:
        decision_interval: Braking events per step (1 allowed) [events].
        episode_events: Braking events per episode; the episode is truncated after them
            (several pad lives: a pad lasts ~1.2e5 events at the default K) [events].
        regime: Wear regime of new pads: ``id``, ``ood`` or ``mixed``.
        ood_share: Share of OOD pads in the ``mixed`` regime [-].
        k_mean, k_std, ood_shift_sigma: Distribution of K (the fields of
            :class:`~brake_env.model.regime.WearRegime`, flat so that ``gym.make`` and RL
            Zoo's ``env_kwargs`` take them as keywords).
        costs: Cost weights (a :class:`CostWeights` or a dict of its fields).
        noise: Sensor noise of the observed channels (a :class:`SensorNoise` or a dict).
        preset: Brake calibration of the default atlas (``hot-duty`` or ``cold-start``).
        interpolate_layers: Blend adjacent atlas layers by volume (paper footnote 1).
        truth: Give the true RUL: a pad is simulated ahead to failure when its truth is
            first read (on a copy of its random stream; events up to ~5e5 are kept for
            serving, the rest only counted; :mod:`brake_env.env.lazy_truth`: a policy that
            never reads it never pays for it, and copying or pickling an info, as SB3's
            vector envs do every step, does not read it; a read costs about one pad life
            simulated, ~0.1 s at the default K, once per pad; Gymnasium's passive env
            checker reads the first two steps' infos whole), so ``info["truth"]["rul_events"]`` and
            ``["life_events"]``, the events' ``rul_events`` column (the oracle reads it)
            and each :class:`~brake_env.env.pads.RetiredPad`'s ``life_left`` and ``life``
            are exact. With False the env simulates only the events it serves, so a
            replacement costs what the pad was used for (exploration, training): those
            fields are None, except that a failed pad's ``life_left`` is 0 and its
            ``life`` the events it braked; the true volume and K are given either way.
        cache_pads: Keep the last this many pads (with the events simulated so far, ~7 MB
            a pad's life at the default K) so that replaying a seed does not simulate its
            pads again; 0 keeps none. A pure speed option: the pads are the same either way.
        pad_pool: Draw every new pad from a fixed pool of this many pads (made from
            ``pad_pool_seed``, shared by all envs of the process with the same settings),
            so each is simulated, and a precomputed predictor run over it, once. For
            training agents on a finite set of pads; 0 (default) draws a fresh pad each
            time.
        pad_pool_seed: Seed of the pool's pads.
    """

    decision_interval: int = 500
    episode_events: int = 500_000
    regime: Literal["id", "ood", "mixed"] = "id"
    ood_share: float = 0.5
    k_mean: float = WearRegime.k_mean
    k_std: float = WearRegime.k_std
    ood_shift_sigma: float = WearRegime.ood_shift_sigma
    costs: CostWeights = field(default_factory=CostWeights)
    noise: SensorNoise = field(default_factory=SensorNoise)
    preset: str = "hot-duty"
    interpolate_layers: bool = False
    truth: bool = True
    cache_pads: int = 0
    pad_pool: int = 0
    pad_pool_seed: int = 0

    def __post_init__(self) -> None:
        plain_numbers(self)
        check_int_fields(ENV_ID, self, (
            ("decision_interval", 1, MAX_DECISION_INTERVAL),
            ("episode_events", 2, 10**9),
            ("cache_pads", 0, 10_000),
            ("pad_pool", 0, 10_000),
            ("pad_pool_seed", 0, 2**63 - 1),
        ))  # fmt: skip
        check_choice(ENV_ID, "preset", self.preset, PRESETS)
        check_types(ENV_ID, self, {"costs": CostWeights, "noise": SensorNoise,
                                   "interpolate_layers": bool, "truth": bool})  # fmt: skip
        self.pad_regime  # validates the regime fields  # noqa: B018

    @property
    def steps_per_episode(self) -> int:
        """Steps until truncation (the reset observes the pad's first event)."""
        return -(-(self.episode_events - 1) // self.decision_interval)

    @classmethod
    def from_kwargs(cls, base: EnvConfig | None = None, **kwargs: Any) -> EnvConfig:
        """``base`` (default config if None) with ``kwargs`` replaced, all validated."""
        nested = {"costs": CostWeights, "noise": SensorNoise}
        return config_from_kwargs(ENV_ID, cls, base, kwargs, nested)

    def to_kwargs(self) -> dict[str, Any]:
        """Every field as JSON-ready keyword arguments: ``from_kwargs(**to_kwargs())`` gives
        this config back (saved beside what was trained or studied on it)."""
        return dataclasses.asdict(self)
