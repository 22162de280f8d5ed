"""Fleet policies evaluated on common episodes with paired intervals, and tuned."""
