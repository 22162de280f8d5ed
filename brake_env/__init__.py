"""BrakeWear core: brake physics, the atlas, the coupled wear simulator and event logs.

No torch or Stable-Baselines3 here; the Gymnasium environment joins this package next.
"""

__version__ = "0.1.0"
