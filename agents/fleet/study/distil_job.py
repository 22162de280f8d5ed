"""What every unit of a distillation (:mod:`.distil`, :mod:`.distil_shared`) shares: the
:class:`Job` (the study, the distillation's settings, the base heuristic; the env, the
planner and the unit keys it builds), labels to and from unit results, and a timer of
decisions."""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.fleet.learning.imitation import Demonstrations
from agents.fleet.policies.rollout import RolloutPolicy
from agents.fleet.policies.view import FleetLayout
from agents.fleet.settings import DistilConfig, FleetStudyConfig
from agents.fleet.study.build import Fitted, rebuild_rule, rul_env
from agents.fleet.study.planners import planner_fields, study_planner
from brake_env.model.atlas import Atlas


@dataclass(frozen=True)
class Job:
    """What every unit of one distillation shares.

    Attributes:
        study: The finished study's settings.
        distil: The distillation's.
        base: The predictor's best tuned heuristic (name, parameters): the planner's base.
    """

    study: FleetStudyConfig
    distil: DistilConfig
    base: tuple[str, dict[str, Any]]

    @property
    def fields(self) -> tuple[str, ...]:
        return planner_fields(self.distil.predictor)

    def layout(self) -> FleetLayout:
        return FleetLayout.of(self.study.fleet, fields=self.fields)

    def env(self, atlas: Atlas, fitted: Fitted | None) -> Any:
        return rul_env(self.study, atlas, self.distil.predictor, fitted, self.fields)

    def rule(self) -> Any:
        """The base rule reading this job's layout (the interval's fields beside the mean)."""
        return rebuild_rule(self.study, *self.base, self.layout())

    def base_input(self) -> Any:
        """The rule whose duties the policy reads (None without ``base_input``)."""
        return self.rule() if self.distil.base_input else None

    def training(self, seed: int) -> Any:
        """A seed's training, spares by the base rule's (s, S) (the planner's order)."""
        p = self.rule().params
        return replace(self.distil.training, seed=seed, reorder=(int(p.s), int(p.S)))

    def planner(self, atlas: Atlas) -> RolloutPolicy:
        return study_planner(self.study, atlas, self.rule())

    def label_key(self, round_: int, chunk: int) -> str:
        return f"labels-{self.distil.predictor}-r{round_}-c{chunk}-{self.distil.digest(False)}"

    def label_keys(self, below: int) -> list[str]:
        return [self.label_key(r, i) for r in range(below)
                for i in range(len(self.distil.label_chunks(r)))]  # fmt: skip

    def seed_key(self, seed: int, kind: str = "central") -> str:
        prefix = "distil" if kind == "central" else f"distil-{kind}"
        return f"{prefix}-{self.distil.predictor}-seed{seed}-{self.distil.digest()}"

    def seed_runs(self) -> list[tuple[str, int]]:
        """(kind, seed) of every trained policy: the central ones, then the shared ones."""
        d = self.distil
        return [("central", s) for s in range(d.seeds)] + [
            ("shared", s) for s in range(d.shared_seeds)]  # fmt: skip

    def keys(self) -> list[str]:
        runs = [self.seed_key(s, kind) for kind, s in self.seed_runs()]
        return self.label_keys(self.distil.label_rounds + 1) + runs


class Timed:
    """A policy whose ``predict`` calls are timed (the decision alone, not the env)."""

    def __init__(self, policy: Any) -> None:
        self.policy, self.seconds, self.calls = policy, 0.0, 0

    def predict(self, observation: Any, *args: Any, **kw: Any) -> Any:
        t0 = time.perf_counter()
        out = self.policy.predict(observation, *args, **kw)
        self.seconds += time.perf_counter() - t0
        self.calls += 1
        return out

    def __repr__(self) -> str:
        return repr(self.policy)


def demo_dict(d: Demonstrations) -> dict[str, NDArray[Any]]:
    """Labels as a unit result (its arrays by field name)."""
    return {f.name: getattr(d, f.name) for f in fields(Demonstrations)}


def demo_of(d: Mapping[str, Any]) -> Demonstrations:
    """:func:`demo_dict` read back."""
    return Demonstrations(**{f.name: np.asarray(d[f.name]) for f in fields(Demonstrations)})
