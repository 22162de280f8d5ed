"""Stable-Baselines3 learning: the agent's env and features, training with its learning
curve, hyperparameters, and saving agents without pickle. Imports :mod:`agents.policies`
and :mod:`agents.study`; SB3 and torch only inside the functions that use them (and
:mod:`agents.learning.curve`, an SB3 callback)."""
