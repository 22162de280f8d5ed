"""Tests of sim2real.validation."""
