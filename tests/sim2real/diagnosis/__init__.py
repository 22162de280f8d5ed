"""Tests of sim2real.diagnosis."""
