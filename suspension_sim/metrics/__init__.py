"""Metrics computed from a run's log (one file each)."""
