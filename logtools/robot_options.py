"""A robot's own analysis options, typed: one frozen dataclass per robot (``RobotPlugin.options``)
whose fields are declared with :func:`option` (CLI flag, help, metavar, whether ``view``,
``batch`` and ``info`` also take it); the settings key is the field name.

The command line (``analyze``; ``view``, ``batch`` and ``info`` those declared for them) offers
every registered robot's options from these declarations, a settings file names them by key, and
both are turned into the dataclass by :func:`build_options`, which checks each value and raises
one :class:`LogcalInputError` naming the flag or key and what was expected. An analysis reads
its robot's options with ``AnalysisConfig.options(TheRobotOptions)``.

    @dataclass(frozen=True)
    class ArmOptions(RobotOptions):
        urdf: str | None = option(flag="--urdf", help="The arm's URDF.", file=True, view=True)

An option whose value names a file says so (``file=True``; a ``Path`` option always does):
a settings file may then name only a file inside its archive (``logtools.batch.settings``),
whatever the option's flag or metavar is spelled like. ``or_name=True`` adds that a plain
name (``panda``: letters, digits, ``_`` and ``-``) is a name, not a file.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any, Literal, Protocol, TypeVar

from logtools.errors import LogcalInputError

__all__ = [
    "OptionSpec",
    "RobotOptions",
    "build_options",
    "option",
    "option_specs",
    "options_fields",
]

T = TypeVar("T", bound="RobotOptions")

_META = "logcal_option"
_VALUE_TYPES = (bool, int, float, str, Path)


@dataclass(frozen=True)
class RobotOptions:
    """A robot's options: none (robots without options of their own use this class itself)."""


@dataclass(frozen=True)
class _Declared:
    flag: str
    help: str
    metavar: str | None
    view: bool
    above: float | None
    at_least: float | None
    file: bool = False
    or_name: bool = False
    batch: bool = False
    info: bool = False


def option(
    *,
    flag: str,
    help: str,
    metavar: str | None = None,
    view: bool = False,
    default: Any = None,
    above: float | None = None,
    at_least: float | None = None,
    file: bool = False,
    or_name: bool = False,
    batch: bool = False,
    info: bool = False,
) -> Any:
    """A field of a :class:`RobotOptions` subclass that is also a CLI option and settings key.

    Args:
        flag: the option of ``logcal analyze`` (``--urdf``).
        help: its help text.
        metavar: what ``-h`` shows for its value (default from the type: NUMBER, N, TEXT, ...).
        view: ``logcal view`` takes it too.
        default: the value when not given (None: "not given", the analysis' own default).
        above: a number must be greater than this.
        at_least: a number must be at least this.
        file: the value names a file (a text or ``Path`` option; ``Path`` ones always do): a
            settings file may name only a file inside its archive.
        or_name: with ``file``: a plain name (letters, digits, ``_``, ``-``) is not a file.
        batch: ``logcal batch`` takes it too, for every log of the archive (over the
            ``logcal.toml`` key); not for an option naming a file.
        info: ``logcal info`` takes it too, and hands it to the robot's ``info`` hook
            (``RobotPlugin.info``: what the robot says of it, e.g. a URDF's transmissions).
    """
    if not flag.startswith("--"):
        raise ValueError(f"option flag {flag!r}: expected a long option such as --name")
    if or_name and not file:
        raise ValueError(f"option {flag}: or_name=True needs file=True")
    if batch and file:
        raise ValueError(f"option {flag}: batch=True is for options that name no file")
    declared = _Declared(flag, help, metavar, view, above, at_least, file, or_name, batch, info)
    return dataclasses.field(default=default, metadata={_META: declared})


@dataclass(frozen=True)
class OptionSpec:
    """One declared option of a robot.

    Attributes:
        key: the settings key (the field name), e.g. ``cutoff_hz``.
        flag: the CLI option, e.g. ``--cutoff-hz``.
        help: its help text.
        metavar: what ``-h`` shows for its value.
        view: ``logcal view`` takes it too.
        type: the value's type (``bool``, ``int``, ``float``, ``str``, ``Path`` or an Enum).
        above: a number must be greater than this (None: no bound).
        at_least: a number must be at least this (None: no bound).
        robot: the plugin declaring it (its ``name``; "" when asked of a bare class).
        file: the value names a file (declared ``file=True``, or of type ``Path``).
        or_name: a plain name (``panda``) is a name, not a file.
        batch: ``logcal batch`` takes it too.
        info: ``logcal info`` takes it too.
    """

    key: str
    flag: str
    help: str
    metavar: str
    view: bool
    type: type
    above: float | None = None
    at_least: float | None = None
    robot: str = ""
    file: bool = False
    or_name: bool = False
    batch: bool = False
    info: bool = False

    def expected(self) -> str:
        """What a value must be, in words ("a number > 0")."""
        if isinstance(self.type, type) and issubclass(self.type, Enum):
            return "one of " + ", ".join(str(m.value) for m in self.type)
        if self.type is bool:
            return "true or false"
        if self.type is str or self.type is Path:
            return "a non-empty text" if self.type is str else "a path"
        what = "a whole number" if self.type is int else "a number"
        if self.above is not None:
            return f"{what} > {self.above:g}"
        if self.at_least is not None:
            return f"{what} >= {self.at_least:g}"
        return what if self.type is int else f"a finite {what[2:]}"


def _value_type(hint: Any, where: str) -> type:
    """``X`` of a field annotated ``X`` or ``X | None``."""
    args = typing.get_args(hint)
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        rest = [a for a in args if a is not type(None)]
        if len(rest) == 1:
            hint = rest[0]
    if isinstance(hint, type) and (hint in _VALUE_TYPES or issubclass(hint, Enum)):
        return hint
    raise TypeError(
        f"{where}: an option's type must be bool, int, float, str, Path or an Enum "
        f"(optionally | None); got {hint!r}"
    )


def _default_metavar(kind: type) -> str:
    if issubclass(kind, Enum):
        return "|".join(str(m.value) for m in kind)
    return {bool: "", int: "N", float: "NUMBER", Path: "PATH"}.get(kind, "TEXT")


def options_fields(cls: type[RobotOptions], robot: str = "") -> tuple[OptionSpec, ...]:
    """The declared options of the options class ``cls``, in field order."""
    if not (isinstance(cls, type) and issubclass(cls, RobotOptions)):
        raise TypeError(f"{cls!r} is not a RobotOptions subclass")
    hints = typing.get_type_hints(cls)
    out = []
    for f in dataclasses.fields(cls):
        declared = f.metadata.get(_META)
        if declared is None:
            raise TypeError(f"{cls.__name__}.{f.name}: declare robot options with option(...)")
        kind = _value_type(hints[f.name], f"{cls.__name__}.{f.name}")
        if declared.file and kind not in (str, Path):
            raise TypeError(f"{cls.__name__}.{f.name}: file=True needs a str or Path option")
        names_file = declared.file or kind is Path
        if declared.batch and names_file:
            raise TypeError(f"{cls.__name__}.{f.name}: batch=True is for options that name no file")
        metavar = declared.metavar
        if metavar is None:
            metavar = (
                ("PATH_OR_NAME" if declared.or_name else "PATH")
                if names_file
                else _default_metavar(kind)
            )
        out.append(
            OptionSpec(
                key=f.name,
                flag=declared.flag,
                help=declared.help,
                metavar=metavar,
                view=declared.view,
                type=kind,
                above=declared.above,
                at_least=declared.at_least,
                robot=robot,
                file=names_file,
                or_name=declared.or_name,
                batch=declared.batch,
                info=declared.info,
            )
        )
    return tuple(out)


class _DeclaresOptions(Protocol):
    """What :func:`option_specs` reads of a ``RobotPlugin`` (named by shape: the plugin
    contract imports this module)."""

    @property
    def name(self) -> str: ...

    @property
    def options(self) -> type[RobotOptions]: ...


def option_specs(plugin: _DeclaresOptions) -> tuple[OptionSpec, ...]:
    """The options ``plugin`` (a ``RobotPlugin``) declares (``plugin.options``), in field
    order."""
    return options_fields(plugin.options, plugin.name)


def _convert(spec: OptionSpec, value: Any) -> Any:
    """``value`` as ``spec``'s type, or raise ValueError."""
    kind = spec.type
    if issubclass(kind, Enum):
        if isinstance(value, kind):
            return value
        for member in kind:
            if isinstance(value, str) and value == str(member.value):
                return member
        raise ValueError
    if kind is bool:
        if isinstance(value, bool):
            return value
        raise ValueError
    if kind is str:
        if isinstance(value, str) and value.strip():
            return value
        raise ValueError
    if kind is Path:
        if isinstance(value, (str, Path)) and str(value).strip():
            return Path(value)
        raise ValueError
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError
    if kind is int:
        if isinstance(value, float) and not value.is_integer():
            raise ValueError
        number: float = int(value)
    else:
        number = float(value)
    if not math.isfinite(number):
        raise ValueError
    if spec.above is not None and not number > spec.above:
        raise ValueError
    if spec.at_least is not None and not number >= spec.at_least:
        raise ValueError
    return number


def build_options(
    cls: type[T],
    values: Mapping[str, Any],
    *,
    source: Literal["cli", "settings"] = "settings",
    where: str = "",
) -> T:
    """An instance of ``cls`` from ``values`` (settings key -> value; None: not given).

    ``source`` says how to name a bad value: by its flag (``--cutoff-hz -1``, from the command
    line) or by its key (``cutoff_hz = -1``, from a settings file, prefixed by ``where``).

    Raises:
        LogcalInputError: a key ``cls`` does not declare, or a value that is not what the
            option expects; the message names the flag or key, the value and what was expected.
    """
    specs = {s.key: s for s in options_fields(cls)}
    prefix = f"{where}: " if where else ""
    kwargs: dict[str, Any] = {}
    for key, value in values.items():
        spec = specs.get(key)
        if spec is None:
            known = ", ".join(specs) or "none"
            raise LogcalInputError(
                f"{prefix}{key!r} is not an option of {cls.__name__}; expected one of: {known}"
            )
        if value is None:
            continue
        try:
            kwargs[key] = _convert(spec, value)
        except (ValueError, TypeError):
            shown = f"{spec.flag} {value}" if source == "cli" else f"{key} = {value!r}"
            raise LogcalInputError(f"{prefix}{shown}: expected {spec.expected()}") from None
    return cls(**kwargs)
