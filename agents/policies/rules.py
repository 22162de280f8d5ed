"""Rule-based replacement policies with Stable-Baselines3's ``predict`` signature, so a rule
and a trained agent are evaluated by the same function; and :class:`PolicyId`, the name of a
policy in the cost comparison."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Literal, Protocol, get_args, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from brake_env.env.brake_wear import KEEP, OBS_NAMES, REPLACE

AGE_INDEX = OBS_NAMES.index("events_since_install")
RUL_INDEX = len(OBS_NAMES)  # the first field RULObservation appends: rul_mean


@runtime_checkable
class Policy(Protocol):
    """Anything with SB3's ``predict``: a rule below or a trained SB3 model."""

    def predict(
        self,
        observation: NDArray[Any],
        state: tuple[NDArray[Any], ...] | None = None,
        episode_start: NDArray[np.bool_] | None = None,
        deterministic: bool = False,
    ) -> tuple[NDArray[Any], tuple[NDArray[Any], ...] | None]: ...


class _Rule:
    """A stateless rule: replace where ``_replace(obs)`` is true, for one obs or a batch."""

    def predict(
        self,
        observation: NDArray[Any],
        state: tuple[NDArray[Any], ...] | None = None,
        episode_start: NDArray[np.bool_] | None = None,
        deterministic: bool = False,
    ) -> tuple[NDArray[Any], tuple[NDArray[Any], ...] | None]:
        obs = np.asarray(observation)
        batch = np.atleast_2d(obs)
        actions = np.where(self._replace(batch), REPLACE, KEEP).astype(np.int64)
        return (actions if obs.ndim == 2 else actions[0]), state

    def _replace(self, obs: NDArray[Any]) -> NDArray[np.bool_]:
        raise NotImplementedError


class ReplaceOnFailure(_Rule):
    """Never replace: the pad runs until it fails (corrective maintenance only)."""

    def _replace(self, obs: NDArray[Any]) -> NDArray[np.bool_]:
        return np.zeros(len(obs), dtype=bool)

    def __repr__(self) -> str:
        return "ReplaceOnFailure()"


class FixedInterval(_Rule):
    """Replace once the pad has braked ``interval_events`` times (time-based maintenance).

    Args:
        interval_events: Pad age at which to replace [events], > 0.
        age_index: Where the observation holds the pad's age (BrakeWear-v0's layout).
    """

    def __init__(self, interval_events: float, age_index: int = AGE_INDEX) -> None:
        if not interval_events > 0:
            raise ValueError(f"FixedInterval: interval_events must be > 0, got {interval_events}")
        self.interval_events = float(interval_events)
        self.age_index = age_index

    def _replace(self, obs: NDArray[Any]) -> NDArray[np.bool_]:
        return obs[:, self.age_index] >= self.interval_events

    def __repr__(self) -> str:
        return f"FixedInterval({self.interval_events:g})"


class RULThreshold(_Rule):
    """Replace when the estimated RUL falls below ``threshold_events`` (predictive maintenance).

    With the true RUL and a threshold of one decision interval this never fails: a pad is
    replaced exactly when it could not finish the next step.

    Args:
        threshold_events: Replace below this estimated RUL [events], >= 0.
        rul_index: Where the observation holds the RUL estimate (``RULObservation`` appends
            it after BrakeWear-v0's fields).
    """

    def __init__(self, threshold_events: float, rul_index: int = RUL_INDEX) -> None:
        if not threshold_events >= 0:
            raise ValueError(f"RULThreshold: threshold_events must be >= 0, got {threshold_events}")
        self.threshold_events = float(threshold_events)
        self.rul_index = rul_index

    def _replace(self, obs: NDArray[Any]) -> NDArray[np.bool_]:
        if obs.shape[1] <= self.rul_index:
            raise ValueError(
                f"RULThreshold: observation has {obs.shape[1]} fields, no RUL estimate at"
                f" index {self.rul_index}; wrap the env in RULObservation"
            )
        return obs[:, self.rul_index] < self.threshold_events

    def __repr__(self) -> str:
        return f"RULThreshold({self.threshold_events:g})"


PolicyKind = Literal[
    "threshold", "lower-threshold", "agent", "fixed-interval", "replace-on-failure", "oracle"
]
_WITH_PREDICTOR = ("threshold", "lower-threshold", "agent")
_TUNED = ("threshold", "lower-threshold", "fixed-interval")


@dataclass(frozen=True)
class PolicyId:
    """Which policy a row of the cost comparison is (docs/results/single-pad.md);
    its :attr:`label` names it in tables, figures and ``costs.json``.

    Attributes:
        kind: ``threshold`` (:class:`RULThreshold` on a predictor's point estimate),
            ``lower-threshold`` (on the lower bound of its interval), ``agent`` (an SB3
            agent trained on its estimates), ``fixed-interval`` (:class:`FixedInterval`),
            ``replace-on-failure`` or ``oracle`` (the true RUL, one decision interval).
        predictor: Whose RUL estimates a threshold or agent policy acts on.
        algo: The agent's algorithm (``ppo`` or ``dqn``).
        parameter: A tuning candidate's threshold or replacement age [events]; ``0`` for a
            threshold and ``inf`` for an age are "never replace" (replace-on-failure, the
            fallback every tuning may choose). None for a policy family (its parameter
            tuned) and for policies without one.
    """

    kind: PolicyKind
    predictor: str | None = None
    algo: str | None = None
    parameter: float | None = None

    def __post_init__(self) -> None:
        kinds = get_args(PolicyKind)
        if self.kind not in kinds:
            raise ValueError(f"PolicyId: kind must be one of {kinds}, got {self.kind!r}")
        if (self.predictor is not None) != (self.kind in _WITH_PREDICTOR):
            raise ValueError(
                "PolicyId: threshold and agent policies, and only they, have a predictor;"
                f" got {self.predictor!r} for {self.kind}"
            )
        if (self.algo is not None) != (self.kind == "agent"):
            raise ValueError(
                f"PolicyId: agents, and only they, have an algo; got {self.algo!r} for {self.kind}"
            )
        if self.parameter is not None and self.kind not in _TUNED:
            raise ValueError(f"PolicyId: a {self.kind} policy has no parameter")

    @property
    def family(self) -> PolicyId:
        """The policy with its parameter left to tuning."""
        return replace(self, parameter=None)

    @property
    def tuned(self) -> bool:
        """A policy family whose parameter is tuned."""
        return self.kind in _TUNED

    @property
    def never(self) -> bool:
        """A candidate that never replaces (replace-on-failure)."""
        p = self.parameter
        return p is not None and (p == 0.0 if self.kind != "fixed-interval" else p == np.inf)

    @property
    def label(self) -> str:
        """``<predictor>/threshold``, ``<predictor>/lower-threshold``, ``<predictor>/<algo>``,
        ``fixed-interval``, ... and a candidate's parameter after a slash:
        ``twin/threshold/1000``, ``fixed-interval/never``."""
        head = {"agent": f"{self.predictor}/{self.algo}"}
        name = head.get(self.kind, f"{self.predictor}/{self.kind}" if self.predictor else self.kind)
        if self.parameter is None:
            return name
        p = self.parameter
        if self.never:
            return f"{name}/never"
        return f"{name}/{int(p) if float(p).is_integer() else format(p, 'g')}"

    def __str__(self) -> str:
        return self.label


ORACLE = PolicyId("oracle")
REPLACE_ON_FAILURE = PolicyId("replace-on-failure")
FIXED_INTERVAL = PolicyId("fixed-interval")
# The estimate field a threshold family acts on.
ESTIMATE_FIELD = {"threshold": "rul_mean", "lower-threshold": "rul_lower"}
