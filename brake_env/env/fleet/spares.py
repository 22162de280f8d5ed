"""The (s, S) reorder rule for the fleet's spare pads, where the env can use it.

One home for the rule: the fleet heuristics (``agents.fleet.policies.rules``) re-export
:func:`reorder`, and the PettingZoo version
(:class:`~brake_env.env.fleet.parallel.BrakeWearFleetParallelEnv` with ``spares=``) orders
by :class:`SparesRule` in the place of its ``store`` agent, so that every agent is a vehicle
with the same spaces (SuperSuit-style vectorisation and parameter sharing need that).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from brake_env.env.fleet import model


def reorder(stock: int, transit: int, fits: int, s: int, S: int, max_order: int) -> int:
    """(s, S): when stock + in transit - fits sent now is below ``s``, order up to ``S``
    (at most ``max_order``); else nothing (:func:`.model.reorder` on one state)."""
    return int(model.reorder(stock, transit, fits, s, S, max_order))


@dataclass(frozen=True)
class SparesRule:
    """Reorder spares by (s, S): when the inventory position (stock + in transit - pads
    sent to be fitted this shift) is below ``s``, order up to ``S``.

    Attributes:
        s: Reorder point (>= 0).
        S: Order-up-to level (>= s).
    """

    s: int
    S: int

    def __post_init__(self) -> None:
        for name in ("s", "S"):
            v = getattr(self, name)
            if isinstance(v, bool | np.bool_) or not isinstance(v, int | np.integer):
                raise ValueError(f"SparesRule: {name} must be an int, got {v!r}")
            object.__setattr__(self, name, int(v))
        if not 0 <= self.s <= self.S:
            raise ValueError(f"SparesRule: need 0 <= s <= S, got s={self.s}, S={self.S}")

    @classmethod
    def of(cls, value: Any) -> SparesRule:
        """A rule from a :class:`SparesRule` or an ``(s, S)`` pair; one ``ValueError``
        naming the value otherwise."""
        if isinstance(value, SparesRule):
            return value
        if not (isinstance(value, tuple | list) and len(value) == 2):
            raise ValueError(f"spares: an (s, S) pair of ints or a SparesRule, got {value!r}")
        return cls(*value)

    def order(self, stock: int, transit: int, fits: int, max_order: int) -> int:
        """The quantity to order this shift."""
        return reorder(stock, transit, fits, self.s, self.S, max_order)
