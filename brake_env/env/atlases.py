"""The atlases the envs of a process share: one per preset and cache folder, loaded once.

An env made without an atlas uses its preset's (:func:`default_atlas`). Such an atlas is a
pure function of its key, so a pickled reference to it can be its key
(:func:`shared_atlas_key`) rather than its ~13 MB of arrays: the lazy truth of an info
(:mod:`brake_env.env.lazy_truth`) crosses processes that way.
"""

from __future__ import annotations

import os

from brake_env.model.atlas import Atlas, AtlasSpec, cached_atlas
from brake_env.model.params import BrakeModel

AtlasKey = tuple[str, str | None]
_ATLASES: dict[AtlasKey, Atlas] = {}


def default_atlas(preset: str = "hot-duty", cache_dir: str | None = None) -> Atlas:
    """The preset's atlas from the on-disk cache (built once, ~1 s), shared in the process."""
    key = (preset, cache_dir or os.environ.get("BRAKEWEAR_CACHE_DIR"))
    if key not in _ATLASES:
        _ATLASES[key] = cached_atlas(AtlasSpec(model=BrakeModel.preset(preset)), cache_dir)
    return _ATLASES[key]


def shared_atlas_key(atlas: Atlas) -> AtlasKey | None:
    """The key that gives ``atlas`` back from :func:`default_atlas` (in this or another
    process), or None if it is not one of the shared atlases (it must then travel whole)."""
    for key, shared in _ATLASES.items():
        if shared is atlas:
            return key
    return None
