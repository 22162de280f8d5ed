"""Stable-Baselines3 agents, rule-based policies and the cost comparison (README
"Maintenance cost by predictor")."""
