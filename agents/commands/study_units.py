"""The units of ``brakewear compare`` run by a :class:`~brake_env.runner.Runner`: the tuning
pads in chunks; then the agents, trained while the held-out pads are simulated; each unit
kept in ``<out>/units`` so that an interrupted comparison resumes (docs/cluster.md,
docs/results/single-pad.md)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from agents.commands.units import (
    UNITS,
    AgentJob,
    UnitProgress,
    agent_key,
    agent_unit,
    join_pads,
    open_store,
    pad_chunks,
    pad_key,
    pad_progress,
    pad_units,
    write_trained,
)
from agents.learning.curve import agent_outcomes
from agents.learning.hyperparameters import load_hyperparams
from agents.learning.train import TrainedAgent, agent_fields
from agents.policies.rules import PolicyId
from agents.study.config import StudyConfig
from agents.study.pads import PadDraws, PadSet
from agents.study.results import AgentRuns
from brake_env.model.atlas import Atlas
from brake_env.prognostics.protocol import Predictor
from brake_env.runner import Runner, Unit, UnitStore

# progress(label, total) returns a callback advanced by the units done.
Progress = Callable[[str, int], Callable[[int], object]]

STUDY_SETS = {"tune": 1, "evaluate": 2}  # seed keys of the tuning and the held-out pads


def study_draws(config: StudyConfig, seed: int, which: str) -> PadDraws:
    """The tuning (``which="tune"``) or the held-out pads (``"evaluate"``). Their seeds
    never overlap (and neither meets an agent's training pads, drawn by the env from its
    own seeds)."""
    n = config.tune_pads if which == "tune" else config.eval_pads
    return PadDraws.stratified(config.env.pad_regime, n, [seed, STUDY_SETS[which]])


class CompareUnits:
    """The units of a comparison: chunks of tuning pads; then the agents, trained while
    the chunks of held-out pads are simulated."""

    def __init__(
        self,
        config: StudyConfig,
        seed: int,
        out_dir: Path,
        hyperparams: Mapping[str, dict[str, Any]] | None,
    ) -> None:
        self.config, self.seed, self.out_dir, self.hyperparams = config, seed, out_dir, hyperparams
        self.draws = {w: study_draws(config, seed, w) for w in STUDY_SETS}
        self.skipped = _skipped_agents(config)
        self.agents = () if self.skipped is not None else config.agent_predictors

    def keys(self) -> list[str]:
        """Every unit's key."""
        chunks = {w: len(pad_chunks(len(d))) for w, d in self.draws.items()}
        pads = [pad_key(w, i) for w, n in chunks.items() for i in range(n)]
        return [*pads, *(agent_key(n) for n in self.agents)]

    def store(self, atlas: Atlas, fitted: Mapping[str, Predictor] | None) -> UnitStore:
        """The store in ``out_dir/units``; its settings are what the units depend on."""
        hp = dict(self.hyperparams or {})
        settings = {
            **self.config.to_dict(),
            "seed": self.seed,
            "atlas": atlas.content_hash,
            "hyperparams": {
                n: hp.get(n) or load_hyperparams(n, self.config.algo) for n in self.agents
            },
            # fitted by the caller: the store cannot tell them apart (fit here when resuming)
            "fitted_by_caller": sorted(fitted or ()),
        }
        return open_store(self.out_dir / UNITS, settings, self.keys())

    def run(
        self,
        runner: Runner,
        store: UnitStore | None,
        atlas: Atlas,
        predictors: Mapping[str, Predictor],
        progress: Progress | None,
    ) -> tuple[PadSet, PadSet, AgentRuns]:
        """The tuning pads, the held-out pads and the agents."""
        env_config = self.config.env
        atlas_ref, used = runner.share(atlas), runner.share(dict(predictors))

        def units(which: str) -> list[Unit]:
            return pad_units(which, self.draws[which], atlas_ref, env_config, used)

        def bar(which: str) -> Any:
            return pad_progress(progress, which, f"{which} pads", len(self.draws[which]))

        if not self.agents:  # nothing waits for the tuning pads: every chunk at once
            bars = [bar("tune"), bar("evaluate")]
            done = runner.run([*units("tune"), *units("evaluate")], store, _both(bars))
            pads = (join_pads(w, self.draws[w], done) for w in STUDY_SETS)
            return next(pads), next(pads), self.skipped or AgentRuns()
        tune_set = join_pads(
            "tune", self.draws["tune"], runner.run(units("tune"), store, bar("tune"))
        )
        curve = runner.share(tune_set)
        training = agent_units(self.config, used, atlas_ref, curve, self.seed, self.hyperparams)
        # The agents train while the held-out pads are simulated (submitted first: they take
        # longest).
        done = runner.start([*training, *units("evaluate")], store)(bar("evaluate"))
        eval_set = join_pads("evaluate", self.draws["evaluate"], done)
        trained = {n: done[agent_key(n)] for n in self.agents}
        runs = agent_runs(self.config, predictors, trained, eval_set, self.out_dir)
        return tune_set, eval_set, runs


def _skipped_agents(config: StudyConfig) -> AgentRuns | None:
    """Why no agent is trained, when the budget is too small to (None: they are)."""
    if config.timesteps >= config.min_timesteps:
        return None
    why = (
        f"not trained: {config.timesteps:,} steps is too small a budget"
        f" (it needs {config.min_timesteps:,} or more to learn)"
    )
    return AgentRuns(
        skipped={PolicyId("agent", n, algo=config.algo): why for n in config.agent_predictors}
    )


def _both(callbacks: list[UnitProgress | None]) -> UnitProgress:
    def call(key: str, result: Any) -> None:
        for c in callbacks:
            if c is not None:
                c(key, result)

    return call


def agent_units(
    config: StudyConfig,
    predictors: Any,
    atlas: Any,
    curve_pads: Any,
    seed: int,
    hyperparams: Mapping[str, dict[str, Any]] | None = None,
) -> list[Unit]:
    """The training of each agent of a comparison as a unit keyed ``agent/<predictor>``
    (the best checkpoint on ``curve_pads``, the tuning pads, kept); ``predictors``,
    ``atlas`` and ``curve_pads`` as :meth:`~brake_env.runner.Runner.share` gave them."""
    hp = hyperparams or {}
    c = config
    return [
        agent_unit(
            AgentJob(n, c.algo, c.timesteps, seed, c.env, hp.get(n)), predictors, atlas, curve_pads
        )
        for n in c.agent_predictors
    ]


def agent_runs(
    config: StudyConfig,
    predictors: Mapping[str, Predictor],
    trained: Mapping[str, Any],
    eval_pads: PadSet,
    out_dir: Path,
) -> AgentRuns:
    """The agents of :func:`agent_units`' results ``trained`` (by predictor) written to
    ``out_dir/agents/<predictor>``, and each evaluated on ``eval_pads``."""
    runs = AgentRuns()
    for name, unit in trained.items():
        res = write_trained(unit, out_dir / "agents" / name)
        runs.seconds[name] = res.seconds
        runs.curves[name] = res.curve
        pid = PolicyId("agent", name, algo=config.algo)
        fields = agent_fields(predictors[name])
        agent = TrainedAgent(res.out_dir)
        runs.outcomes[pid] = agent_outcomes(agent, name, eval_pads, fields, config.episode_events)
    return runs
