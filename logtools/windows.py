"""Windowed analysis of a long log: the plan of its time windows and the pooling of the
windows' results into one estimate.

A log longer than a window budget is analysed window by window (:func:`logtools.analyze.
analyze_log` runs the loop): each window is read on its own (an MCAP file's chunk index gives
the chunks of that time span, so a window costs its own chunks, not the file's), analysed as a
run by the robot's plugin, and only its result is kept (no per-sample arrays), so peak memory
is that of one window whatever the log's length.

Why not the robot's own pooled fit (``RobotPlugin.pool``)? It refits every run's samples at
once, which is what the windows are there to avoid. The windows' estimates are pooled here
instead, by their values and covariances (:func:`calib.pooling.gls.pool_gls`): generalised least
squares over all parameters at once, the generalised Cochran's Q test of whether the windows
agree, and where they disagree beyond their errors random effects (the multivariate
DerSimonian-Laird between-window covariance; a single widening factor Q/df where some window
lacks a parameter) and the parameters flagged. Each
window's covariance is taken with its correlations and its reported standard errors (a window
whose robot widened an interval for a misfit counts with the wider one); a parameter a window
does not determine (no finite std) takes no part from it. The pooled result carries the pooled
covariance, and the robot recomputes its derived quantities from it (``RobotPlugin.
derive_pooled``, e.g. the tractor's L1 + L2 from the pooled L1, L2 and their covariance). When
some window has no covariance, each parameter is pooled on its own instead (inverse-variance
weighting, :func:`calib.pooling.meta.pool_estimates`, the batch's meta-analysis), and so is
each derived quantity; the pooled result then has no covariance.

A single change of the parameters between consecutive windows (a trailer swapped mid-log) is
tested with :func:`calib.adequacy.parameter_change` and reported in the adequacy, as a robot
reports one within a log. Adequacy: the pooled model explains the log only if it explains every
window (:func:`calib.adequacy.combine_runs`).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import gc
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

from calib.adequacy import PieceFit, parameter_change
from calib.adequacy.combine import combine_runs
from calib.adequacy.verdict import NOT_EXPLAINED
from calib.pooling.estimates import DeriveFn, one_method, pool_pieces, pooled_estimate
from calib.results import AnalysisResult, CalibrationResult, json_safe
from logtools.errors import LogcalInputError
from logtools.readers import LogExtent, log_extent, read_log

__all__ = [
    "AUTO_ROWS",
    "MAX_WINDOWS",
    "WINDOW_ROWS",
    "DeriveFn",
    "Reduced",
    "WindowPlan",
    "check_window",
    "plan_windows",
    "pool_runs",
    "pool_windows",
    "release_memory",
    "window_result",
]

AUTO_ROWS = 720_000
"""Samples of the fastest topic above which a log is analysed by windows when no window is
asked for: 2 h at 100 Hz (a 4-hour 100 Hz log analysed whole peaks near 1 GB)."""

WINDOW_ROWS = 360_000
"""Samples of the fastest topic per automatic window: 1 h at 100 Hz (2 h at 50 Hz)."""

MIN_AUTO_WINDOW_S = 600.0
"""The shortest automatic window (s), whatever the rate."""

MAX_WINDOWS = 100_000
"""The most windows one log is cut into. The count is worked out before any window is made:
a log whose clock jumps decades (or whose summary claims it does) with ``--window 10`` would
otherwise be a plan of hundreds of millions of windows (3.5 GB, then MemoryError; issue 34),
and is a named error instead."""

_YEAR_S = 365.25 * 86400.0


def _duration_words(seconds: float) -> str:
    if seconds >= _YEAR_S:
        return f"{seconds / _YEAR_S:.3g} years"
    if seconds >= 86400.0:
        return f"{seconds / 86400.0:.3g} days"
    return f"{seconds:.6g} s"


def _check_window_count(
    path: str | os.PathLike[str], extent: LogExtent, lo: float, hi: float, window_s: float
) -> None:
    """Raise :class:`LogcalInputError` when ``[lo, hi]`` cut into ``window_s`` windows would make
    more than :data:`MAX_WINDOWS` (computed, not built)."""
    count = math.ceil((hi - lo) / window_s)
    if count <= MAX_WINDOWS:
        return
    name = os.fsdecode(os.fspath(path))
    raise LogcalInputError(
        f"{name}: spans {_duration_words(hi - lo)} (log_time {extent.first_ns} .. "
        f"{extent.last_ns} ns); windows of {window_s:g} s would be {count:,} windows (at most "
        f"{MAX_WINDOWS:,}): its clock jumps or its index claims a span it does not hold. Crop "
        "it with --start/--end, choose a longer --window, or --window 0 to analyse it whole."
    )


@dataclass(frozen=True)
class WindowPlan:
    """The windows of one log.

    Attributes:
        origin_ns: the log's first log time (ns); windows count seconds from it.
        spans_s: each window's first and last second after ``origin_ns`` (the last window
            takes a remainder shorter than half a window).
        window_s: the window length asked for or chosen.
        automatic: chosen because the log is long (no ``--window`` given).
        extent: the log's time span and message counts (from its index, or from one read).
        whole: the windows cover the whole log (no ``--start``/``--end``), so that the
            messages read over all windows must add up to the extent's counts.
    """

    origin_ns: int
    spans_s: tuple[tuple[float, float], ...]
    window_s: float
    automatic: bool
    extent: LogExtent
    whole: bool

    def describe(self) -> str:
        """``analysed in 24 windows of 3600 s (automatic: ...)``."""
        why = (
            f" (automatic: {self.extent.duration_s / 3600:.3g} h at "
            f"{self.extent.rate_hz:.3g} Hz; --window 0 analyses it whole)"
            if self.automatic
            else ""
        )
        return f"analysed in {len(self.spans_s)} windows of {self.window_s:g} s{why}"


def check_window(value: float | None, *, where: str = "--window") -> None:
    """Raise :class:`LogcalInputError` unless ``value`` is None or a finite number >= 0."""
    if value is None:
        return
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise LogcalInputError(
            f"{where} {value!r}: expected seconds (a number >= 0; 0: the whole log at once)"
        )
    if not math.isfinite(value) or value < 0:
        raise LogcalInputError(
            f"{where} {value:g}: expected seconds >= 0 (0: the whole log at once)"
        )


def _extent_by_reading(path: str | os.PathLike[str]) -> LogExtent | None:
    """The extent of a log whose format keeps no index: read it once (its frames dropped)."""
    log = read_log(path)
    firsts = [i.first_ns for i in log.info.values() if i.first_ns is not None]
    lasts = [i.last_ns for i in log.info.values() if i.last_ns is not None]
    if not firsts or not lasts:
        return None
    return LogExtent(
        min(firsts),
        max(lasts),
        {t: i.message_count for t, i in log.info.items() if i.message_count},
    )


def plan_windows(
    path: str | os.PathLike[str],
    window_s: float | None,
    *,
    start_s: float | None = None,
    end_s: float | None = None,
) -> WindowPlan | None:
    """The windows to analyse ``path`` by, or None to analyse it whole.

    ``window_s``: 0 whole; None automatic (windows of ``WINDOW_ROWS`` samples at the log's
    rate when it holds more than ``AUTO_ROWS``; only for a log whose index gives its extent
    without reading it, an MCAP file with a summary); > 0 windows of that length (a log
    without an index is read once to learn its span). ``start_s``/``end_s`` (seconds from the
    log's first sample) restrict the span the windows cover. A span no longer than one window
    is analysed whole.

    Raises:
        LogcalInputError: ``window_s`` is not a number >= 0, or the span would make more
            than :data:`MAX_WINDOWS` windows.
    """
    check_window(window_s)
    if window_s == 0:
        return None
    extent = log_extent(path)
    if extent is None:
        if window_s is None:
            return None
        extent = _extent_by_reading(path)
        if extent is None:
            return None
    lo = max(0.0, start_s or 0.0)
    hi = min(extent.duration_s, math.inf if end_s is None else end_s)
    if not hi > lo:
        return None  # reading says what is wrong with the span
    automatic = window_s is None
    if window_s is None:
        rate = extent.rate_hz
        if (hi - lo) * rate <= AUTO_ROWS:
            return None
        window_s = max(MIN_AUTO_WINDOW_S, float(round(WINDOW_ROWS / rate)))
    if hi - lo <= window_s:
        return None
    _check_window_count(path, extent, lo, hi, window_s)
    edges = [lo]
    while edges[-1] + window_s < hi:
        edges.append(edges[-1] + window_s)
    if hi - edges[-1] < 0.5 * window_s and len(edges) > 1:
        edges.pop()  # a short remainder joins the last window
    spans = tuple((a, b) for a, b in zip(edges, [*edges[1:], hi], strict=True))
    return WindowPlan(
        extent.first_ns,
        spans,
        float(window_s),
        automatic,
        extent,
        whole=start_s is None and end_s is None,
    )


class Reduced:
    """An analysis object (a robot's section or discovery result) reduced to what it shows:
    its JSON (``to_dict``) and, where it has one, its report text (``report``). The object
    itself may hold per-sample arrays (a fitter's context, corrected signals for the views)
    that a window's result must not keep."""

    def __init__(self, obj: Any) -> None:
        self._doc = obj.to_dict() if hasattr(obj, "to_dict") else json_safe(obj)
        self._report = obj.report() if callable(getattr(obj, "report", None)) else None

    def to_dict(self) -> Any:
        return self._doc

    def report(self) -> Any:
        return self._report if self._report is not None else ""


def release_memory() -> None:
    """Give a finished window's memory back before the next window is read: collect the
    reference cycles an analysis leaves (some hold its arrays until the cyclic collector runs,
    which would keep two windows alive at once), then, where the C library is glibc, return
    the freed heap to the system (``malloc_trim``; otherwise freed blocks stay in the process
    and its resident size creeps up from window to window)."""
    gc.collect()
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        trim = libc.malloc_trim
    except (OSError, AttributeError):
        return  # not glibc (macOS, musl without it, Windows): the collector's part is done
    trim(0)


def window_result(
    result: AnalysisResult, index: int, span_s: tuple[float, float]
) -> AnalysisResult:
    """One window's result as the pooled result keeps it: no artifacts (the per-sample arrays
    views and pooled fits use), its sections and discovery reduced to their JSON and report
    text (:class:`Reduced`; the JSON is unchanged), its window in ``source["window"]``."""
    return replace(
        result,
        artifacts={},
        sections={k: Reduced(v) for k, v in result.sections.items()},
        discovery=None if result.discovery is None else Reduced(result.discovery),
        source={
            **result.source,
            "window": {"index": index, "start_s": span_s[0], "end_s": span_s[1]},
        },
    )


def _estimates_and_labels(
    pieces: Sequence[AnalysisResult],
) -> tuple[list[CalibrationResult], list[str]]:
    """The estimates of ``pieces`` (each with one) and the labels that name them."""
    return [r.estimate for r in pieces if r.estimate is not None], [
        window_label(r) for r in pieces if r.estimate is not None
    ]


def window_label(result: AnalysisResult) -> str:
    """``window 3 (7200-10800 s)`` for a window's result, else its path."""
    w = result.source.get("window")
    if not isinstance(w, Mapping):
        return str(result.source.get("path", ""))
    return f"window {w['index']} ({w['start_s']:.0f}-{w['end_s']:.0f} s)"


def _change(windows: Sequence[AnalysisResult], names: Sequence[str]) -> Any:
    pieces = []
    for r in windows:
        w = r.source.get("window")
        if r.estimate is None or not isinstance(w, Mapping):
            continue
        ps = r.estimate.parameters
        pieces.append(
            PieceFit(
                float(w["start_s"]),
                float(w["end_s"]),
                {n: ps[n].value for n in names if n in ps and ps[n].identifiable},
                {n: ps[n].std for n in names if n in ps and ps[n].identifiable},
            )
        )
    return parameter_change(pieces, list(names)) if names else None


def pool_windows(
    path: str,
    plan: WindowPlan,
    windows: Sequence[AnalysisResult],
    errors: Sequence[str],
    counts: Mapping[str, int],
    *,
    derive: DeriveFn | None = None,
) -> AnalysisResult:
    """One result of a log analysed by ``plan``'s windows: each window's own result in
    ``runs``, the parameters pooled over them in ``estimate`` (see the module docstring; the
    robot's ``derive`` recomputes its derived quantities from the pooled parameters and
    covariance), ``source["windows"]`` the plan, and warnings for windows that could not be
    analysed, parameters that differ between windows and messages that do not add up to the
    log's index (``counts``: messages read per topic over all windows).

    Raises:
        LogcalInputError: no window could be analysed (the first window's error).
    """
    if not windows:
        raise LogcalInputError(errors[0] if errors else f"{path}: no window could be read")
    robot = windows[0].robot
    warnings: list[str] = [plan.describe()]
    warnings += [f"{path}: {e}" for e in errors]
    warnings += _count_mismatch(path, plan, counts)
    estimate = None
    change = None
    stats: dict[str, Any] = {}
    with_estimate = [r for r in windows if r.estimate is not None]
    labelled = [(window_label(r), r.adequacy) for r in windows]
    if not with_estimate:
        adequacy = combine_runs(labelled, "each window's model")
    else:
        ests, names = _estimates_and_labels(with_estimate)
        params, derived, cov, stats, more = pool_pieces(ests, names, "windows", derive)
        warnings += more
        model = one_method(ests, "each window's method")
        adequacy = combine_runs(labelled, model)
        change = _change(with_estimate, list(params))
        if change is not None:
            warnings.append(f"{path}: {change.note} (between windows)")
            adequacy = replace(
                adequacy,
                verdict=NOT_EXPLAINED,
                changes=(*adequacy.changes, change),
                notes=(
                    *adequacy.notes,
                    f"one parameter set does not hold over the windows: {change.note}",
                ),
            )
        estimate = pooled_estimate(
            params, derived, cov, ests, len(windows), adequacy, model, "window"
        )
    truths = [dict(r.truth) for r in windows]
    source = {
        "path": path,
        "windows": _windows_source(plan, len(windows), errors, stats),
        "duration_s": plan.extent.duration_s,
        "runs_pooled": len(with_estimate),
    }
    return AnalysisResult(
        robot=robot,
        segments=[],
        methods=[],
        estimate=estimate,
        adequacy=adequacy,
        truth=truths[0] if all(t == truths[0] for t in truths) else {},
        source=source,
        warnings=warnings,
        runs=list(windows),
    )


def _count_mismatch(path: str, plan: WindowPlan, counts: Mapping[str, int]) -> list[str]:
    """A warning when the whole log's windows read other message counts than its index lists
    (``counts``: messages read per topic)."""
    if not plan.whole or dict(counts) == {t: n for t, n in plan.extent.messages.items() if n}:
        return []
    read, listed = sum(counts.values()), sum(plan.extent.messages.values())
    return [
        f"{path}: the windows read {read} messages and the file's summary "
        f"lists {listed}: a message outside the chunks its index lists, or a "
        "summary that disagrees with the file"
    ]


def _windows_source(
    plan: WindowPlan, analysed: int, errors: Sequence[str], stats: dict[str, Any]
) -> dict[str, Any]:
    """``source["windows"]``: the plan, how many windows were analysed, the errors and the
    pooling per name."""
    return {
        "count": len(plan.spans_s),
        "window_s": plan.window_s,
        "first_ns": plan.origin_ns + round(plan.spans_s[0][0] * 1e9),
        "last_ns": min(plan.extent.last_ns, plan.origin_ns + round(plan.spans_s[-1][1] * 1e9)),
        "automatic": plan.automatic,
        "analysed": analysed,
        "spans_s": [list(s) for s in plan.spans_s],
        "errors": list(errors),
        "pooling": stats,
    }


def pool_runs(
    results: Sequence[AnalysisResult], *, derive: DeriveFn | None = None
) -> AnalysisResult:
    """Several runs pooled by their estimates (the pooling of :func:`pool_windows`, without the
    test for a change in time): what ``analyze_logs`` uses when a run was analysed by windows,
    whose samples the robot's own pooled fit would need. ``derive``: the robot's derived
    quantities of the pooled estimate (``RobotPlugin.derive_pooled``)."""
    labels = [str(r.source.get("path", "")) for r in results]
    labelled = list(zip(labels, [r.adequacy for r in results], strict=True))
    with_estimate = [r for r in results if r.estimate is not None]
    warnings = [
        "runs analysed by windows: the runs are pooled by their estimates and "
        "covariances, not by the robot's joint fit"
    ]
    estimate = None
    stats: dict[str, Any] = {}
    if not with_estimate:
        adequacy = combine_runs(labelled, "each run's model")
    else:
        ests, names = _estimates_and_labels(with_estimate)
        params, derived, cov, stats, more = pool_pieces(ests, names, "runs", derive)
        warnings += [w.replace("the windows of the log", "the runs") for w in more]
        model = one_method(ests, "each run's method")
        adequacy = combine_runs(labelled, model)
        estimate = pooled_estimate(params, derived, cov, ests, len(results), adequacy, model, "run")
    truths = [dict(r.truth) for r in results]
    return AnalysisResult(
        robot=results[0].robot,
        segments=[],
        methods=[],
        estimate=estimate,
        adequacy=adequacy,
        truth=truths[0] if all(t == truths[0] for t in truths) else {},
        source={"runs": labels, "runs_pooled": len(with_estimate), "pooling": stats},
        warnings=warnings,
        runs=list(results),
    )
