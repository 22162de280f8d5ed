"""The cost study's engine: its settings, pads and their estimates, where each policy takes
a pad off, the one cost arithmetic, tuning, paired bootstrap intervals and the ranking.
Imports only :mod:`agents.policies` of the agents (no SB3, no runner)."""
