"""Unmodelled effects and the truth simulator: the plug-in interface (interface.py), the
candidate library (library.py), effects on a coarse grid (grid.py), thermal history between
events (carry_over.py) and the truth logs (truth.py)."""
