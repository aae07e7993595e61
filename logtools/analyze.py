"""The ``logcal analyze`` pipeline as one library call: read -> the robot's plugin analyses ->
(several runs) the plugin pools them.

Which robot a log comes from is decided when it is read (:mod:`logtools.robot`); everything
after that goes through the robot's :class:`~logtools.robots.base.RobotPlugin`. The library
never prints: progress goes to an optional callback ``progress(stage: str)``. The settings of
an analysis, :class:`AnalysisConfig`, live in :mod:`logtools.analysis_config` (named here too).

An analysis runs its linear algebra on one BLAS thread (``threadpoolctl``): its matrices are
tall and thin (a log's rows by a few parameters), where OpenBLAS's thread pool spins rather
than works; on the 2-core machine it made the 1-hour analysis ~35 % more expensive in CPU
Parallelism comes from analysing logs side by side (``logcal batch``).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Any

from threadpoolctl import threadpool_limits

from calib.results import AnalysisResult
from logtools.analysis_config import AnalysisConfig
from logtools.errors import LogcalInputError
from logtools.load import LoadedLog, load_log
from logtools.robot_options import RobotOptions
from logtools.robots import plugin_for
from logtools.signals import SignalSource

if TYPE_CHECKING:
    from logtools.windows import WindowPlan

__all__ = [
    "AnalysisConfig",
    "analyze_loaded",
    "analyze_log",
    "analyze_logs",
    "options_from_settings",
]

Progress = Callable[[str], None]


def options_from_settings(
    values: Mapping[str, Any], *, where: str = "settings"
) -> dict[str, RobotOptions]:
    """Robot options by plugin name from settings keys (``{"urdf": "panda"}``): each key goes to
    every registered robot whose options declare it; robots given no key are left out.

    Raises:
        LogcalInputError: a key no robot declares (the message lists the known keys), or a value
            that is not what its option expects (:func:`~logtools.robot_options.build_options`).
    """
    from logtools.robot_options import build_options, option_specs
    from logtools.robots import plugins

    out: dict[str, RobotOptions] = {}
    known: set[str] = set()
    for plugin in plugins():
        keys = {s.key for s in option_specs(plugin)}
        known |= keys
        mine = {k: v for k, v in values.items() if k in keys}
        if mine:
            out[plugin.name] = build_options(plugin.options, mine, where=where)
    unknown = sorted(set(values) - known)
    if unknown:
        raise LogcalInputError(
            f"{where}: {unknown[0]!r} is not an option of any robot; expected one of: "
            f"{', '.join(sorted(known)) or 'none'}"
        )
    return out


def _noop(_: str) -> None:
    return None


def analyze_log(
    path: str | os.PathLike[str],
    *,
    channel_map: Mapping[str, SignalSource] | None = None,
    config: AnalysisConfig | None = None,
    progress: Progress | None = None,
) -> tuple[LoadedLog, AnalysisResult]:
    """Read ``path`` (MCAP, ROS bag or CSV) and analyse it; returns the loaded log and the
    result.

    A long log (``config.window_s``; by default more than about 2 h of samples at 100 Hz) is
    analysed by time windows (:mod:`logtools.windows`): each window read and analysed on its
    own, then pooled; ``result.source["windows"]`` says how, ``result.runs`` holds each
    window's result and the loaded log returned is the last window's.

    Raises:
        LogcalInputError: the log cannot be read or analysed, or ``config.window_s`` is not a
            number >= 0.
    """
    progress = progress or _noop
    cfg = config or AnalysisConfig()
    plan = _window_plan(path, channel_map, cfg)
    if plan is not None:
        return _analyze_windows(os.fspath(path), plan, channel_map, cfg, progress)
    progress("reading log")
    loaded = load_log(path, channel_map)
    return loaded, analyze_loaded(loaded, config=cfg, progress=progress)


def _window_plan(
    path: str | os.PathLike[str],
    channel_map: Mapping[str, SignalSource] | None,
    cfg: AnalysisConfig,
) -> WindowPlan | None:
    from logtools.load import LoadRequest
    from logtools.windows import plan_windows

    req = channel_map if isinstance(channel_map, LoadRequest) else None
    return plan_windows(
        path, cfg.window_s, start_s=req.start_s if req else None, end_s=req.end_s if req else None
    )


def _analyze_windows(
    path: str,
    plan: WindowPlan,
    channel_map: Mapping[str, SignalSource] | None,
    cfg: AnalysisConfig,
    progress: Progress,
) -> tuple[LoadedLog, AnalysisResult]:
    """Each window of ``plan`` read, analysed and reduced to its result before the next is
    read; the results pooled (:func:`logtools.windows.pool_windows`)."""
    from logtools.channel_map import ChannelMap
    from logtools.load import LoadRequest
    from logtools.windows import pool_windows, release_memory, window_result

    base = (
        channel_map if isinstance(channel_map, ChannelMap) else ChannelMap(dict(channel_map or {}))
    )
    user_end = channel_map.end_s if isinstance(channel_map, LoadRequest) else None
    truth = channel_map.ground_truth if isinstance(channel_map, LoadRequest) else None

    def request(k: int) -> ChannelMap | None:
        a, b = plan.spans_s[k]
        # a window ends 1 ns before the next one starts: no sample is in two windows
        end = user_end if k == len(plan.spans_s) - 1 else b - 1e-9
        return LoadRequest.of(
            base, ground_truth=truth, start_s=a, end_s=end, origin_ns=plan.origin_ns
        )

    results: list[AnalysisResult] = []
    errors: list[str] = []
    counts: dict[str, int] = {}
    last: LoadedLog | None = None
    last_ok = -1
    n = len(plan.spans_s)

    def one(k: int) -> LoadedLog:
        # its own frame: a window's frames and analysis are released when it returns
        loaded = load_log(path, request(k))
        res = analyze_loaded(loaded, config=cfg, progress=progress)
        for topic, info in loaded.log.info.items():
            counts[topic] = counts.get(topic, 0) + info.message_count
        results.append(window_result(res, k + 1, plan.spans_s[k]))
        return loaded

    for k, (a, b) in enumerate(plan.spans_s):
        progress(f"window {k + 1} of {n}: {a:.0f}-{b:.0f} s")
        last = None  # the previous window's frames go before the next window is read
        release_memory()
        try:
            last, last_ok = one(k), k
        except LogcalInputError as err:
            errors.append(f"window {k + 1} ({a:.0f}-{b:.0f} s): {err}")
    progress(f"pooling {len(results)} windows")
    derive = plugin_for(str(results[0].robot)).derive_pooled if results else None
    pooled = pool_windows(path, plan, results, errors, counts, derive=derive)
    if last is None:  # the last window failed: the loaded log returned is the last one read
        last = load_log(path, request(last_ok))
    return last, pooled


def analyze_loaded(
    loaded: LoadedLog,
    *,
    config: AnalysisConfig | None = None,
    progress: Progress | None = None,
) -> AnalysisResult:
    """Analyse an already loaded log with its robot's plugin.

    Each stage runs inside its own boundary: a stage that lacks data or fails numerically says
    so in ``stages`` and the others still report.
    """
    plugin = plugin_for(str(loaded.robot), where=str(loaded.path))
    with threadpool_limits(limits=1, user_api="blas"):
        return plugin.analyze(loaded, config or AnalysisConfig(), progress or _noop)


def _pooled_adequacy(pooled: AnalysisResult) -> AnalysisResult:
    """A pooled result whose plugin set no adequacy gets the runs' combined verdict, and a pooled
    estimate over runs its model does not explain is widened and not determined (a tight pooled
    interval over a misfit is the worst kind: pooling shrinks it further)."""
    if pooled.adequacy is not None or not pooled.runs:
        return pooled
    from calib.adequacy import combine_runs, under_misfit_all

    names = [str(r.source.get("path", f"run {i}")) for i, r in enumerate(pooled.runs, 1)]
    model = pooled.estimate.method if pooled.estimate is not None else "each run's model"
    adequacy = combine_runs(list(zip(names, [r.adequacy for r in pooled.runs], strict=True)), model)
    estimate = pooled.estimate
    if estimate is not None and adequacy.channels and not adequacy.explains:
        estimate = replace(
            estimate,
            parameters=under_misfit_all(estimate.parameters, adequacy),
            derived=under_misfit_all(estimate.derived, adequacy),
            verdict=estimate.verdict + " " + adequacy.summary,
        )
    return replace(pooled, adequacy=adequacy, estimate=estimate)


def analyze_logs(
    paths: Sequence[str | os.PathLike[str]],
    *,
    channel_map: Mapping[str, SignalSource] | None = None,
    config: AnalysisConfig | None = None,
    progress: Progress | None = None,
) -> tuple[list[LoadedLog], AnalysisResult]:
    """Analyse several runs of one robot: each run on its own (``runs``) and, where the robot's
    plugin can pool, one estimate from all of them (``estimate``); a single path gives that
    run's result.

    A run that cannot be read is left out and named in ``source["errors"]`` (the others are
    still analysed and pooled).

    Raises:
        LogcalInputError: no run could be read (the first run's error), or the runs are of
            different robots.
    """
    progress = progress or _noop
    cfg = config or AnalysisConfig()
    if len(paths) == 1:
        loaded, res = analyze_log(paths[0], channel_map=channel_map, config=cfg, progress=progress)
        return [loaded], res
    runs: list[tuple[LoadedLog, AnalysisResult]] = []
    errors: list[LogcalInputError] = []
    windowed = False
    for i, p in enumerate(paths, 1):
        progress(f"run {i} of {len(paths)}: {p}")
        try:
            plan = _window_plan(p, channel_map, cfg)
            if plan is not None:  # a long run: by windows, its result pooled over them
                loaded, res = _analyze_windows(os.fspath(p), plan, channel_map, cfg, progress)
                windowed = True
            else:
                progress("reading log")
                loaded = load_log(p, channel_map)
            if runs and str(loaded.robot) != str(runs[0][0].robot):
                raise LogcalInputError(
                    f"{loaded.path}: a {loaded.robot} log among runs of robot "
                    f"{runs[0][0].robot} ({runs[0][0].path}); analyse each robot's runs "
                    "on their own."
                )
            if plan is None:
                res = analyze_loaded(loaded, config=cfg, progress=progress)
            runs.append((loaded, res))
        except LogcalInputError as err:
            errors.append(err)
    if not runs:
        raise errors[0]
    plugin = plugin_for(str(runs[0][0].robot))
    if windowed:  # the robot's joint fit needs every run's samples, which windows do not keep
        from logtools.windows import pool_runs

        pooled = pool_runs([r for _, r in runs], derive=plugin.derive_pooled)
    elif plugin.pool is not None:
        with threadpool_limits(limits=1, user_api="blas"):
            pooled = plugin.pool(runs, cfg, progress)
    else:
        pooled = AnalysisResult(
            robot=runs[0][1].robot,
            segments=[],
            methods=[],
            estimate=None,
            source={"runs": [r.source.get("path", "") for _, r in runs]},
            warnings=[
                f"the {plugin.title} has no pooled analysis: each run is reported on its own"
            ],
            runs=[r for _, r in runs],
        )
    pooled = _pooled_adequacy(pooled)
    return [lo for lo, _ in runs], replace(
        pooled,
        source={**pooled.source, "errors": [str(e) for e in errors]},
        warnings=[str(e) for e in errors] + list(pooled.warnings),
    )
