"""The digital twin: state estimation, wear-coefficient identification, prognosis (issue 4)."""
