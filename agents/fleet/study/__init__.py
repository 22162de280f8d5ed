"""``brakewear fleet-study``: its units on the runner, summary, figures and run."""
