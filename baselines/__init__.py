"""Physics-based and data-driven RUL baselines (paper 2.2 and 2.3).

``PhysicsPredictor`` (paper 2.3) and ``WindowPredictor`` (a health index from rolling-window
features, the data-driven model a practitioner would build) need numpy only.
``MLPPredictor`` and ``MLPConfig`` (paper 2.2) live in :mod:`baselines.mlp`, which imports
torch; they are loaded on first access, so ``import baselines`` stays free of torch.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from baselines.physics import PhysicsPredictor
from baselines.window import WindowConfig, WindowPredictor

if TYPE_CHECKING:
    from baselines.mlp import MLPConfig, MLPPredictor

__all__ = ["MLPConfig", "MLPPredictor", "PhysicsPredictor", "WindowConfig", "WindowPredictor"]


def __getattr__(name: str) -> Any:
    if name in ("MLPConfig", "MLPPredictor"):
        from baselines import mlp

        return getattr(mlp, name)
    raise AttributeError(f"module 'baselines' has no attribute {name!r}")
