"""The package version (one place; :mod:`suspension_sim` and the run records read it from here)."""

__version__ = "0.1.0"
