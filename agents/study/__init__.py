"""The cost studies: what policies cost, with paired intervals."""
