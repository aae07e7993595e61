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
from typing import Any

from threadpoolctl import threadpool_limits

from calib.results import AnalysisResult
from logtools.analysis_config import AnalysisConfig
from logtools.errors import LogcalInputError
from logtools.load import LoadedLog, load_log
from logtools.robots import plugin_for
from logtools.robots.options import RobotOptions
from logtools.signals import SignalSource

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
            that is not what its option expects (:func:`~logtools.robots.options.build_options`).
    """
    from logtools.robots import plugins
    from logtools.robots.options import build_options, option_specs

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
    result."""
    progress = progress or _noop
    progress("reading log")
    loaded = load_log(path, channel_map)
    return loaded, analyze_loaded(loaded, config=config, progress=progress)


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
    adequacy = combine_runs(list(zip(names, [r.adequacy for r in pooled.runs], strict=True)),
                            model)
    estimate = pooled.estimate
    if estimate is not None and adequacy.channels and not adequacy.explains:
        estimate = replace(
            estimate, parameters=under_misfit_all(estimate.parameters, adequacy),
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
        loaded, res = analyze_log(paths[0], channel_map=channel_map, config=cfg,
                                  progress=progress)
        return [loaded], res
    runs: list[tuple[LoadedLog, AnalysisResult]] = []
    errors: list[LogcalInputError] = []
    for i, p in enumerate(paths, 1):
        progress(f"run {i} of {len(paths)}: {p}")
        try:
            progress("reading log")
            loaded = load_log(p, channel_map)
            if runs and str(loaded.robot) != str(runs[0][0].robot):
                raise LogcalInputError(
                    f"{loaded.path}: a {loaded.robot} log among runs of robot "
                    f"{runs[0][0].robot} ({runs[0][0].path}); analyse each robot's runs "
                    "on their own."
                )
            runs.append((loaded, analyze_loaded(loaded, config=cfg, progress=progress)))
        except LogcalInputError as err:
            errors.append(err)
    if not runs:
        raise errors[0]
    plugin = plugin_for(str(runs[0][0].robot))
    if plugin.pool is not None:
        with threadpool_limits(limits=1, user_api="blas"):
            pooled = plugin.pool(runs, cfg, progress)
    else:
        pooled = AnalysisResult(
            robot=runs[0][1].robot, segments=[], methods=[], estimate=None,
            source={"runs": [r.source.get("path", "") for _, r in runs]},
            warnings=[f"the {plugin.title} has no pooled analysis: each run is reported "
                      "on its own"],
            runs=[r for _, r in runs],
        )
    pooled = _pooled_adequacy(pooled)
    return [lo for lo, _ in runs], replace(
        pooled,
        source={**pooled.source, "errors": [str(e) for e in errors]},
        warnings=[str(e) for e in errors] + list(pooled.warnings),
    )
