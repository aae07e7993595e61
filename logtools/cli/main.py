"""The ``logcal`` command line: one small module per command, errors turned into exit code 2."""

from __future__ import annotations

import sys
import traceback
from collections.abc import Sequence

import typer

from calib.errors import CalibError
from logtools.errors import LogcalError

__all__ = ["app", "debug_enabled", "main", "run"]

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
    from logtools.cli import analyze, info, reproduce, simulate, view

    for module in (info, simulate, analyze, reproduce, view):
        module.register(app)


_register()


def _click_exception_types() -> tuple[
    tuple[type[BaseException], ...], tuple[type[BaseException], ...]
]:
    """(usage-error types, abort types) of typer's vendored click and of click, when present."""
    usage: list[type[BaseException]] = []
    abort: list[type[BaseException]] = [typer.Abort]
    try:  # typer >= 0.2x vendors its own copy of click
        from typer._click import exceptions as vendored

        usage.append(vendored.ClickException)
    except ImportError:  # pragma: no cover - depends on the typer version
        pass
    try:  # older typer runs on the click package
        import click  # type: ignore[import-not-found, unused-ignore]

        usage.append(click.ClickException)
        abort.append(click.exceptions.Abort)
    except ImportError:
        pass
    return tuple(usage), tuple(abort)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI in-process with ``argv`` (without the program name); return the exit code."""
    args = list(sys.argv[1:] if argv is None else argv)
    _state["debug"] = "--debug" in args
    usage_errors, aborts = _click_exception_types()
    try:
        app(args=args, prog_name="logcal", standalone_mode=False)
    except (LogcalError, CalibError) as err:
        if _state["debug"]:
            traceback.print_exc()
        print(f"logcal: error: {err}", file=sys.stderr)
        return 2
    except typer.Exit as ex:
        return int(ex.exit_code or 0)
    except SystemExit as ex:
        return int(ex.code or 0) if isinstance(ex.code, int) else 1
    except usage_errors as ex:
        ex.show()  # type: ignore[attr-defined]  # a click ClickException
        return int(getattr(ex, "exit_code", 2))
    except aborts:
        print("Aborted.", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("Interrupted.", file=sys.stderr)
        return 130
    except Exception as err:  # a bug of ours: one line for the user, the traceback on --debug
        if _state["debug"]:
            traceback.print_exc()
        print(
            f"logcal: internal error: {type(err).__name__}: {err} (run with --debug for the "
            "traceback, and please report it)",
            file=sys.stderr,
        )
        return 1
    return 0


def run() -> None:
    """Console-script entry point."""
    raise SystemExit(main())


if __name__ == "__main__":
    run()
