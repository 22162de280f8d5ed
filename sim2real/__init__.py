"""Sim-to-real gap: unmodelled-effect library, "truth" simulator and gap diagnosis (DESIGN 7)."""
