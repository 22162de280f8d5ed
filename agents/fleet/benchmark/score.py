"""Score a policy on a suite's test split against the shipped baselines and the bound
(``brakewear fleet-score``; in Python :func:`score`).

The policy acts on the suite's fleet env with the suite's ``observe`` predictor's RUL
appended (mean, hot and mild route, per vehicle, in shifts: the observation the shipped
rules act on), and is made by ``FACTORY(env)``. What it returns may be an object with SB3's
``predict`` (with an ``action_masks`` parameter, as sb3-contrib's MaskablePPO has, it is
given the env's masks), a callable from observation to action, or a PettingZoo per-agent
policy (a callable of (observation, agent), or a mapping of agent to callable), driven
through the fleet's PettingZoo Parallel env on the same episodes
(:mod:`agents.fleet.benchmark.per_agent`). Every action is checked against the env's mask.
The baselines are read from the suite's shipped file, never rerun;
each is paired with the policy on the test episodes they share (a moved test split shares
none: re-score a baseline there as ``baseline:NAME``).
"""

from __future__ import annotations

import importlib
import importlib.util
import inspect
import os
import sys
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from agents.fleet.benchmark.baselines import BASELINES_DIR, read_baselines, rebuild
from agents.fleet.benchmark.distilled import MeanEpisode, SeedMean
from agents.fleet.benchmark.per_agent import PerAgent, is_per_agent
from agents.fleet.benchmark.suite import Suite
from agents.fleet.evaluation.costs import EpisodeCost, paired_interval, run_episode
from agents.fleet.study.build import rul_env
from agents.fleet.study.units import study_fit
from brake_env.model.atlas import Atlas
from brake_env.prognostics.registry import ORACLE

BASELINE = "baseline:"


def load_factory(spec: str) -> Callable[[Any], Any]:
    """``MODULE:FACTORY`` (a module importable from here or the working folder) or
    ``PATH.py:FACTORY`` imported.

    Raises:
        ValueError: Not of that form, the module or the name not found (named).
    """
    module, sep, name = spec.rpartition(":")
    if not sep or not module or not name:
        raise ValueError(f"--policy {spec!r}: expected MODULE:FACTORY or baseline:NAME")
    try:
        mod = _import(module)
    except (ImportError, OSError, SyntaxError) as e:
        raise ValueError(f"--policy {spec!r}: cannot import {module!r} ({e})") from None
    factory = getattr(mod, name, None)
    if not callable(factory):
        raise ValueError(f"--policy {spec!r}: {module} has no callable {name!r}")
    return factory


def _import(module: str) -> Any:
    """A module by name (the working folder on the path, as ``python -m`` has it) or a
    ``.py`` file by path."""
    if module.endswith(".py"):
        spec = importlib.util.spec_from_file_location(Path(module).stem, module)
        if spec is None or spec.loader is None or not Path(module).is_file():
            raise ImportError(f"no such file {module}")
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        return mod
    if os.getcwd() not in sys.path:
        sys.path.append(os.getcwd())
    return importlib.import_module(module)


class Adapted:
    """A scored policy as the episode runner drives it (SB3's ``predict``).

    Args:
        policy: An object with ``predict`` (given ``action_masks=`` if it takes them), or
            a callable from observation to action.
        env: The env it acts on (for the masks).
    """

    def __init__(self, policy: Any, env: Any) -> None:
        self.policy, self.env = policy, env
        if hasattr(policy, "predict"):
            params = inspect.signature(policy.predict).parameters
            self.kind = "predict, masked" if "action_masks" in params else "predict"
        elif callable(policy):
            self.kind = "callable"
        else:
            raise ValueError(f"the factory returned {type(policy).__name__}: neither an"
                             " object with predict() nor a callable")  # fmt: skip
        self.name = getattr(policy, "name", type(policy).__name__)

    def predict(self, obs: Any, deterministic: bool = True) -> tuple[Any, None]:
        if self.kind == "callable":
            return np.asarray(self.policy(obs)), None
        kw = {"action_masks": self.env.unwrapped.action_masks()} if "masked" in self.kind else {}
        action, _ = self.policy.predict(obs, deterministic=deterministic, **kw)
        return np.asarray(action), None


def score(
    suite: Suite, policy: str | Callable[[Any], Any], atlas: Atlas, *,
    episodes_from: int | None = None, episodes: int | None = None,
    baselines: dict[str, Any] | None = None, progress: Any = None,
    baselines_dir: Path = BASELINES_DIR,
) -> dict[str, Any]:  # fmt: skip
    """``policy`` (``baseline:NAME``, ``MODULE:FACTORY`` or a factory) on ``suite``'s test
    split (moved to ``episodes_from``; its first ``episodes``), paired with each baseline
    (default: the shipped ones; a distilled one's agents are read from ``baselines_dir``)
    and the bound; ``score.json``'s content.

    Raises:
        ValueError: An unknown baseline, a factory that cannot be loaded, a policy that
            breaks the env's mask (naming the shift).
    """
    config = suite.study_config("test", episodes_from)
    if episodes is not None:
        if not 2 <= episodes <= config.eval_episodes:
            raise ValueError(f"--episodes must be in [2, {config.eval_episodes}], got {episodes}")
        config = replace(config, eval_episodes=episodes)
    shipped = read_baselines(suite) if baselines is None else baselines
    env, adapted, label = suite_policy(suite, policy, atlas, config, shipped, baselines_dir)
    seeds = config.eval_seeds()
    eps: list[EpisodeCost | MeanEpisode] = []
    for seed in seeds:
        if isinstance(adapted, PerAgent | SeedMean):
            eps.append(adapted.run(seed))
        else:
            eps.append(run_episode(env, adapted, seed, check_masks=True))
        if progress is not None:
            progress.update(1)
    net = [e.net for e in eps]
    out: dict[str, Any] = {
        "policy": label, "suite": suite.name, "suite_digest": suite.digest,
        "objective": suite.objective, "observe": suite.observe,
        "net": float(np.mean(net)), "cost": float(np.mean([e.per_vehicle_shift for e in eps])),
        "episodes": {"seed": seeds, "net": net, "cost": [e.per_vehicle_shift for e in eps]},
    }  # fmt: skip
    out.update(compare(seeds, net, shipped))
    return out


def suite_policy(
    suite: Suite, policy: str | Callable[[Any], Any], atlas: Atlas, config: Any,
    shipped: dict[str, Any] | None, baselines_dir: Path = BASELINES_DIR,
) -> tuple[Any, Adapted | PerAgent | SeedMean, str]:  # fmt: skip
    """(env, the adapted policy, its label) of ``policy`` (as :func:`score` takes it) on
    ``config``'s episodes of ``suite``: what an analysis runs a policy the benchmark way by."""
    if isinstance(policy, str) and policy.startswith(BASELINE):
        name = policy.removeprefix(BASELINE)
        known = (shipped or {}).get("baselines", {})
        if name not in known:
            raise ValueError(f"--policy {policy}: suite {suite.name!r} ships no baseline"
                             f" {name!r} (shipped: {', '.join(known) or 'none'})")  # fmt: skip
        env, rule = rebuild(suite, known[name], atlas, config, baselines_dir)
        return env, rule if isinstance(rule, SeedMean) else Adapted(rule, env), policy
    factory = load_factory(policy) if isinstance(policy, str) else policy
    p = suite.observe
    fitted = None if p == ORACLE else study_fit(config, p, atlas, atlas)
    env = rul_env(config, atlas, p, fitted)
    label = policy if isinstance(policy, str) else getattr(factory, "__name__", "policy")
    made = factory(env)
    return env, PerAgent(made, env) if is_per_agent(made) else Adapted(made, env), label


def compare(
    seeds: Sequence[int], net: Sequence[float], shipped: dict[str, Any] | None
) -> dict[str, Any]:
    """Each baseline's mean on the scored episodes and the paired interval of the policy
    minus it; the bound's mean and the policy's ratio to it (a ratio only to a positive
    bound). Baselines that do not hold every scored episode are listed as not paired."""
    out: dict[str, Any] = {"baselines": {}, "not_paired": [], "bound": None,
                           "ratio_to_bound": None}  # fmt: skip
    if shipped is None:
        out["not_paired"] = ["(no baselines shipped for this suite)"]
        return out
    x = np.asarray(net, dtype=float)
    for name, b in shipped["baselines"].items():
        y = _on(seeds, b["episodes"]["seed"], b["episodes"]["net"])
        if y is None:
            out["not_paired"].append(name)
            continue
        iv = paired_interval(x, y, "difference")
        out["baselines"][name] = {
            "net": float(y.mean()), "episodes": y.tolist(),
            "minus": {"mean": iv.point, "low": iv.low, "high": iv.high, "level": iv.level},
        }  # fmt: skip
    bound = shipped.get("bound")
    y = None if bound is None else _on(seeds, shipped["seeds"], bound["episodes"])
    if y is not None:
        out["bound"] = {"net": float(y.mean())}
        if y.mean() > 0:
            r = paired_interval(x, y, "ratio")
            out["ratio_to_bound"] = {"mean": r.point, "low": r.low, "high": r.high}
    return out


def _on(seeds: Sequence[int], have: Sequence[int], values: Sequence[float]) -> Any:
    """``values`` (by ``have``'s seeds) on ``seeds``, or None if any is missing."""
    at = {int(s): float(v) for s, v in zip(have, values, strict=True)}
    if not all(int(s) in at for s in seeds) or len(seeds) < 2:
        return None
    return np.array([at[int(s)] for s in seeds])
