"""Every registered robot's own options as CLI options of ``analyze``, ``view``, ``batch`` and
``info`` (those declared ``view=True``, ``batch=True``, ``info=True``), generated from the
plugins' declarations (:mod:`logtools.robot_options`), and the warning when one given does not
apply to the robot found.

A command opts in with :func:`with_robot_options`: its function takes one parameter
``robot_options: GivenOptions`` and the decorator offers each declared option (``--urdf``,
``--method``, ...) in its place. The signature is computed when the click command is built
(every ``logcal`` run), so a plugin registered at run time (``register(...)``) brings its
options too.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from enum import Enum
from pathlib import PurePath
from typing import TYPE_CHECKING, Any, Literal

import typer

if TYPE_CHECKING:
    from logtools.robot_options import OptionSpec, RobotOptions
    from logtools.robots.base import RobotPlugin

__all__ = ["GivenOptions", "general_warnings", "with_robot_options"]

_PARAM = "robot_options"

Command = Literal["analyze", "view", "batch", "info"]


@dataclass(frozen=True)
class _CliOption:
    """One generated CLI option: the flag, its declarations (one per robot) and its parameter."""

    name: str
    specs: tuple[OptionSpec, ...]

    @property
    def flag(self) -> str:
        return self.specs[0].flag


def _cli_options(command: Command) -> list[_CliOption]:
    """The robots' options ``command`` offers, one per flag (robots may share one)."""
    from logtools.robot_options import option_specs
    from logtools.robots import plugins

    by_flag: dict[str, list[OptionSpec]] = {}
    for plugin in plugins():
        for spec in option_specs(plugin):
            if (
                command == "analyze"
                or (command == "view" and spec.view)
                or (command == "batch" and spec.batch)
                or (command == "info" and spec.info)
            ):
                by_flag.setdefault(spec.flag, []).append(spec)
    out = []
    for flag, specs in by_flag.items():
        kinds = {s.type for s in specs}
        if len(kinds) > 1:
            raise TypeError(
                f"robot option {flag}: robots {', '.join(s.robot for s in specs)} "
                f"declare it with different types ({', '.join(map(str, kinds))})"
            )
        if len({(s.file, s.or_name) for s in specs}) > 1:
            raise TypeError(
                f"robot option {flag}: robots {', '.join(s.robot for s in specs)} "
                "disagree on whether its value names a file (file=, or_name=)"
            )
        name = "ro_" + flag.lstrip("-").replace("-", "_")
        out.append(_CliOption(name, tuple(specs)))
    return out


def _typer_option(opt: _CliOption) -> Any:
    first = opt.specs[0]
    robots = " and ".join(dict.fromkeys(s.robot for s in opt.specs))
    help_text = first.help if len(opt.specs) == 1 else f"{first.help} ({robots})"
    return typer.Option(
        None, first.flag, metavar=first.metavar or None, help=help_text, show_default=False
    )


@dataclass(frozen=True)
class GivenOptions:
    """The robot options given on the command line.

    Attributes:
        values: flag -> value of each option given (left out: not given).
        specs: flag -> every robot's declaration of that flag.
    """

    values: Mapping[str, Any] = field(default_factory=dict)
    specs: Mapping[str, tuple[OptionSpec, ...]] = field(default_factory=dict)

    def by_robot(self) -> dict[str, RobotOptions]:
        """Each robot's options built from the values given (robots given none are left out).

        Raises:
            LogcalInputError: a value that is not what its option expects (naming the flag).
        """
        from logtools.robot_options import build_options
        from logtools.robots import plugin_for

        keyed: dict[str, dict[str, Any]] = {}
        for flag, value in self.values.items():
            for spec in self.specs[flag]:
                keyed.setdefault(spec.robot, {})[spec.key] = value
        return {
            robot: build_options(plugin_for(robot).options, values, source="cli")
            for robot, values in keyed.items()
        }

    def by_key(self) -> dict[str, Any]:
        """The values given by settings key, as plain data (an Enum as its value, a path as
        text), checked against every robot declaring them: what ``logcal batch`` hands its
        workers with the ``logcal.toml`` keys.

        Raises:
            LogcalInputError: a value that is not what its option expects (naming the flag).
        """
        self.by_robot()  # checks each value against every robot declaring its flag
        out: dict[str, Any] = {}
        for flag, value in self.values.items():
            plain = value.value if isinstance(value, Enum) else value
            out[self.specs[flag][0].key] = str(plain) if isinstance(plain, PurePath) else plain
        return out

    def unused(self, plugin: RobotPlugin, where: str = "") -> list[str]:
        """One warning per option given that ``plugin``'s robot does not declare."""
        out = []
        for flag in self.values:
            robots = tuple(dict.fromkeys(s.robot for s in self.specs[flag]))
            if plugin.name not in robots:
                out.append(_not_used(flag, robots, plugin, where))
        return out


def _not_used(flag: str, robots: tuple[str, ...], plugin: RobotPlugin, where: str) -> str:
    return (
        f"{flag} applies to {' and '.join(robots) or 'no'} logs; "
        f"{where or 'the log'} is a {plugin.name} log ({plugin.title}): {flag} was not used"
    )


def general_warnings(
    plugin: RobotPlugin, given: Mapping[str, tuple[str, object]], where: str = ""
) -> list[str]:
    """Warnings for general options given that only some robots use: ``given`` maps a flag to
    (what it sets, its value; None or False: not given). What it sets is an ``AnalysisConfig``
    setting (robots naming it in ``uses_settings``) or ``pose`` (robots reading the pose
    signals x, y, yaw: ``--ground-truth``)."""
    from logtools.robots import plugins

    def applies(p: RobotPlugin, what: str) -> bool:
        if what == "pose":
            return {"x", "y", "yaw"} <= {s.name for s in p.signals}
        return what in p.uses_settings

    out = []
    for flag, (what, value) in given.items():
        if value is None or value is False or applies(plugin, what):
            continue
        robots = tuple(p.name for p in plugins() if applies(p, what))
        out.append(_not_used(flag, robots, plugin, where))
    return out


class _WithRobotOptions:
    """A command function whose signature, as typer reads it, has the robots' options in place
    of its ``robot_options`` parameter (computed anew each time the command is built)."""

    def __init__(self, fn: Callable[..., None], command: Command) -> None:
        self._fn = fn
        self._command = command
        self.__name__ = fn.__name__
        self.__qualname__ = fn.__qualname__
        self.__module__ = fn.__module__
        self.__doc__ = fn.__doc__
        self.__wrapped__ = fn

    def _own(self) -> tuple[list[inspect.Parameter], dict[str, Any]]:
        sig = inspect.signature(self._fn, eval_str=True)
        hints = inspect.get_annotations(self._fn, eval_str=True)
        params = [p for p in sig.parameters.values() if p.name != _PARAM]
        return params, {k: v for k, v in hints.items() if k != _PARAM}

    @property
    def __signature__(self) -> inspect.Signature:  # read by inspect.signature (typer)
        params, _ = self._own()
        taken = {
            d
            for p in params
            if hasattr(p.default, "param_decls")
            for d in (p.default.param_decls or ())
        }
        for opt in _cli_options(self._command):
            if opt.flag in taken:
                raise TypeError(
                    f"robot option {opt.flag} ({opt.specs[0].robot}) clashes with "
                    f"{self._command}'s own {opt.flag}"
                )
            params.append(
                inspect.Parameter(
                    opt.name,
                    inspect.Parameter.KEYWORD_ONLY,
                    default=_typer_option(opt),
                    annotation=opt.specs[0].type | None,
                )
            )
        return inspect.Signature(params)

    @property
    def __annotations__(self) -> dict[str, Any]:  # type: ignore[override]  # get_type_hints
        _, hints = self._own()
        for opt in _cli_options(self._command):
            hints[opt.name] = opt.specs[0].type | None
        return hints

    def __call__(self, **kwargs: Any) -> None:
        opts = _cli_options(self._command)
        values: dict[str, Any] = {}
        for opt in opts:
            value = kwargs.pop(opt.name, None)
            if value is not None and value is not False:
                values[opt.flag] = value
        given = GivenOptions(values, {o.flag: o.specs for o in opts})
        self._fn(**kwargs, **{_PARAM: given})


def with_robot_options(
    command: Command,
) -> Callable[[Callable[..., None]], Any]:
    """Decorate a command function (before ``app.command``) so that it offers every robot's
    options (``view``: those declared ``view=True``; ``batch``: ``batch=True``; ``info``:
    ``info=True``) and receives
    them as one ``robot_options: GivenOptions`` argument."""

    def deco(fn: Callable[..., None]) -> Any:
        return _WithRobotOptions(fn, command)

    return deco
