"""Env families: what a fleet env gives the study, the benchmark and ``plan``, so that a
second fleet (a rail fleet, say) adds its env folder, one :func:`register_family` call and
fleet files naming it, and no study of its own.

A family is a config class (:class:`~brake_env.env.fleet.config.FleetConfig` or a subclass:
the fields the study and the policies read, its own added) and an env on it with
:class:`~brake_env.env.fleet.env.BrakeWearFleetEnv`'s interface (the observation the
policies' layout reads, ``action_masks()``, ``truth()``, ``info``'s costs and counts). A
fleet file's ``family`` key names its family (default ``brake``: every file before it);
the config's class finds the family back (:func:`family_of`), so whatever builds a fleet env
from a config calls :func:`make_env` and names no env class. The env is given as
gymnasium's registry gives one, a ``"module:Class"`` entry point (imported when first
made) or a callable.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from brake_env.env.fleet.config import FleetConfig

BRAKE = "brake"


@dataclass(frozen=True)
class EnvFamily:
    """A family of fleet envs.

    Attributes:
        name: What fleet files' ``family`` key calls it.
        config: Its config class (its fleet files' keys are this class's fields).
        entry_point: The env: ``"module:Class"`` or a callable, called as
            ``entry_point(config, atlas=atlas)``.
        description: One line for listings.
    """

    name: str
    config: type[FleetConfig]
    entry_point: str | Callable[..., Any]
    description: str = ""

    def make(self, config: FleetConfig, atlas: Any = None) -> Any:
        """An env of this family on ``config`` (``atlas``: the pads' physics, None: the
        config's preset's, cached)."""
        if type(config) is not self.config:
            raise TypeError(f"family {self.name!r} makes envs of {self.config.__name__},"
                            f" got a {type(config).__name__}")  # fmt: skip
        return _load(self.entry_point)(config, atlas=atlas)


_FAMILIES: dict[str, EnvFamily] = {}


def register_family(family: EnvFamily) -> None:
    """Add ``family`` (again: no change).

    Raises:
        ValueError: Its name or its config class is another family's.
    """
    for other in _FAMILIES.values():
        if other == family:
            return
        if other.name == family.name or other.config is family.config:
            raise ValueError(f"register_family: {family.name!r} ({family.config.__name__})"
                             f" clashes with family {other.name!r}"
                             f" ({other.config.__name__})")  # fmt: skip
    _FAMILIES[family.name] = family


def families() -> tuple[str, ...]:
    return tuple(_FAMILIES)


def family(name: str) -> EnvFamily:
    """The family called ``name``.

    Raises:
        ValueError: No such family, named with the known ones.
    """
    if name not in _FAMILIES:
        raise ValueError(f"family must be one of {', '.join(_FAMILIES)}, got {name!r}")
    return _FAMILIES[name]


def family_of(config: FleetConfig) -> EnvFamily:
    """The family whose config class ``config`` is (exactly).

    Raises:
        TypeError: No family has that class.
    """
    for f in _FAMILIES.values():
        if type(config) is f.config:
            return f
    raise TypeError(f"no env family has config class {type(config).__name__}"
                    f" (families: {', '.join(_FAMILIES)})")  # fmt: skip


def make_env(config: FleetConfig, atlas: Any = None) -> Any:
    """The env of ``config``'s family on it: what the study and the benchmark build."""
    return family_of(config).make(config, atlas)


def _load(entry_point: str | Callable[..., Any]) -> Callable[..., Any]:
    if callable(entry_point):
        return entry_point
    module, _, name = entry_point.partition(":")
    fn: Callable[..., Any] = getattr(importlib.import_module(module), name)
    return fn


register_family(EnvFamily(BRAKE, FleetConfig, "brake_env.env.fleet.env:BrakeWearFleetEnv",
                          "trucks' brake pads on a mine's hot and mild routes"))  # fmt: skip
