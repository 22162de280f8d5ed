"""Suites: a fleet file and the protocol every policy on it is scored by.

A suite file (TOML; the shipped ones in ``suites/`` beside this module) names its fleet (a
shipped fleet or a fleet file's path, relative to the suite file) and a ``[protocol]``: the
episode length, the dev split (seeds ``0..dev_episodes-1``, where every design choice is
made; the rules are tuned on the tuning seeds from 10,000, on the dev side too), the sealed
test split (``test_episodes`` seeds from ``test_from``, read once to score), the predictors'
fits (``n_train_runs`` simulated run-to-failure pads, ``seed``), the objective (``net``)
and ``observe``, the predictor whose RUL a scored policy's observation carries. A suite is
run as a fleet study on one of its splits (:meth:`Suite.study_config`).
"""

from __future__ import annotations

import hashlib
import json
import os
import tomllib
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

from agents.fleet.settings import OBJECTIVES, FleetStudyConfig
from agents.fleet.settings.training import TUNE_SEED0
from brake_env.env.fleet.fleet_file import FleetFile, read_fleet, shipped_fleets
from brake_env.prognostics.registry import predictor_names

SUITES_DIR = Path(__file__).with_name("suites")
SPLITS = ("dev", "test")
_INTS = ("shifts", "dev_episodes", "test_from", "test_episodes", "tune_episodes",
         "n_train_runs", "seed")  # fmt: skip


@dataclass(frozen=True)
class Suite:
    """A suite read and validated (the protocol's fields as in the module's text)."""

    name: str
    fleet: str
    description: str = ""
    shifts: int = 365
    dev_episodes: int = 20
    test_from: int = 900_000
    test_episodes: int = 20
    tune_episodes: int = 3
    n_train_runs: int = 10
    seed: int = 0
    objective: str = "net"
    observe: str = "twin"

    def __post_init__(self) -> None:
        for k in _INTS:
            v = getattr(self, k)
            if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v <= 2**31:
                raise ValueError(f"suite {self.name!r}: {k} must be an integer in [0, 2**31],"
                                 f" got {v!r}")  # fmt: skip
        if self.test_episodes < 20:
            raise ValueError(f"suite {self.name!r}: test_episodes must be >= 20 (a sealed test"
                             f" split to rank on), got {self.test_episodes}")  # fmt: skip
        if min(self.shifts, self.dev_episodes, self.tune_episodes, self.n_train_runs) < 1:
            raise ValueError(f"suite {self.name!r}: shifts, dev_episodes, tune_episodes and"
                             " n_train_runs must be >= 1")  # fmt: skip
        if self.test_from < max(self.dev_episodes, TUNE_SEED0 + self.tune_episodes):
            raise ValueError(f"suite {self.name!r}: the test split (seeds from"
                             f" {self.test_from}) overlaps the dev side")  # fmt: skip
        if self.objective not in OBJECTIVES:
            raise ValueError(f"suite {self.name!r}: objective must be one of {OBJECTIVES}")
        if self.observe not in predictor_names():
            raise ValueError(f"suite {self.name!r}: observe must be one of"
                             f" {list(predictor_names())}, got {self.observe!r}")  # fmt: skip

    @property
    def fleet_file(self) -> FleetFile:
        return read_fleet(self.fleet, episode_shifts=self.shifts)

    @property
    def digest(self) -> str:
        """What the suite's figures depend on: its protocol and its fleet's content."""
        payload = {**asdict(self), "fleet": read_fleet(self.fleet).digest}
        payload.pop("description")
        return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()[:16]

    def seeds(self, split: str = "test", episodes_from: int | None = None) -> list[int]:
        """A split's episode seeds (the test split moved to ``episodes_from``)."""
        c = self.study_config(split=split, episodes_from=episodes_from)
        return c.eval_seeds()

    def study_config(
        self, split: str = "test", episodes_from: int | None = None, **budget: Any
    ) -> FleetStudyConfig:
        """The fleet study of this suite on ``split``'s episodes (``budget``: the study's
        other fields, e.g. predictors, heuristics, trials, bound_iterations)."""
        if split not in SPLITS:
            raise ValueError(f"split must be one of {SPLITS}, got {split!r}")
        first, n = (0, self.dev_episodes) if split == "dev" else (self.test_from,
                                                                   self.test_episodes)  # fmt: skip
        return FleetStudyConfig(
            size=self.fleet, shifts=self.shifts, eval_episodes=n,
            episodes_from=first if episodes_from is None else episodes_from,
            tune_episodes=self.tune_episodes, n_train_runs=self.n_train_runs,
            seed=self.seed, objective=self.objective,  # type: ignore[arg-type]
            **budget,
        )  # fmt: skip

    def dev_config(self, episodes_from: int, episodes: int, **budget: Any) -> FleetStudyConfig:
        """The study of ``episodes`` dev-side episodes from ``episodes_from`` (an analysis's).

        Raises:
            ValueError: They reach the sealed test split.
        """
        config = replace(self.study_config("dev", episodes_from, **budget), eval_episodes=episodes)
        seeds = config.eval_seeds()
        if max(seeds) >= self.test_from:
            raise ValueError(f"episodes {seeds[0]}..{seeds[-1]} reach the test split (from"
                             f" {self.test_from}): analyses run on the dev side")  # fmt: skip
        return config


def shipped_suites() -> tuple[str, ...]:
    return tuple(sorted(p.stem for p in SUITES_DIR.glob("*.toml")))


def read_named_toml(
    name: str | os.PathLike[str], folder: Path, shipped: tuple[str, ...], what: str
) -> tuple[Path, dict[str, Any]]:
    """(the path, the TOML) of a shipped file's name (``folder/NAME.toml``) or a file.

    Raises:
        ValueError: Neither (the shipped names listed), or not TOML: named with ``what``.
    """
    text = os.fspath(name)
    path = folder / f"{text}.toml" if text in shipped else Path(text)
    if not path.is_file():
        raise ValueError(f"{what} {text!r}: no such file, and not a shipped {what}"
                         f" ({', '.join(shipped)})")  # fmt: skip
    try:
        return path, tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise ValueError(f"{what} file {path}: not TOML ({e})") from None


def read_suite(suite: str | os.PathLike[str]) -> Suite:
    """A shipped suite's name or a suite file.

    Raises:
        ValueError: Not a suite, not TOML, an unknown or bad key: named with the file.
    """
    path, data = read_named_toml(suite, SUITES_DIR, shipped_suites(), "suite")
    protocol = data.pop("protocol", {})
    known = {"name", "fleet", "description"}
    bad = sorted(set(data) - known) + sorted(set(protocol) - set(_INTS) - {"objective", "observe"})
    if bad or not isinstance(protocol, dict) or "fleet" not in data:
        raise ValueError(f"suite file {path}: unknown key(s) {bad} or no fleet; keys: name,"
                         f" fleet, description and [protocol] {list(_INTS)}, objective,"
                         " observe")  # fmt: skip
    fleet = str(data["fleet"])
    if fleet not in shipped_fleets():
        fleet = str((path.parent / fleet).resolve())
    try:
        suite_ = Suite(name=str(data.get("name", path.stem)), fleet=fleet,
                       description=str(data.get("description", "")), **protocol)  # fmt: skip
        suite_.fleet_file  # noqa: B018  (the fleet read now: a bad one named here)
    except (TypeError, ValueError) as e:
        raise ValueError(f"suite file {path}: {e}") from None
    return suite_
