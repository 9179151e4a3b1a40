"""Vehicle models: one Python file per MJCF model in ``models/`` (like dm_control's suite domains)."""
