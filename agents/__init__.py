"""Stable-Baselines3 agents, rule-based policies and the cost comparison (issue 5)."""
