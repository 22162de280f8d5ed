"""Tests of sim2real.effects: the effects and the truth simulator."""
