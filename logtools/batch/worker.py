"""What one worker does with one log: read, analyse, draw its views; never raises.

The function runs in another process (a local pool) or on another machine (Ray), so it takes
and returns plain picklable values, writes nothing into the output folder (the driver writes,
atomically) and returns the view files' bytes. Any failure, ours or the log's, becomes the
outcome's ``error``: one bad log never stops a batch.

Each log is cropped to its span (``AnalysisOptions.start_s``/``end_s``, the command line's
``--start``/``--end``, else the ``logcal.toml`` keys ``start``/``end``) through the same
:class:`~logtools.load.LoadRequest` that ``logcal analyze --start/--end`` builds.

The robot's own options come from the log's ``logcal.toml`` settings (plain values by key,
``LogSettings.options``) and, over them, from the command line (``AnalysisOptions.options``: the
options robots declare ``batch=True``), turned into typed options by
:func:`~logtools.analyze.options_from_settings` for ``AnalysisConfig(robot_options=...)``; the
views are drawn by :func:`logtools.views.write_views`, as ``logcal analyze --rrd`` does.
"""

from __future__ import annotations

import tempfile
import time
import traceback
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from logtools.batch.archive import LogJob
from logtools.errors import LogcalInputError

if TYPE_CHECKING:
    from calib.results import AnalysisResult
    from logtools.analyze import AnalysisConfig
    from logtools.batch.settings import LogSettings
    from logtools.load import LoadedLog

__all__ = ["AnalysisOptions", "LogOutcome", "analyse_job", "check_span", "log_span"]


@dataclass(frozen=True)
class AnalysisOptions:
    """Settings every log of a batch is analysed with (``logcal analyze``'s options).

    Attributes:
        repeats: bootstrap repeats per method-table row.
        seed: seed of the bootstrap draws (the same for every log: reproducible reports).
        discovery: run model-mismatch discovery.
        views: also draw each log's rerun recording (``.rrd``) and static image (``.png``) when
            its robot plugin has them.
        start_s, end_s: analyse each log from / up to this many seconds after its first sample
            (``--start``/``--end``; None: the ``logcal.toml`` keys ``start``/``end``, else the
            whole log).
        options: robot options given on the command line, as plain values by settings key
            (e.g. the tractor-trailer's ``{"baseline": "steady"}``); each wins over the same
            ``logcal.toml`` key.
    """

    repeats: int = 10
    seed: int = 0
    discovery: bool = True
    views: bool = True
    start_s: float | None = None
    end_s: float | None = None
    options: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        check_span(self.start_s, self.end_s)

    def fingerprint(self) -> str:
        """The settings that change a result, as text (part of each log's manifest key; the
        bounds and robot options only when given, so that a batch without them keeps its
        keys)."""
        span = "".join(
            f";{k}={v!r}"
            for k, v in (("start", self.start_s), ("end", self.end_s))
            if v is not None
        )
        given = "".join(f";{k}={v!r}" for k, v in sorted(self.options.items()))
        return (
            f"repeats={self.repeats};seed={self.seed};discovery={self.discovery};"
            f"views={self.views}{given}{span}"
        )


def check_span(start_s: float | None, end_s: float | None) -> None:
    """Bounds as ``--start``/``--end`` take them: finite seconds >= 0, the end after the start.

    Raises:
        LogcalInputError: which bound is wrong, and why.
    """
    import math

    for flag, v in (("--start", start_s), ("--end", end_s)):
        if v is not None and (not math.isfinite(v) or v < 0):
            raise LogcalInputError(
                f"{flag} {v:g}: expected seconds >= 0 from each log's first sample"
            )
    if start_s is not None and end_s is not None and end_s <= start_s:
        raise LogcalInputError(f"--end {end_s:g} s is not after --start {start_s:g} s")


def log_span(
    settings: LogSettings | None, options: AnalysisOptions
) -> tuple[float | None, float | None]:
    """The span a log is analysed over: each bound from ``options`` (the command line), else
    from its ``logcal.toml`` settings; None: not bounded."""
    start = options.start_s if options.start_s is not None else getattr(settings, "start_s", None)
    end = options.end_s if options.end_s is not None else getattr(settings, "end_s", None)
    return start, end


@dataclass(frozen=True)
class LogOutcome:
    """What became of one log.

    Attributes:
        job: the log.
        status: ``ok`` (analysed) or ``failed`` (``error`` says why).
        error: the error message (names file, topic or field for a bad log).
        error_kind: ``input`` (the log's or its settings' fault: a ``LogcalInputError`` or a
            stated limit of the data) or ``internal`` (a bug of ours; ``detail`` holds the
            traceback).
        detail: traceback of an internal error.
        result: the analysis as JSON (``AnalysisResult.to_dict()``).
        robot: the robot type analysed.
        start_ns, end_ns: first and last time of the aligned log (ns since the Unix epoch).
        views: suffix (``.rrd``, ``.png``) -> the file's bytes.
        notes: what was not drawn and why.
        seconds: wall time spent on the log.
    """

    job: LogJob
    status: str
    error: str | None = None
    error_kind: str | None = None
    detail: str | None = None
    result: dict[str, Any] | None = None
    robot: str | None = None
    start_ns: int | None = None
    end_ns: int | None = None
    views: dict[str, bytes] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    seconds: float = 0.0


def _known_errors() -> tuple[type[Exception], ...]:
    from calib.errors import CalibError
    from logtools.errors import LogcalError

    return (LogcalError, CalibError)


def _draw_views(
    loaded: LoadedLog, result: AnalysisResult, config: AnalysisConfig
) -> tuple[dict[str, bytes], list[str]]:
    """The robot's views (``.rrd``, ``.png``) as bytes, drawn by the one
    :func:`logtools.views.write_views` into a temporary folder (a view that fails, or a robot
    without views, is a note: the analysis stands)."""
    from logtools.views import write_views

    with tempfile.TemporaryDirectory(prefix="logcal-batch-") as tmp:
        rrd, png = Path(tmp) / "view.rrd", Path(tmp) / "view.png"
        try:
            written = write_views(
                [loaded],
                result,
                rrd=rrd,
                png=png,
                inputs=[Path(loaded.path)],
                config=config,
                on_error="note",
            )
        except Exception as err:  # e.g. an output check: the analysis still stands
            return {}, [f"views not drawn: {type(err).__name__}: {err}"]
        views = {
            path.suffix: path.read_bytes()
            for path in (written.rrd, written.png)
            if path is not None
        }
        return views, written.notes


EPOCH_FLOOR_NS = 946_684_800 * 10**9
"""2000-01-01 UTC: earlier first stamps are taken as relative times (a CSV's ``t`` from 0, a
simulation clock), not as when the log was recorded; such a log has no start time."""


def _time_span(t_ns: list[int]) -> tuple[int | None, int | None]:
    if not t_ns or min(t_ns) < EPOCH_FLOOR_NS:
        return None, None
    return int(min(t_ns)), int(max(t_ns))


def _no_longer_plain(path: str) -> str | None:
    """Why ``path`` is no longer a regular file or a real folder (None: it still is)."""
    import os
    import stat

    from logtools.batch.files import file_kind

    try:
        mode = os.lstat(path).st_mode
    except OSError as err:
        return f"cannot read it ({err.strerror or err})"
    if stat.S_ISREG(mode) or stat.S_ISDIR(mode):
        return None
    return f"is now {file_kind(mode)}; logcal reads regular files only"


def analyse_job(job: LogJob, options: AnalysisOptions) -> LogOutcome:
    """Analyse ``job`` with ``options``; every failure is returned, never raised."""
    t0 = time.perf_counter()
    if job.entry_error is not None or job.settings is None:
        return LogOutcome(
            job,
            "failed",
            error=job.entry_error or job.settings_error,
            error_kind="input",
            seconds=time.perf_counter() - t0,
        )
    changed = _no_longer_plain(job.path)
    if changed is not None:  # replaced by a link or a FIFO since the archive was walked
        return LogOutcome(
            job,
            "failed",
            error=f"{job.rel}: {changed}",
            error_kind="input",
            seconds=time.perf_counter() - t0,
        )
    try:
        from dataclasses import replace

        from logtools.analyze import AnalysisConfig, analyze_log, options_from_settings
        from logtools.channel_map import ChannelMap, load_channel_map
        from logtools.load import LoadRequest
        from logtools.robots import plugin_for

        s = job.settings
        cmap: ChannelMap | None = load_channel_map(s.channel_map) if s.channel_map else None
        if s.robot is not None:
            plugin = plugin_for(s.robot, where=f"{s.robot_from}: [robot]")
            base = cmap if cmap is not None else ChannelMap()
            cmap = replace(base, robot=replace(base.robot, type=plugin.name))
        start_s, end_s = log_span(s, options)
        check_span(start_s, end_s)  # one bound from the command line, one from logcal.toml
        cmap = LoadRequest.of(cmap, start_s=start_s, end_s=end_s)  # as analyze --start/--end
        config = AnalysisConfig(
            repeats=options.repeats,
            seed=options.seed,
            discovery=options.discovery,
            robot_options=options_from_settings(
                {**s.options, **options.options},
                where=s.sources[-1] if s.sources else "logcal.toml",
            ),
            window_s=0.0 if options.views else None,  # views draw every sample
        )
        loaded, result = analyze_log(job.path, channel_map=cmap, config=config)
        win = result.source.get("windows")  # a long log analysed by windows: its whole span
        start_ns, end_ns = _time_span(
            [win["first_ns"], win["last_ns"]]
            if isinstance(win, dict)
            else loaded.frame["t_ns"].to_list()
        )
        views: dict[str, bytes] = {}
        notes: list[str] = []
        if options.views:
            views, notes = _draw_views(loaded, result, config)
        return LogOutcome(
            job,
            "ok",
            result=result.to_dict(),
            robot=result.robot,
            start_ns=start_ns,
            end_ns=end_ns,
            views=views,
            notes=notes,
            seconds=time.perf_counter() - t0,
        )
    except Exception as err:
        from logtools.batch.budgets import Budgets, active, out_of_memory

        if out_of_memory(err):  # over --log-memory (RLIMIT_AS of the worker): the log's size
            message = (active() or Budgets(timeout_s=None)).memory_message(job.rel)
            return LogOutcome(
                job, "failed", error=message, error_kind="input", seconds=time.perf_counter() - t0
            )
        if isinstance(err, _known_errors()):
            return LogOutcome(
                job, "failed", error=str(err), error_kind="input", seconds=time.perf_counter() - t0
            )
        # a bug of ours on this log: recorded, the batch goes on
        return LogOutcome(
            job,
            "failed",
            error=f"internal error: {type(err).__name__}: {err}",
            error_kind="internal",
            detail=traceback.format_exc(),
            seconds=time.perf_counter() - t0,
        )
