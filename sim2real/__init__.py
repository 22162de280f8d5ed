"""Sim-to-real gap: unmodelled-effect library, "truth" simulator and gap diagnosis (README
"Sim-to-real gap")."""
