"""Physics-based and data-driven RUL baselines (paper 2.2 and 2.3).

``PhysicsPredictor`` (paper 2.3) needs numpy only. ``MLPPredictor`` and ``MLPConfig``
(paper 2.2) live in :mod:`baselines.mlp`, which imports torch; they are loaded on first
access, so ``import baselines`` stays free of torch.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from baselines.physics import PhysicsPredictor

if TYPE_CHECKING:
    from baselines.mlp import MLPConfig, MLPPredictor

__all__ = ["MLPConfig", "MLPPredictor", "PhysicsPredictor"]


def __getattr__(name: str) -> Any:
    if name in ("MLPConfig", "MLPPredictor"):
        from baselines import mlp

        return getattr(mlp, name)
    raise AttributeError(f"module 'baselines' has no attribute {name!r}")
