"""What every env of the package shares (BrakeWear-v0, BrakeWearFleet-v0, and a third one
would too): the checks of their configs' common fields, ``gym.make`` keyword arguments
turned into a validated config, the render mode, the registered entry point, the atlas an
env runs on, and the check that a wrapper wraps the env it was made for."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Mapping
from typing import Any, TypeVar

import gymnasium as gym
import numpy as np

from brake_env._validate import check_keywords, from_dict
from brake_env.env.atlases import default_atlas
from brake_env.model.atlas import Atlas

C = TypeVar("C")


def check_int_fields(env_id: str, config: object, spec: tuple[tuple[str, int, int], ...]) -> None:
    """Each ``(name, lowest, highest)`` of ``spec`` is an int (Python or numpy) in range."""
    for name, lo, hi in spec:
        v = getattr(config, name)
        if isinstance(v, bool) or not isinstance(v, int | np.integer) or not lo <= v <= hi:
            raise ValueError(f"{env_id}: {name} must be an int in [{lo}, {hi}], got {v!r}")


def check_choice(
    env_id: str, name: str, value: Any, choices: Mapping[str, Any] | tuple[str, ...]
) -> None:
    if value not in choices:
        raise ValueError(f"{env_id}: {name} must be one of {list(choices)}, got {value!r}")


def check_types(env_id: str, config: object, kinds: Mapping[str, type]) -> None:
    """Each named field is an instance of its type (``bool`` fields: a real bool)."""
    for name, kind in kinds.items():
        v = getattr(config, name)
        if not isinstance(v, kind):
            if kind is bool:
                raise ValueError(f"{env_id}: {name} must be a bool, got {v!r}")
            raise TypeError(
                f"{env_id}: {name} must be {kind.__name__} or a dict of its fields, got {v!r}"
            )


def config_from_kwargs(
    env_id: str, cls: type[C], base: C | None, kwargs: dict[str, Any], nested: Mapping[str, type]
) -> C:
    """``base`` (the default config if None) with ``kwargs`` replaced, all validated: an
    unknown keyword is named; a ``nested`` field may come as a dict of its fields."""
    check_keywords(env_id, kwargs, (f.name for f in dataclasses.fields(cls)))  # type: ignore[arg-type]
    if base is not None and not isinstance(base, cls):
        fleet = isinstance(base, str) and "Fleet" in env_id  # a fleet's name meant as fleet=
        hint = " (a shipped fleet's name or a fleet file goes to fleet=)" if fleet else ""
        raise ValueError(f"{env_id}: config must be a {cls.__name__}, got {base!r}{hint}")
    for name, kind in nested.items():
        if isinstance(kwargs.get(name), dict):
            kwargs[name] = from_dict(kind, kwargs[name])
    return dataclasses.replace(base or cls(), **kwargs)  # type: ignore[type-var]


def check_render_mode(env_id: str, render_mode: str | None, modes: list[str]) -> None:
    if render_mode == "human":
        raise ValueError(
            f"{env_id} has no 'human' render mode (its render_modes are {modes}); use"
            " render_mode='rgb_array' and show the frames, or wrap that env in"
            " gymnasium.wrappers.HumanRendering yourself (it needs pygame)"
        )
    if render_mode not in (None, *modes):
        shown = ", ".join(repr(m) for m in modes)
        raise ValueError(f"{env_id}: render_mode must be None, {shown}, got {render_mode!r}")


def env_atlas(atlas: Atlas | str | os.PathLike[str] | None, preset: str) -> Atlas:
    """The atlas an env runs on: given, loaded from a saved ``.npz``, or the preset's."""
    if atlas is None:
        return default_atlas(preset)
    return atlas if isinstance(atlas, Atlas) else Atlas.load(atlas)


def require_env(wrapper: str, env: Any, kind: type, env_id: str) -> None:
    """A wrapper made for one env refuses another, naming both (instead of failing later on
    an attribute the other env does not have)."""
    if not isinstance(env.unwrapped, kind):
        raise TypeError(
            f"{wrapper} wraps {env_id} ({kind.__name__}), got {type(env.unwrapped).__name__}"
        )


def make_registered(cls: Callable[..., gym.Env[Any, Any]], **kwargs: Any) -> gym.Env[Any, Any]:
    """A registered env's entry point: ``cls`` made from ``gym.make``'s keywords. A function,
    so ``gym.make`` leaves ``render_mode`` to the env: given the class it would wrap
    ``"human"`` in its pygame window instead of saying the env has no such mode.
    ``"rgb_array_list"`` and ``"ansi_list"`` collect the frames, as ``gym.make`` does."""
    mode = kwargs.get("render_mode")
    if isinstance(mode, str) and mode.endswith("_list") and mode[:-5] in ("ansi", "rgb_array"):
        return gym.wrappers.RenderCollection(cls(**{**kwargs, "render_mode": mode[:-5]}))
    return cls(**kwargs)
