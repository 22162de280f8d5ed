"""Maintenance policies and what they cost: rule policies (:mod:`agents.policies`), the
pad-by-pad cost study (:mod:`agents.study`), SB3 learning (:mod:`agents.learning`) and the
``brakewear train`` / ``compare`` commands (:mod:`agents.commands`). Each sub-package
imports only the ones before it in that list."""
