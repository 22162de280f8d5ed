"""Withheld-effect validation of the diagnosis (validate.py) and the reports of a diagnosis
and a validation: text and files (report.py), figures (plots.py)."""
