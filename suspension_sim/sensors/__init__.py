"""Sensors: what a controller may read (one registered type per measured quantity)."""
