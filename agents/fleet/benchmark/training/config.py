"""A plain-RL training configuration: a TOML file naming the algorithm, the suite it trains
on and the algorithm's settings, read and checked (``configs/`` beside this package holds the
shipped ones).

```toml
algorithm = "maskable_ppo"       # or "mappo"
suite = "default"                # a shipped suite or a suite file
[train]                          # FleetTraining's fields (MarlTraining's for mappo)
timesteps = 40000
learning_rate = 3e-4
```

From scratch means no imitation: the settings' imitation fields are refused. The env is the
suite's, as ``fleet-score`` gives it (:func:`suite_env`): the suite's fleet, its ``observe``
predictor fitted as the suite fits it, training episodes drawn from their own seed.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from agents.fleet.benchmark.suite import Suite, read_named_toml, read_suite
from agents.fleet.learning.marl import MarlTraining
from agents.fleet.settings import FleetTraining
from agents.fleet.study.build import rul_env
from agents.fleet.study.fits import study_fit
from brake_env.env.atlases import default_atlas
from brake_env.model.atlas import Atlas
from brake_env.prognostics.registry import ORACLE

CONFIGS_DIR = Path(__file__).parent.with_name("configs")
ALGORITHMS = {"maskable_ppo": FleetTraining, "mappo": MarlTraining}
TOP_KEYS = ("algorithm", "suite", "description", "spares", "train")
# Not from scratch, or not for this entry point (the vehicle network is trained on labels).
REFUSED = ("imitation_episodes", "imitation_epochs", "imitation_lr", "imitation_value",
           "imitation_rounds", "vehicle_net")  # fmt: skip
TRAIN_SEED0 = 40_000_000
"""Training episodes: the env's first reset of copy i is seeded ``TRAIN_SEED0 + 1000 x seed
+ i`` (later episodes follow from its generator), apart from the dev, tuning and test seeds."""


@dataclass(frozen=True)
class TrainingConfig:
    """A training configuration read (:func:`read_config`).

    Attributes:
        algorithm: ``maskable_ppo`` or ``mappo``.
        suite: The suite trained on.
        settings: The algorithm's settings (:class:`FleetTraining` or :class:`MarlTraining`).
        spares: MAPPO's (s, S) reorder rule (its agents are the vehicles alone); None for
            MaskablePPO, whose settings carry theirs (``reorder``).
        path: The file it was read from ("" if made in code).
    """

    algorithm: str
    suite: Suite
    settings: Any
    spares: tuple[int, int] | None = None
    path: str = ""

    def with_settings(self, **changes: Any) -> TrainingConfig:
        """The same configuration with some settings changed (checked again)."""
        try:
            settings = dataclasses.replace(self.settings, **changes)
        except (TypeError, ValueError) as e:
            raise ValueError(f"training config {self.path or '(in code)'}: {e}") from None
        return dataclasses.replace(self, settings=settings)


def shipped_configs() -> tuple[str, ...]:
    return tuple(sorted(p.stem for p in CONFIGS_DIR.glob("*.toml")))


def read_config(path: str | os.PathLike[str], suite: str | None = None) -> TrainingConfig:
    """A training configuration file (or a shipped one's name); ``suite`` overrides its
    suite.

    Raises:
        ValueError: Not TOML, an unknown key (named), an unknown algorithm, a refused
            setting (imitation) or a bad value (named by the settings' own check).
    """
    p, data = read_named_toml(path, CONFIGS_DIR, shipped_configs(), "training config")
    return from_dict(data, str(p), suite)


def from_dict(data: dict[str, Any], where: str = "(in code)",
              suite: str | None = None) -> TrainingConfig:  # fmt: skip
    """:func:`read_config` on TOML already parsed."""
    bad = sorted(set(data) - set(TOP_KEYS))
    if bad:
        raise ValueError(f"training config {where}: unknown key(s) {bad}; keys: {TOP_KEYS}")
    algorithm = data.get("algorithm")
    if algorithm not in ALGORITHMS:
        raise ValueError(f"training config {where}: algorithm must be one of"
                         f" {list(ALGORITHMS)}, got {algorithm!r}")  # fmt: skip
    cls = ALGORITHMS[algorithm]
    train = data.get("train", {})
    if not isinstance(train, dict):
        raise ValueError(f"training config {where}: [train] must be a table")
    fields = {f.name for f in dataclasses.fields(cls)} - set(REFUSED)
    refused, unknown = sorted(set(train) & set(REFUSED)), sorted(set(train) - fields)
    if refused:
        raise ValueError(f"training config {where}: [train] {refused} refused: plain RL"
                         " from scratch has no imitation")  # fmt: skip
    if unknown:
        raise ValueError(f"training config {where}: unknown [train] key(s) {unknown};"
                         f" {cls.__name__}'s are {sorted(fields)}")  # fmt: skip
    values = {k: tuple(v) if isinstance(v, list) else v for k, v in train.items()}
    spares = data.get("spares")
    if (algorithm == "mappo") != (spares is not None) or not _pair(spares):
        raise ValueError(f"training config {where}: spares = [s, S] (0 <= s <= S) is mappo's"
                         f" and it needs one, got {spares!r}")  # fmt: skip
    try:
        settings = cls(**values)
        suite_ = read_suite(suite or data.get("suite", "default"))
    except (TypeError, ValueError) as e:
        raise ValueError(f"training config {where}: {e}") from None
    pair = None if spares is None else (int(spares[0]), int(spares[1]))
    return TrainingConfig(str(algorithm), suite_, settings, pair, where)


def _pair(v: Any) -> bool:
    """None or [s, S] with 0 <= s <= S, integers."""
    if v is None:
        return True
    ok = isinstance(v, list) and len(v) == 2 and all(type(x) is int for x in v)
    return ok and 0 <= v[0] <= v[1]


def suite_atlas(suite: Suite) -> Atlas:
    """The atlas of the suite's fleet's preset (the one ``fleet-score`` scores on)."""
    return default_atlas(suite.fleet_file.config.preset)


def suite_env(suite: Suite, atlas: Atlas, split: str = "dev") -> tuple[Any, Any]:
    """(a function making the suite's env on ``split``, the fitted ``observe`` predictor or
    None for the oracle): the env ``fleet-score`` scores on, the predictor fitted once."""
    config = suite.study_config(split)
    p = suite.observe
    fitted = None if p == ORACLE else study_fit(config, p, atlas, atlas)

    def make() -> Any:
        return rul_env(config, atlas, p, fitted)

    return make, fitted
