"""Stable-Baselines3 agents, rule-based policies and the cost comparison (DESIGN 1.4;
README, "Maintenance cost by predictor")."""
