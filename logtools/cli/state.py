"""What the root command sets for every subcommand: whether ``--debug`` was given.

Its own module so that subcommands read it without importing the CLI's entry point (which
imports them to register their commands)."""

from __future__ import annotations

__all__ = ["debug_enabled", "set_debug"]

_state = {"debug": False}


def set_debug(value: bool) -> None:
    """Record ``--debug`` (the root command's callback)."""
    _state["debug"] = bool(value)


def debug_enabled() -> bool:
    """Whether ``--debug`` was given (errors then keep their traceback)."""
    return bool(_state["debug"])
