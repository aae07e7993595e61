"""The ``logcal`` command line: one small module per command, errors turned into exit code 2."""

from __future__ import annotations

import inspect
import sys
import traceback
from collections.abc import Sequence
from enum import Enum
from pathlib import Path
from typing import Any, get_args, get_origin

import typer

from calib.errors import CalibError
from logtools.cli.state import debug_enabled, set_debug
from logtools.cli.streams import guard_streams, pipe_broken, silence_stdout, stdout_failure
from logtools.errors import LogcalError
from logtools.safe_text import printable

__all__ = [
    "KNOWN_ERRORS",
    "app",
    "command",
    "debug_enabled",
    "launch",
    "main",
    "readable_metavars",
    "run",
]

HELP_OPTIONS = ["-h", "--help"]

app = typer.Typer(
    name="logcal",
    help="Calibrate robot parameters from drive logs (MCAP, ROS bags, CSV) and explain model "
    "mismatch.",
    epilog="Shell completion: logcal --install-completion (bash, zsh, fish, PowerShell), or "
    "logcal --show-completion to print the script. Errors: exit code 2 with one message; "
    "--debug shows the traceback.",
    no_args_is_help=False,
    invoke_without_command=True,
    add_completion=True,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # help as written: plain text, no markup eating "[signals.NAME]"
    context_settings={"help_option_names": HELP_OPTIONS},
)


def _version(value: bool) -> None:
    if value:
        from importlib.metadata import PackageNotFoundError, version

        try:
            text = version("logcal")
        except PackageNotFoundError:  # run from a source tree that was never installed
            text = "unknown (not installed)"
        typer.echo(f"logcal {text}")
        raise typer.Exit(0)


@app.callback()
def _root(
    ctx: typer.Context,
    debug: bool = typer.Option(False, "--debug", help="Show the full traceback of errors."),
    show_version: bool = typer.Option(
        False,
        "--version",
        "-V",
        is_eager=True,
        callback=_version,
        help="Print logcal's version and exit.",
    ),
) -> None:
    set_debug(debug)
    if ctx.invoked_subcommand is None:  # bare ``logcal``: the help, and success
        typer.echo(ctx.get_help())
        raise typer.Exit(0)


def _register() -> None:
    from logtools.cli import analyze, batch, info, reproduce, simulate, view

    for module in (info, simulate, analyze, reproduce, view, batch):
        module.register(app)


_NAMED_METAVARS = {
    "--out": "PATH",
    "-o": "PATH",
    "--rrd": "FILE.rrd",
    "--png": "FILE.png",
    "--channel-map": "FILE.toml",
    "--port": "PORT",
    "--workers": "N",
    "--seed": "N",
    "--repeats": "N",
    "--address": "HOST:PORT",
}
"""Metavars by option name, for options that do not set their own."""


def _metavar(info: Any, annotation: Any) -> str:
    """A readable metavar for a parameter without one: nothing for a flag, the choices of an
    enum, FILE/PATH/N/NUMBER/TEXT by type (``LOG...`` style for arguments)."""
    args = [a for a in get_args(annotation) if a is not type(None)]
    base = args[0] if get_origin(annotation) is not list and args else annotation
    many = get_origin(annotation) is list or any(get_origin(a) is list for a in args)
    if many:
        inner = next((get_args(a)[0] for a in [annotation, *args] if get_origin(a) is list), str)
        base = inner
    names = list(getattr(info, "param_decls", None) or ())
    named = next((_NAMED_METAVARS[n] for n in names if n in _NAMED_METAVARS), None)
    if base is bool:
        return ""
    if named:
        text = named
    elif isinstance(base, type) and issubclass(base, Enum):
        text = "|".join(str(m.value) for m in base)
    elif base is Path:
        text = "PATH"
    elif base is int:
        text = "N"
    elif base is float:
        text = "NUMBER"
    else:
        text = "TEXT"
    return text + ("..." if many else "")


def readable_metavars(typer_app: typer.Typer) -> None:
    """Give every option and argument of ``typer_app`` (and its sub-apps) that has no metavar
    a readable one, instead of typer's ``<bool>``/``<path>``/``<list[Path]>``."""
    commands = [*typer_app.registered_commands]
    callbacks = [c.callback for c in commands]
    if typer_app.registered_callback is not None:
        callbacks.append(typer_app.registered_callback.callback)
    for group in typer_app.registered_groups:
        if group.typer_instance is not None:
            readable_metavars(group.typer_instance)
    for fn in callbacks:
        if fn is None:
            continue
        hints = inspect.get_annotations(fn, eval_str=True)
        for name, param in inspect.signature(fn).parameters.items():
            info = param.default
            if not isinstance(info, (typer.models.OptionInfo, typer.models.ArgumentInfo)):
                continue
            if info.metavar is not None or name not in hints:
                continue
            if isinstance(info, typer.models.ArgumentInfo):
                info.metavar = name.upper()  # ARCHIVE; a list shows as ARCHIVE... in usage
            else:
                info.metavar = _metavar(info, hints[name])


def _plain_arguments(command: Any) -> None:
    """Show arguments by their metavar alone (``LOG...``), not with typer's ``<list[Path]>``."""
    for param in getattr(command, "params", ()):
        if param.param_type_name == "argument" and param.metavar is not None:
            param.display_type_rich = lambda ctx: None
    for sub in getattr(command, "commands", {}).values():
        _plain_arguments(sub)


def _whole_short_help(command: Any) -> None:
    """List each subcommand in its group's help by the whole first paragraph of its help,
    not click's cut at the first period ("Recompute the patent's Figs.") or at 45 columns."""
    for sub in getattr(command, "commands", {}).values():
        if not sub.short_help and sub.help:
            sub.short_help = " ".join(sub.help.strip().split("\n\n")[0].split())
        _whole_short_help(sub)


def command() -> Any:
    """The click command of ``logcal`` (built from ``app`` and the robot plugins registered now,
    arguments shown plainly)."""
    from logtools.cli import reproduce, simulate

    simulate.sync()
    reproduce.sync()
    readable_metavars(app)
    cmd = typer.main.get_command(app)
    _plain_arguments(cmd)
    _whole_short_help(cmd)
    return cmd


_register()
readable_metavars(app)


KNOWN_ERRORS: tuple[type[Exception], ...] = (LogcalError, CalibError)
"""Errors that are the input's fault or a stated limit of the data: one line, exit code 2."""


def _run_command(args: list[str]) -> int:
    """The command's exit code, its stdout flushed (a full stdout fails here, not at exit)."""
    try:
        command().main(args=args, prog_name="logcal", standalone_mode=True)
        code = 0
    except SystemExit as ex:  # standalone typer/click ends every run with SystemExit
        code = int(ex.code or 0) if isinstance(ex.code, int) else 1
    if pipe_broken():  # the reader of our stdout has gone (| head): click ended quietly
        silence_stdout()
        return 2
    if sys.stdout is not None:
        sys.stdout.flush()
    return code


def launch(argv: Sequence[str] | None = None) -> int:
    """Run the CLI in-process with ``argv`` (without the program name); return the exit code.

    The one place errors become exit codes: usage errors (typer/click) exit 2 with their own
    message; ``KNOWN_ERRORS`` print one line ``logcal: error: ...`` and exit 2; an output that
    cannot be written (a full disk, a full or closed stdout: :mod:`logtools.cli.streams`) one
    line and exit 2, a broken pipe exit 2 quietly; anything else is a bug of ours: one line,
    exit 1 (``--debug`` shows the traceback of either).
    """
    args = list(sys.argv[1:] if argv is None else argv)
    set_debug("--debug" in args)
    guard_streams()
    try:
        return _run_command(args)
    except KNOWN_ERRORS as err:
        if debug_enabled():
            traceback.print_exc()
        print(f"logcal: error: {printable(err)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("Interrupted.", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader of our stdout has gone (| head): end quietly
        silence_stdout()
        return 2
    except OSError as err:
        message = stdout_failure(err)
        if message is None:
            return _internal(err)
        if debug_enabled():
            traceback.print_exc()
        silence_stdout()
        print(f"logcal: error: {printable(message)}", file=sys.stderr)
        return 2
    except Exception as err:  # a bug of ours: one line for the user, the traceback on --debug
        return _internal(err)


def _internal(err: Exception) -> int:
    if debug_enabled():
        traceback.print_exc()
    print(
        f"logcal: internal error: {type(err).__name__}: {printable(err)} (run with --debug "
        "for the traceback, and please report it)",
        file=sys.stderr,
    )
    return 1


main = launch
"""Former name of :func:`launch` (tests and scripts call ``main([...])``)."""


def run() -> None:
    """Console-script entry point."""
    raise SystemExit(launch())


if __name__ == "__main__":
    run()
