"""Road and base-excitation inputs (one file each)."""
