"""Tests of sim2real.commands: the CLI and validate-gap's units."""
