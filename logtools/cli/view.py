"""`logcal view`: placeholder until its issue lands."""

from __future__ import annotations

import typer

__all__ = ["register"]


def register(app: typer.Typer) -> None:
    """Add the `view` command to ``app``."""

    @app.command("view")
    def _cmd() -> None:
        """Not yet available."""
        raise typer.Exit(code=1)
