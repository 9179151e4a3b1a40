"""Plant effects: nonlinear force elements added per suspension corner (one file each)."""
