"""Sim-to-real gap: unmodelled-effect library, "truth" simulator and gap diagnosis
(docs/results/sim2real.md)."""
