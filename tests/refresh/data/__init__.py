"""Data of the refresh tests: a task of their own for ``python -m refresh manage``."""
