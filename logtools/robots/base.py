"""The shape every robot fills in: a :class:`RobotPlugin` declares its signals, how to tell its
logs apart, its analysis (segmentation, methods, estimators, discovery), its pooled analysis of
several runs, its readable report and its rerun views.

``logcal analyze``, ``view``, ``info``, ``simulate``, ``reproduce``, the report, the JSON and the
.rrd go through this interface only, so a new robot adds its own files plus one line in
:mod:`logtools.robots` (``_PLUGIN_MODULES``, or ``register(...)``). Its options are a typed
dataclass (:mod:`logtools.robot_options`) from which the CLI's options are generated.
Modelled on evo's one entry point per trajectory kind and pysindy's pluggable feature libraries:
the pipeline is generic, what differs between robots is declared in one object.

A plugin's numerics live in ``calib`` (e.g. ``calib.diff_drive``), its views in ``viz`` (named by
an import path, so that ``logtools`` never imports rerun); the plugin module in
``logtools.robots`` only wires them together.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

from logtools.robot_options import RobotOptions
from logtools.signals import RobotKey, SignalSource, SignalSpec

if TYPE_CHECKING:
    from pathlib import Path

    import polars as pl
    import typer
    from rich.console import RenderableType

    from calib.results import AnalysisResult, CalibrationResult, Estimate
    from logtools.analysis_config import AnalysisConfig
    from logtools.loaded import LoadedLog
    from logtools.signals import RobotConfig, SignalOrigin

__all__ = [
    "AnalyzeFn",
    "CommandsFn",
    "Derived",
    "FoundSignals",
    "PoolFn",
    "Progress",
    "RobotPlugin",
    "SamplesFn",
    "SignalDerivation",
    "SignalSpec",
    "Views",
    "lazy",
    "load_commands",
    "load_samples",
    "load_view",
    "load_views",
]

O_contra = TypeVar("O_contra", bound=RobotOptions, contravariant=True)

Progress = Callable[[str], None]


class AnalyzeFn(Protocol):
    """Analyse one loaded log: ``(loaded, config, progress) -> AnalysisResult``.

    ``config`` is a :class:`logtools.analysis_config.AnalysisConfig`. Each stage runs inside its own
    boundary (``logtools.stages.Stages``): a stage that lacks data or fails numerically says so
    in ``AnalysisResult.stages`` and the others still report. Raises ``LogcalInputError`` (or a
    subclass naming file, topic and field) only when the log cannot be analysed at all.
    """

    def __call__(
        self, loaded: LoadedLog, config: AnalysisConfig, progress: Progress
    ) -> AnalysisResult: ...


class PoolFn(Protocol):
    """Pool several runs of one robot: ``(runs, config, progress) -> AnalysisResult`` where
    ``runs`` pairs each loaded log with its own analysis; the result's ``runs`` holds those."""

    def __call__(
        self,
        runs: Sequence[tuple[LoadedLog, AnalysisResult]],
        config: AnalysisConfig,
        progress: Progress,
    ) -> AnalysisResult: ...


class Views(Protocol[O_contra]):
    """A robot's rerun views: ``(out, loaded, result, options) -> Path``, the file written.

    ``options`` is the robot's own options (an instance of ``RobotPlugin.options``, e.g. the
    tractor-trailer's ``method_for_psi``); ``loaded`` the read log, ``result`` its analysis (a
    pooled analysis is drawn run by run, each into its own file). Named by an import path
    (``RobotPlugin.views``) so that ``logtools`` never imports rerun.
    """

    def __call__(
        self, out: Path, loaded: LoadedLog, result: AnalysisResult, options: O_contra, /
    ) -> Path: ...


class CommandsFn(Protocol):
    """Adds a robot's subcommands to a command group (``logcal simulate`` or ``reproduce``):
    ``(group: typer.Typer) -> None``."""

    def __call__(self, group: typer.Typer, /) -> None: ...


class SamplesFn(Protocol):
    """Writes a robot's sample logs into a folder that exists: ``(out_dir) -> paths written``,
    the same bytes on every run (fixed presets and seeds; ``python -m logtools.sample_logs``)."""

    def __call__(self, out_dir: Path, /) -> list[Path]: ...


@dataclass(frozen=True)
class FoundSignals:
    """What a :class:`SignalDerivation` is given: the signals found in one log so far.

    Attributes:
        path: the log (for notes).
        signals: logical name -> frame (``t_ns`` int64 increasing, ``value`` float64), cleaned.
        sources: logical name -> where it came from.
        robot: the channel map's ``[robot]`` table, completed from the ``logcal`` metadata
            record (the keys declared ``RobotKey.from_metadata``).
        params_from: where each completed or given number of ``robot`` came from (for
            notes), by key.
    """

    path: str
    signals: Mapping[str, pl.DataFrame]
    sources: Mapping[str, SignalSource]
    robot: RobotConfig
    params_from: Mapping[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class Derived:
    """What a :class:`SignalDerivation` gives: the signal (None: it cannot be derived from this
    log), its source and origin, and notes for the log's problems either way.

    Attributes:
        signal: frame ``t_ns`` (int64 increasing), ``value`` (float64 finite); None: not derived.
        source: where it came from (topic ``(derived)``, field and formula the expression).
        origin: how it was obtained (the derivation's kind, expression and one sentence).
        notes: sentences for ``problems`` (why it was not derived, what was left out).
    """

    signal: pl.DataFrame | None = None
    source: SignalSource | None = None
    origin: SignalOrigin | None = None
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class SignalDerivation:
    """A signal a robot derives from others when a log lacks it (the tractor-trailer's curvature
    command from a steering command and the wheelbase, or from a velocity command).

    The signal resolution (:func:`logtools.channel_map.resolve_signals`) runs every plugin's
    derivations on every log (the robot is told from the signals found), after the channel
    map's formulas, in plugin order.

    Attributes:
        name: the signal it gives.
        derive: ``(found) -> Derived``, called when the log has no ``name`` and the channel map
            does not switch it off.
        check: ``(found) -> notes``, called on every log after the derivations: what the
            signals found mean for what this robot derives (a saturated steering angle gives no
            curvature); None: nothing to check.
    """

    name: str
    derive: Callable[[FoundSignals], Derived]
    check: Callable[[FoundSignals], Sequence[str]] | None = None


@dataclass(frozen=True)
class RobotPlugin:
    """One robot type.

    Attributes:
        name: the robot type as written in the ``logcal`` metadata record and the channel map's
            ``[robot] type`` (``tractor_trailer``, ``diff_drive``, ``manipulator``).
        title: what a person calls it ("tractor with an off-axle trailer").
        signals: the logical signals it reads; ``required`` ones must be present to analyse.
        identify: given the names of the logical signals found in a log, a short reason
            ("signals wheel_left, wheel_right") when they identify this robot, else None. Asked
            in ``_PLUGIN_MODULES`` order when neither channel map nor metadata names the robot.
        analyze: analyse one log.
        report: the robot's own detailed part of the readable report (rich renderables: method
            tables, diagnostics), shown with ``--methods``; the header, estimate, adequacy,
            stages and notes are drawn around it.
        summary: the few lines of the robot's own that belong beside the answer in every
            report (e.g. dead reckoning before/after); None: none.
        pooled_summary: the same for a pooled report of several runs (e.g. each run's dead
            reckoning before/after, and which runs calibration made worse).
        pool: analyse several runs together (None: each run is reported on its own).
        views: import path ``"viz.module:function"`` of the rerun views, a :class:`Views`
            function ``(out, loaded, result, options) -> Path`` returning the file written;
            None: no views yet.
        png: import path of a static PNG report image ``(out, loaded, result) -> Path``;
            None: none.
        options: the robot's own options, a frozen :class:`RobotOptions` dataclass whose fields
            are declared with :func:`logtools.robot_options.option` (flag, help, whether
            ``view`` takes it); ``analyze``/``view`` offer them, settings files name them by
            field name, the analysis reads them with ``AnalysisConfig.options(cls)``.
        uses_settings: the general ``AnalysisConfig`` settings only this robot reads: giving
            one for another robot is warned about.
        info: import path ``"module:function"`` of an :class:`~logtools.robots.info.InfoFn`
            saying what ``logcal info`` shows of the robot's options declared ``info=True``
            (the manipulator's URDF transmissions); None: nothing.
        simulate: import path ``"module:function"`` of a :class:`CommandsFn` adding the robot's
            ``logcal simulate`` subcommand(s); None: none.
        reproduce: the same for ``logcal reproduce`` (published results); None: none.
        samples: import path of a :class:`SamplesFn` writing the robot's sample logs
            (``sample_logs/``, ``logcal simulate samples``); None: none.
        robot_keys: the keys of the channel map's ``[robot]`` table it reads beyond plain
            nominal numbers (:class:`~logtools.signals.RobotKey`: a text, a positive length, a
            number the metadata record may give).
        identified_by: the sets of signals each of which ``identify`` takes as this robot
            (``(("wheel_left", "wheel_right"), ("odom_omega", "gyro_z"))``), for the message
            of a log no robot is found in; empty: its ``required`` signals.
        aliases: other names accepted for ``name`` (older metadata).
        span_signals: signals whose common time span sets the aligned frame (a joint signal
            ``q3`` matches ``q``; none present: all signals).
        prepare: completes the aligned frame after reading, given the channel map's
            ``[robot]`` table (e.g. the tractor-trailer derives the measured curvature).
        derived_signals: signals it derives from others when a log lacks them
            (:class:`SignalDerivation`; the tractor-trailer's ``kappa_cmd``).
        derive_pooled: its derived quantities (``CalibrationResult.derived``) of an estimate
            pooled by estimates (windows, runs), computed from the pooled parameters and their
            covariance: ``(pooled, pieces) -> {key: Estimate}`` (the tractor-trailer's
            L1 + L2); None: each derived quantity is pooled on its own.
    """

    name: str
    title: str
    signals: tuple[SignalSpec, ...]
    identify: Callable[[frozenset[str]], str | None]
    analyze: AnalyzeFn
    report: Callable[[AnalysisResult], list[RenderableType]]
    pool: PoolFn | None = None
    summary: Callable[[AnalysisResult], list[RenderableType]] | None = None
    pooled_summary: Callable[[AnalysisResult], list[RenderableType]] | None = None
    views: str | None = None
    png: str | None = None
    aliases: tuple[str, ...] = ()
    identified_by: tuple[tuple[str, ...], ...] = ()
    span_signals: tuple[str, ...] = ()
    prepare: Callable[[pl.DataFrame, RobotConfig], pl.DataFrame] | None = None
    derived_signals: tuple[SignalDerivation, ...] = ()
    derive_pooled: (
        Callable[[CalibrationResult, Sequence[CalibrationResult]], Mapping[str, Estimate]] | None
    ) = None
    options: type[RobotOptions] = RobotOptions
    uses_settings: tuple[str, ...] = ()
    info: str | None = None
    simulate: str | None = None
    reproduce: str | None = None
    samples: str | None = None
    robot_keys: tuple[RobotKey, ...] = ()

    @property
    def required(self) -> tuple[str, ...]:
        """Names of the signals this robot cannot be analysed without."""
        return tuple(s.name for s in self.signals if s.required)

    @property
    def identifying_signals(self) -> tuple[tuple[str, ...], ...]:
        """The sets of signals that identify this robot in a log (``identified_by``, else the
        required signals)."""
        return self.identified_by or ((self.required,) if self.required else ())


def load_view(path: str) -> Callable[..., Path]:
    """The function named by a ``"module:function"`` import path (``RobotPlugin.png``)."""
    import importlib

    module, _, name = path.partition(":")
    fn: Callable[..., Path] = getattr(importlib.import_module(module), name)
    return fn


def load_views(path: str) -> Views[Any]:
    """The :class:`Views` function named by ``RobotPlugin.views``."""
    fn: Views[Any] = load_view(path)
    return fn


def load_commands(path: str) -> CommandsFn:
    """The :class:`CommandsFn` named by ``RobotPlugin.simulate`` / ``reproduce``."""
    import importlib

    module, _, name = path.partition(":")
    fn: CommandsFn = getattr(importlib.import_module(module), name)
    return fn


def load_samples(path: str) -> SamplesFn:
    """The :class:`SamplesFn` named by ``RobotPlugin.samples``."""
    import importlib

    module, _, name = path.partition(":")
    fn: SamplesFn = getattr(importlib.import_module(module), name)
    return fn


def lazy(path: str) -> Callable[..., Any]:
    """A function that imports ``"module:function"`` when first called and forwards to it.

    Plugins declare ``analyze``, ``pool`` and ``report`` this way, so that loading every
    plugin's declaration (done to find any log's robot) imports no analysis code."""
    target: list[Callable[..., Any]] = []

    def call(*args: Any, **kwargs: Any) -> Any:
        if not target:
            target.append(load_view(path))
        return target[0](*args, **kwargs)

    call.__name__ = call.__qualname__ = path.rpartition(":")[2]
    return call
