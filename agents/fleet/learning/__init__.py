"""Learning fleet policies: behaviour cloning, MaskablePPO, parameter-shared PPO."""
