"""Reproductions of the source papers: one module per source, registered by name in
:data:`suspension_sim.reproductions.framework.SOURCES`; run them with ``suspension-sim reproduce``."""
