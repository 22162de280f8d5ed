"""Tests of the sim-to-real package."""
