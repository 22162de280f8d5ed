"""What a fleet rule reads from the observation, the heuristics, and the exact reference."""
