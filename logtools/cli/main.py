"""The ``logcal`` command line: one small module per command, errors turned into exit code 2."""

from __future__ import annotations

import sys
import traceback
from collections.abc import Sequence

import typer

from calib.errors import CalibError
from logtools.errors import LogcalError
from logtools.safe_text import printable

__all__ = ["KNOWN_ERRORS", "app", "debug_enabled", "launch", "main", "run"]

app = typer.Typer(
    name="logcal",
    help="Calibrate robot parameters from drive logs (MCAP, CSV) and explain model mismatch.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

_state = {"debug": False}


@app.callback()
def _root(
    debug: bool = typer.Option(False, "--debug", help="Show the full traceback of errors."),
) -> None:
    _state["debug"] = debug


def debug_enabled() -> bool:
    """Whether ``--debug`` was given (errors then keep their traceback)."""
    return bool(_state["debug"])


def _register() -> None:
    from logtools.cli import analyze, batch, info, reproduce, simulate, view

    for module in (info, simulate, analyze, reproduce, view, batch):
        module.register(app)


_register()


KNOWN_ERRORS: tuple[type[Exception], ...] = (LogcalError, CalibError)
"""Errors that are the input's fault or a stated limit of the data: one line, exit code 2."""


def launch(argv: Sequence[str] | None = None) -> int:
    """Run the CLI in-process with ``argv`` (without the program name); return the exit code.

    The one place errors become exit codes: usage errors (typer/click) exit 2 with their own
    message; ``KNOWN_ERRORS`` print one line ``logcal: error: ...`` and exit 2; anything else
    is a bug of ours: one line, exit 1 (``--debug`` shows the traceback of either).
    """
    args = list(sys.argv[1:] if argv is None else argv)
    _state["debug"] = "--debug" in args
    try:
        app(args=args, prog_name="logcal", standalone_mode=True)
    except SystemExit as ex:  # standalone typer/click ends every run with SystemExit
        return int(ex.code or 0) if isinstance(ex.code, int) else 1
    except KNOWN_ERRORS as err:
        if _state["debug"]:
            traceback.print_exc()
        print(f"logcal: error: {printable(err)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("Interrupted.", file=sys.stderr)
        return 130
    except Exception as err:  # a bug of ours: one line for the user, the traceback on --debug
        if _state["debug"]:
            traceback.print_exc()
        print(
            f"logcal: internal error: {type(err).__name__}: {printable(err)} (run with --debug "
            "for the "
            "traceback, and please report it)",
            file=sys.stderr,
        )
        return 1
    return 0


main = launch
"""Former name of :func:`launch` (tests and scripts call ``main([...])``)."""


def run() -> None:
    """Console-script entry point."""
    raise SystemExit(launch())


if __name__ == "__main__":
    run()
