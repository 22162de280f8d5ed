"""What ``brakewear fleet-study`` runs (:class:`FleetStudyConfig`), the heuristics' and the
predictors' names it takes."""

from __future__ import annotations

import hashlib
import json
import re
from dataclasses import asdict, dataclass, field
from typing import Any, Literal

from agents.fleet.settings.training import CURVE_SEED0, TUNE_SEED0, FleetTraining
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.fleet_file import FleetFile, read_fleet, shipped_fleets
from brake_env.prognostics.commands.predict_units import model_checksum
from brake_env.prognostics.persist import read_header
from brake_env.prognostics.registry import ORACLE, predictor_names

# The sizes of before the fleet files: their units' settings name the size alone.
SIZES = ("small", "default")
# The heuristics of agents.fleet.evaluation.tuning.SPACES, in its order (tested equal), so
# that the settings and the parser need not import the tuning (Optuna, scipy).
# What the heuristics are tuned on, their best chosen on and the predictors ranked by:
# the headline cost per vehicle-shift, or the net cost (less the pad life left at the end;
# agents.fleet.evaluation.costs.figures).
Objective = Literal["cost", "net"]
OBJECTIVES: tuple[Objective, ...] = ("cost", "net")
HEURISTICS = ("threshold", "time-to-window", "(n, N)", "capacity greedy", "duty rule",
              "(s, S)", "standby", "best combination")  # fmt: skip
DEFAULT_HEURISTICS = ("threshold", "(n, N)", "best combination")
# A predictor named NAME+effect is NAME made on the atlas with the study's effects (the
# diagnosis fed back), as `brakewear backtest --fed-back` names it; NAME alone is made on the
# nominal atlas (its user does not know the effect).
FED_BACK = "+effect"
# Replacement by age alone (agents.fleet.study.interval): the baseline a predictor's value
# is counted from. Like the oracle, nothing is fitted for it.
FIXED_INTERVAL = "fixed-interval"
UNFITTED = (ORACLE, FIXED_INTERVAL)
# A user's model's name (--model NAME=DIR): a word, as unit keys and tables take it.
MODEL_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_.-]{0,39}")


def study_predictor_names() -> tuple[str, ...]:
    """The registry's predictors, but for the oracle's their fed-back versions, and the
    fixed interval."""
    names = predictor_names()
    return (*names, *(n + FED_BACK for n in names if n != ORACLE), FIXED_INTERVAL)


def check_model(name: str, path: str) -> None:
    """A user's saved model ``NAME=DIR`` as a study takes it: a name of its own (no
    registered predictor's) and a model directory ``brakewear fit`` wrote.

    Raises:
        ValueError: The name or the directory, named.
    """
    if not isinstance(name, str) or not MODEL_NAME.fullmatch(name):
        raise ValueError(f"model {name!r}: a name is a letter then up to 39 letters, digits"
                         " or _ . -")  # fmt: skip
    if name in study_predictor_names():
        raise ValueError(f"model {name!r}: the name of a registered predictor; give the model"
                         " a name of its own (--model MINE=DIR)")  # fmt: skip
    try:
        read_header(path)
    except (FileNotFoundError, ValueError) as e:
        raise ValueError(f"model {name!r}: {e}") from None


@dataclass(frozen=True)
class FleetStudyConfig:
    """What the fleet study runs.

    Attributes:
        size: The fleet: a shipped fleet's name (``small``: SMALL_FLEET, 2 vehicles, the
            reference's size; ``default``: the env's 12 vehicles; ``default-mixed``,
            ``large``; :func:`~brake_env.env.fleet.fleet_file.shipped_fleets`) or a fleet
            file's path (:mod:`~brake_env.env.fleet.fleet_file`). Its ``episode_shifts`` is
            replaced by ``shifts``. The perfect-information reference runs on 2 vehicles.
        shifts: Shifts an episode.
        predictors: Predictors whose RUL the heuristics (and agents) act on (names of the
            registry, :func:`~brake_env.prognostics.registry.predictor_names`; all by default).
        heuristics: Heuristics tuned per predictor (:data:`HEURISTICS`).
        trials: Optuna trials per heuristic; ``trials_best`` for the best combination
            (8 parameters, not 1-3).
        tune_episodes: Tuning episodes (seeds from 10,000).
        eval_episodes: Evaluation episodes (seeds ``episodes_from``..), the same for every
            policy.
        episodes_from: The first evaluation episode's seed (0: the episodes every earlier
            study and design choice used; a suite's sealed test split starts elsewhere).
        n_train_runs: Run-to-failure pads the predictors are fitted on.
        agent_predictors: Predictors given a MaskablePPO agent.
        agent_seeds: Training seeds per agent predictor.
        shared_seeds: Training seeds of the parameter-shared PPO (one policy per vehicle,
            :mod:`agents.fleet.learning.shared`; spares by the teacher's (s, S)) per agent
            predictor; 0: none.
        training: The agents' settings (its ``seed`` is replaced by each training seed);
            with ``imitation_episodes`` > 0 each agent starts by cloning its predictor's
            best tuned heuristic (behaviour cloning, then PPO).
        curve_episodes, curve_every: The learning curve: cost on that many episodes
            (seeds from 20,000) every ``curve_every`` shifts of training.
        tail: Shifts beyond the episode the reference's program looks ahead.
        seed: Seed of the predictors' fits and of the tuning samplers.
        rollout_predictors: Predictors given the rollout planner on their best tuned
            heuristic (:mod:`agents.fleet.policies.rollout`); its evaluation episodes run
            as units of ``rollout_chunk`` episodes.
        rollout_horizon, rollout_samples: The planner's shifts simulated per candidate and
            sampled futures.
        rollout_chunk: Evaluation episodes per rollout unit.
        rollout_seed: Seed of the planner's sampled futures (None: ``seed``, as before it
            could be set apart from the fits').
        bound_iterations: Price vectors the Lagrangian bound's search tries (0: no bound);
            with the bound, the price-directed policy runs on the evaluation episodes too.
        objective: What the heuristics are tuned on, the best heuristic is chosen on, the
            predictors are ranked by and the rollout is compared with its base on:
            ``cost`` (the headline) or ``net`` (:data:`OBJECTIVES`). Every row reports both.
        effects: Unmodelled effects the fleet's pads wear with, canonical ``NAME:P=V,...``
            (:mod:`brake_env.model.effects`): the env, the oracle and the predictors' training
            pads are on the atlas with them (the truth); each predictor is made on the nominal
            atlas, ``NAME+effect`` (:data:`FED_BACK`) on the truth's.
            Empty: no effect, the study as it was.
        models: A user's saved models (``brakewear fit --out DIR``) as (NAME, DIR): each is
            loaded instead of fitted and ranked among the predictors (NAME is added to
            ``predictors`` if not there); its checksum is in the settings.
    """

    size: str = "small"
    shifts: int = 365
    predictors: tuple[str, ...] = field(default_factory=predictor_names)
    heuristics: tuple[str, ...] = DEFAULT_HEURISTICS
    trials: int = 15
    trials_best: int = 45
    tune_episodes: int = 3
    eval_episodes: int = 40
    episodes_from: int = 0
    n_train_runs: int = 10
    agent_predictors: tuple[str, ...] = ()
    agent_seeds: int = 10
    shared_seeds: int = 0
    training: FleetTraining = field(default_factory=FleetTraining)
    curve_episodes: int = 2
    curve_every: int = 20_000
    tail: int = 200
    seed: int = 0
    rollout_predictors: tuple[str, ...] = ()
    rollout_horizon: int = 28
    rollout_samples: int = 16
    rollout_chunk: int = 5
    rollout_seed: int | None = None
    bound_iterations: int = 0
    objective: Objective = "cost"
    effects: tuple[str, ...] = ()
    models: tuple[tuple[str, str], ...] = ()

    def __post_init__(self) -> None:
        if not isinstance(self.size, str) or not self.size:
            shipped = ", ".join(shipped_fleets())
            raise ValueError(f"FleetStudyConfig: size must be a fleet's name or file, got"
                             f" {self.size!r} (shipped: {shipped})")  # fmt: skip
        self.fleet  # noqa: B018  (read now: a bad fleet file is refused here, named)
        if (
            isinstance(self.episodes_from, bool)
            or not isinstance(self.episodes_from, int)
            or (not 0 <= self.episodes_from <= 2**31)
        ):
            raise ValueError(f"FleetStudyConfig: episodes_from must be an integer in"
                             f" [0, 2**31], got {self.episodes_from!r}")  # fmt: skip
        bad = [h for h in self.heuristics if h not in HEURISTICS]
        if bad or not self.heuristics:
            raise ValueError(
                f"FleetStudyConfig: unknown heuristic(s) {bad}; known {list(HEURISTICS)}"
            )
        self._check_models()
        known = (*study_predictor_names(), *self.model_names)
        bad = [p for p in self.predictors if p not in known]
        if bad or not self.predictors:
            raise ValueError(
                f"FleetStudyConfig: predictors must be among {list(known)},"
                f" got {list(self.predictors)}"
            )
        self._check_effects()
        missing = [p for p in self.agent_predictors + self.rollout_predictors
                   if p not in self.predictors]  # fmt: skip
        if missing:
            raise ValueError(
                f"FleetStudyConfig: agent or rollout predictor(s) {missing} are not among the"
                f" predictors {self.predictors} (each is compared with its predictor's"
                " heuristics)"
            )
        for name in ("shifts", "trials", "trials_best", "tune_episodes", "n_train_runs",
                     "curve_episodes", "curve_every", "rollout_horizon", "rollout_samples",
                     "rollout_chunk"):  # fmt: skip
            if int(getattr(self, name)) < 1:
                raise ValueError(
                    f"FleetStudyConfig: {name} must be >= 1, got {getattr(self, name)}"
                )
        if self.rollout_seed is not None and not 0 <= int(self.rollout_seed) < 2**31:
            raise ValueError(f"FleetStudyConfig: rollout_seed must be in [0, 2**31), got"
                             f" {self.rollout_seed}")  # fmt: skip
        if min(self.agent_seeds, self.shared_seeds, self.bound_iterations) < 0:
            raise ValueError(f"FleetStudyConfig: agent_seeds, shared_seeds and bound_iterations"
                             f" must be >= 0, got {self.agent_seeds}, {self.shared_seeds} and"
                             f" {self.bound_iterations}")  # fmt: skip
        if self.objective not in OBJECTIVES:
            raise ValueError(
                f"FleetStudyConfig: objective must be one of {OBJECTIVES}, got {self.objective!r}"
            )
        if self.eval_episodes < 2:
            raise ValueError(
                f"FleetStudyConfig: eval_episodes must be >= 2 (paired intervals),"
                f" got {self.eval_episodes}"
            )

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> FleetStudyConfig:
        """The config a study wrote (``costs.json``'s ``config``: :func:`dataclasses.asdict`
        with the derived ``fleet``)."""
        d = {k: v for k, v in d.items() if k != "fleet"}
        tr = dict(d.get("training", {}))
        if "net_arch" in tr:
            tr["net_arch"] = tuple(tr["net_arch"])
        if tr.get("reorder") is not None:
            tr["reorder"] = tuple(tr["reorder"])
        tuples = ("predictors", "heuristics", "agent_predictors", "rollout_predictors", "effects")
        models = tuple((str(n), str(p)) for n, p in d.get("models", ()))
        return cls(**{**d, **{k: tuple(d[k]) for k in tuples if k in d},
                      "training": FleetTraining(**tr), "models": models})  # fmt: skip

    def _check_models(self) -> None:
        """Each model named once, by a name of its own, a model directory; its name joins
        the predictors (a config read back from ``costs.json`` has it there already)."""
        if not isinstance(self.models, tuple) or not all(
            isinstance(m, tuple) and len(m) == 2 for m in self.models
        ):
            raise ValueError(f"FleetStudyConfig: models must be a tuple of (NAME, DIR),"
                             f" got {self.models!r}")  # fmt: skip
        names = self.model_names
        if len(set(names)) < len(names):
            raise ValueError(f"FleetStudyConfig: a model name given twice in {list(names)}")
        for name, path in self.models:
            check_model(name, path)
        extra = tuple(n for n in names if n not in self.predictors)
        object.__setattr__(self, "predictors", (*self.predictors, *extra))

    @property
    def model_names(self) -> tuple[str, ...]:
        return tuple(n for n, _ in self.models)

    def model_dir(self, name: str) -> str:
        return dict(self.models)[name]

    @property
    def fleet_file(self) -> FleetFile:
        """The fleet file (its currency and shifts a year), episodes as the study's."""
        return read_fleet(self.size, episode_shifts=self.shifts, truth=False)

    @property
    def fleet(self) -> FleetConfig:
        return self.fleet_file.config

    @property
    def has_reference(self) -> bool:
        return self.fleet.n_vehicles == 2

    def eval_seeds(self) -> list[int]:
        return list(range(self.episodes_from, self.episodes_from + self.eval_episodes))

    def tune_seeds(self) -> list[int]:
        return list(range(TUNE_SEED0, TUNE_SEED0 + self.tune_episodes))

    def curve_seeds(self) -> list[int]:
        return list(range(CURVE_SEED0, CURVE_SEED0 + self.curve_episodes))

    def settings(self) -> dict[str, Any]:
        """What every unit's result depends on (the unit store refuses other settings);
        each unit's own parameters are in its key."""
        return {"size": self.size, "shifts": self.shifts, "eval_episodes": self.eval_episodes,
                "tune_episodes": self.tune_episodes, "n_train_runs": self.n_train_runs,
                "seed": self.seed, "objective": self.objective,
                **({"effects": list(self.effects)} if self.effects else {}),
                **self._fleet_settings()}  # fmt: skip

    def _fleet_settings(self) -> dict[str, Any]:
        """A fleet other than the two sizes of before, and a moved evaluation split, enter
        the settings (the fleet by its content's digest, so an edited file is another
        study); the settings of before are unchanged for those."""
        out: dict[str, Any] = {}
        if self.size not in SIZES:
            out["fleet"] = read_fleet(self.size).digest
        if self.episodes_from:
            out["episodes_from"] = self.episodes_from
        if self.models:  # units are of the model's very bytes (its header names its arrays')
            out["models"] = {n: model_checksum(p) for n, p in self.models}
        return out

    def _check_effects(self) -> None:
        if not isinstance(self.effects, tuple) or not all(
            isinstance(e, str) and e.strip() for e in self.effects
        ):
            raise ValueError(f"FleetStudyConfig: effects must be a tuple of effect texts"
                             f" NAME:P=V, got {self.effects!r}")  # fmt: skip
        fed = [p for p in self.predictors if p.endswith(FED_BACK)]
        if fed and not self.effects:
            raise ValueError(f"FleetStudyConfig: predictor(s) {fed} are made on the atlas with"
                             " the study's effects, and it has none (--effect)")  # fmt: skip

    def physics_tag(self) -> str:
        """Every stored unit's key ends with it: ``-fx`` and a digest of the effects (empty
        without effects: the keys are those of before), so that no unit of other physics
        is ever taken for this study's."""
        if not self.effects:
            return ""
        return "-fx" + hashlib.sha256(json.dumps(list(self.effects)).encode()).hexdigest()[:8]

    def trials_of(self, heuristic: str) -> int:
        return self.trials_best if heuristic == "best combination" else self.trials

    def heuristic_key(self, predictor: str, heuristic: str) -> str:
        return f"heuristic-{predictor}-{heuristic}-t{self.trials_of(heuristic)}{self.physics_tag()}"

    def agent_runs(self) -> list[tuple[str, str, int]]:
        """(kind, predictor, seed) of every agent: ``central`` then ``shared``."""
        return [(kind, p, s) for kind, n in (("central", self.agent_seeds),
                                             ("shared", self.shared_seeds))
                for p in self.agent_predictors for s in range(n)]  # fmt: skip

    def rollout_chunks(self) -> list[list[int]]:
        """The evaluation seeds, ``rollout_chunk`` to a rollout unit."""
        seeds, k = self.eval_seeds(), self.rollout_chunk
        return [seeds[i : i + k] for i in range(0, len(seeds), k)]

    def rollout_key(self, predictor: str, chunk: int) -> str:
        """A rollout unit's key; its base (the best heuristic) depends on which were tuned."""
        base = json.dumps([sorted(self.heuristics), self.trials, self.trials_best])
        digest = hashlib.sha256(base.encode()).hexdigest()[:8]
        seed = "" if self.rollout_seed is None else f"-p{self.rollout_seed}"
        return (f"rollout-{predictor}-h{self.rollout_horizon}-s{self.rollout_samples}"
                f"-c{self.rollout_chunk}{seed}-{chunk}-{digest}{self.physics_tag()}")  # fmt: skip

    @property
    def planner_seed(self) -> int:
        """The rollout planner's seed (:attr:`rollout_seed`, else :attr:`seed`)."""
        return self.seed if self.rollout_seed is None else int(self.rollout_seed)

    def bound_key(self) -> str:
        return f"bound-i{self.bound_iterations}{self.physics_tag()}"

    def reference_key(self) -> str:
        return f"reference-tail{self.tail}{self.physics_tag()}"

    def agent_key(self, predictor: str, seed: int, kind: str = "central") -> str:
        spec = {"training": asdict(self.training),
                "curve": [self.curve_episodes, self.curve_every]}  # fmt: skip
        digest = hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()[:10]
        prefix = "agent" if kind == "central" else f"agent-{kind}"
        return f"{prefix}-{predictor}-seed{seed}-{digest}{self.physics_tag()}"
