"""Extra CLI commands: each module here defines ``register(app: typer.Typer)`` (batch, view, compare,
diagnose, ...), so a new command is one new file."""
