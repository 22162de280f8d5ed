"""The cost study's work as units of :class:`~brake_env.runner.Runner`: chunks of pads
simulated and run through every predictor, and agents trained (docs/cluster.md,
docs/results/single-pad.md).

A unit's result is a tree the :class:`~brake_env.runner.UnitStore` saves (arrays, numbers,
strings, dicts), so an interrupted study resumes from the units that finished; and it holds
all the driver needs, since a worker's disk need not be the driver's. A pad's events and
estimates depend on the pad alone, and an agent's training on its seed (with one torch
thread), so the figures are the same wherever the units run.
"""

from __future__ import annotations

import json
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path, PurePosixPath
from typing import Any

import numpy as np

from agents.learning.persist import read_agent, write_agent
from agents.learning.train import TrainResult, train_agent
from agents.study.pads import PadDraws, PadSet, collect_pads, concat_pad_sets
from brake_env.env.config import EnvConfig
from brake_env.model.atlas import Atlas
from brake_env.output import atomic_path, write_json
from brake_env.prognostics.protocol import Predictor
from brake_env.runner import Unit
from brake_env.units import UnitStore
from brake_env.units import open_store as units_store

# Pads per unit: two of collect_pads' groups; small enough that a few workers finish
# together (a unit is seconds of work) and an interrupted run loses little.
CHUNK_PADS = 16
UNITS = "units"  # the units' folder in a command's output directory
# A trained agent's files that travel as the header and arrays of agents.learning.persist, or are
# written again by the driver (train.json names the folder); every other file goes as bytes.
_REWRITTEN = ("agent.json", "agent.npz", "train.json")

# progress(key, result): called as each unit finishes (brake_env.runner.Runner.run)
UnitProgress = Callable[[str, Any], object]


# ---------------------------------------------------------------------- pads
def pad_chunks(n: int) -> list[np.ndarray]:
    """Indices of each unit's pads among ``n``: chunks of :data:`CHUNK_PADS`, the last
    one shorter."""
    return [np.arange(i, min(i + CHUNK_PADS, n)) for i in range(0, n, CHUNK_PADS)]


def pad_key(stage: str, i: int) -> str:
    return f"{stage}/pads-{i:04d}"


def pad_units(
    stage: str, draws: PadDraws, atlas: Any, config: EnvConfig, predictors: Any
) -> list[Unit]:
    """:func:`~agents.study.pads.collect_pads` of ``draws`` in chunks, keyed
    ``<stage>/pads-0000``...; ``atlas`` and ``predictors`` as :meth:`Runner.share` gave them."""
    return [
        Unit(pad_key(stage, i), collect_chunk, (draws.subset(c), atlas, config, predictors))
        for i, c in enumerate(pad_chunks(len(draws)))
    ]


def collect_chunk(
    draws: PadDraws, atlas: Atlas, config: EnvConfig, predictors: Mapping[str, Predictor]
) -> dict[str, Any]:
    """A pad unit: the chunk's :class:`PadSet` as a tree."""
    return collect_pads(draws, atlas, config, predictors).to_tree()


def join_pads(stage: str, draws: PadDraws, results: Mapping[str, Any]) -> PadSet:
    """The pad set of every chunk of ``stage`` in ``results``, in order, with the study's
    draws."""
    n = len(pad_chunks(len(draws)))
    parts = [PadSet.from_tree(results[pad_key(stage, i)]) for i in range(n)]
    return replace(concat_pad_sets(parts), draws=draws)


def pad_progress(
    progress: Callable[[str, int], Callable[[int], object]] | None,
    stage: str,
    label: str,
    total: int,
) -> UnitProgress | None:
    """A unit progress callback that advances ``progress(label, total)``'s bar by the pads
    of each chunk of ``stage`` done (other units pass it by)."""
    if progress is None:
        return None
    bar = progress(label, total)

    def advance(key: str, result: Any) -> None:
        if key.startswith(f"{stage}/pads-"):
            bar(len(result["life"]))

    return advance


# ---------------------------------------------------------------------- agents
def agent_key(predictor: str) -> str:
    return f"agent/{predictor}"


@dataclass(frozen=True)
class AgentJob:
    """What an agent unit trains (:func:`~agents.learning.train.train_agent`'s settings).

    Attributes:
        predictor: The predictor whose estimates the agent sees.
        algo: ``ppo`` or ``dqn``.
        timesteps: Training steps.
        seed: Seeds the algorithm and the training envs.
        env: BrakeWear-v0's settings.
        hyperparams: The algorithm's table (None: the predictor's hyperparameter file).
        progress_bar: Show SB3's progress bar (in this process only).
    """

    predictor: str
    algo: str
    timesteps: int
    seed: int
    env: EnvConfig
    hyperparams: dict[str, Any] | None = None
    progress_bar: bool = False


def agent_unit(job: AgentJob, predictors: Any, atlas: Any, curve_pads: Any) -> Unit:
    """The training of ``job`` as a unit (:func:`train_unit`); ``predictors``, ``atlas`` and
    ``curve_pads`` as :meth:`Runner.share` gave them."""
    return Unit(agent_key(job.predictor), train_unit, (job, predictors, atlas, curve_pads))


def train_unit(
    job: AgentJob,
    predictors: Mapping[str, Predictor],
    atlas: Atlas,
    curve_pads: PadSet | None,
) -> dict[str, Any]:
    """An agent unit: :func:`~agents.learning.train.train_agent` of ``job`` in a temporary
    folder, returned as a tree for :func:`write_trained`.

    The tree holds the :class:`~agents.learning.train.TrainResult` (without its folder), the
    saved agent as :func:`~agents.learning.persist.read_agent` gives it (header as JSON,
    arrays), the env's settings, and every other file of the folder as bytes: SB3's
    ``model.zip`` and ``vecnormalize.pkl`` (to resume training; trusted input only), the
    learning curve, the observation statistics and the TensorBoard logs.

    torch runs on one thread here (the hyperparameters' ``torch_threads`` may say
    otherwise), so the agent is the same in this process and on a Ray worker.
    """
    import torch

    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        with tempfile.TemporaryDirectory(prefix="brakewear-agent-") as tmp:
            res = train_agent(
                predictors[job.predictor], atlas, tmp, algo=job.algo, timesteps=job.timesteps,
                seed=job.seed, env=job.env, hyperparams=job.hyperparams, curve_pads=curve_pads,
                progress_bar=job.progress_bar,
            )  # fmt: skip
            header, arrays = read_agent(tmp)
            files = {
                p.relative_to(tmp).as_posix(): np.frombuffer(p.read_bytes(), np.uint8)
                for p in sorted(Path(tmp).rglob("*"))
                if p.is_file() and p.relative_to(tmp).as_posix() not in _REWRITTEN
            }
    finally:
        torch.set_num_threads(threads)  # in this process: as it was
    result = {k: v for k, v in asdict(res).items() if k != "out_dir"}
    # The header as JSON text: it names classes under "$class" keys, which a unit's tree
    # cannot hold (the store reserves "$").
    agent = {"header": json.dumps(header), "arrays": arrays}
    return {"result": result, "agent": agent, "env_kwargs": job.env.to_kwargs(), "files": files}


def write_trained(unit: Mapping[str, Any], out_dir: str | Path) -> TrainResult:
    """Write an agent unit's result as :func:`~agents.learning.train.train_agent` writes its folder
    (``agent.json``, ``agent.npz``, ``train.json`` last, and the other files); the
    :class:`~agents.learning.train.TrainResult` with ``out_dir``.

    Raises:
        ValueError: A file of the unit would land outside ``out_dir``.
    """
    out = Path(out_dir)
    for rel, blob in unit["files"].items():
        parts = PurePosixPath(rel).parts
        if not parts or parts[0] == "/" or ".." in parts:
            raise ValueError(f"agent unit: file {rel!r} would land outside {out}")
        (out / rel).parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(out / rel) as tmp:
            tmp.write_bytes(np.asarray(blob, np.uint8).tobytes())
    write_agent(json.loads(unit["agent"]["header"]), unit["agent"]["arrays"], out)
    result = TrainResult(out_dir=str(out), **unit["result"])
    write_json({**asdict(result), "env_kwargs": unit["env_kwargs"]}, out / "train.json")
    return result


# ---------------------------------------------------------------------- store
def open_store(
    directory: Path, settings: Mapping[str, Any], keys: Sequence[str], command: str = "compare"
) -> UnitStore:
    """The unit store of a run (``settings``: what its results depend on; the chunk size
    and the package version added): :func:`brake_env.units.open_store`.

    Raises:
        ValueError: ``directory`` holds units of a run with other settings, or another
            run is writing there.
    """
    from brake_env.prognostics.persist import package_version

    # The chunking too: the pads of a unit key depend on it.
    version = {"chunk_pads": CHUNK_PADS, "package_version": package_version()}
    return units_store(directory, {**settings, **version}, keys, command)
