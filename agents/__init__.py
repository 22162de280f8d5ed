"""Maintenance policies and what they cost. BrakeWear-v0 (one pad): rule policies
(:mod:`agents.policies`), the pad-by-pad cost study (:mod:`agents.study`), SB3 learning
(:mod:`agents.learning`) and the ``brakewear train`` / ``compare`` commands
(:mod:`agents.commands`); each imports only the ones before it in that list.
BrakeWearFleet-v0: :mod:`agents.fleet`, one package with rooms of its own, which imports
none of the single-pad ones."""
