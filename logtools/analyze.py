"""The ``logcal analyze`` pipeline: load -> segment -> calibrate -> discover, as one library call.

The library never prints: progress goes to an optional callback ``progress(stage: str)``.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Literal

import numpy as np
import polars as pl

from calib.results import AnalysisResult, CommandType, MethodResult, Segment
from logtools.errors import LogcalInputError, MissingSignalsError
from logtools.load import LoadedLog, load_log
from logtools.signals import Robot, SignalSource

__all__ = ["AnalysisConfig", "UnsupportedRobotError", "analyze_loaded", "analyze_log"]

Progress = Callable[[str], None]


class UnsupportedRobotError(LogcalInputError):
    """The log is of a robot whose analysis is not available yet."""


@dataclass(frozen=True)
class AnalysisConfig:
    """Settings of one analysis.

    Args:
        repeats: repeats (moving-block bootstrap replicates) per method table row.
        baseline: the model discovery compares against ("steady": the patent's steady-state
            relation; "transient": the off-axle trailer kinematics).
        seed: seed of every random draw (bootstrap), for reproducible reports.
        discovery: run model-mismatch discovery.
        per_segment: also report the method table per command type.
    """

    repeats: int = 10
    baseline: Literal["steady", "transient"] = "steady"
    seed: int = 0
    discovery: bool = True
    per_segment: bool = True


def _noop(_: str) -> None:
    return None


def analyze_log(
    path: str | os.PathLike[str],
    *,
    channel_map: Mapping[str, SignalSource] | None = None,
    config: AnalysisConfig | None = None,
    progress: Progress | None = None,
) -> tuple[LoadedLog, AnalysisResult]:
    """Read ``path`` (MCAP or CSV) and analyse it; returns the loaded log and the result."""
    progress = progress or _noop
    progress("reading log")
    loaded = load_log(path, channel_map)
    return loaded, analyze_loaded(loaded, config=config, progress=progress)


def _require(loaded: LoadedLog, names: tuple[str, ...]) -> None:
    missing = [n for n in names if n not in loaded.frame.columns]
    if missing:
        raise MissingSignalsError(
            loaded.path, missing, loaded.log.topic_names(), str(Robot.TRACTOR_TRAILER)
        )


def _usable_rows(frame: pl.DataFrame, cols: tuple[str, ...]) -> pl.DataFrame:
    """Rows where every column in ``cols`` is a finite number."""
    cond = pl.lit(True)
    for c in cols:
        cond = cond & pl.col(c).is_not_null() & pl.col(c).is_finite()
    return frame.filter(cond)


def _segments(t_s: np.ndarray, frame: pl.DataFrame) -> list[Segment]:
    from logtools.segmentation import segment_command

    if "kappa_cmd" not in frame.columns:
        return [Segment(0.0, float(t_s[-1]), CommandType.OTHER, 0, len(t_s))]
    return segment_command(t_s, frame["kappa_cmd"].to_numpy())


def _mask_for(segments: list[Segment], kind: CommandType, n: int) -> np.ndarray:
    mask = np.zeros(n, dtype=bool)
    for s in segments:
        if s.command_type == kind:
            mask[s.start_index : s.end_index] = True
    return mask


def _method_tables(
    kappa: np.ndarray,
    psi: np.ndarray,
    segments: list[Segment],
    cfg: AnalysisConfig,
    rng: np.random.Generator,
    progress: Progress,
) -> tuple[list[MethodResult], list[str]]:
    from calib.errors import InsufficientDataError
    from calib.tractor_trailer.repeats import methods_table

    rows: list[MethodResult] = []
    notes: list[str] = []
    groups: list[tuple[str, np.ndarray]] = [("all", np.ones(kappa.size, dtype=bool))]
    if cfg.per_segment:
        kinds = sorted({s.command_type for s in segments}, key=list(CommandType).index)
        groups += [(str(k), _mask_for(segments, k, kappa.size)) for k in kinds]
    for label, mask in groups:
        progress(f"least-squares methods ({label})")
        try:
            rows += methods_table(
                kappa[mask], psi[mask], segment=label, repeats=cfg.repeats, rng=rng
            )
        except InsufficientDataError as err:
            notes.append(f"methods on segment type {label!r} skipped: {err}")
    return rows, notes


def analyze_loaded(
    loaded: LoadedLog,
    *,
    config: AnalysisConfig | None = None,
    progress: Progress | None = None,
) -> AnalysisResult:
    """Analyse an already loaded log (see ``analyze_log``)."""
    cfg = config or AnalysisConfig()
    progress = progress or _noop
    if loaded.robot is not Robot.TRACTOR_TRAILER:
        raise UnsupportedRobotError(
            f"{loaded.path}: this log is of robot type {str(loaded.robot)!r}; logcal analyze "
            "calibrates the tractor_trailer robot today (diff_drive and manipulator_2link follow). "
            "If this is a tractor-trailer log, set the 'robot' entry of its 'logcal' metadata "
            "record or map its hitch-angle topic with --channel-map."
        )
    _require(loaded, ("psi", "kappa"))
    rng = np.random.default_rng(cfg.seed)
    frame = _usable_rows(loaded.frame, ("psi", "kappa"))
    if frame.height < 10:
        raise LogcalInputError(
            f"{loaded.path}: only {frame.height} samples have both a joint angle (psi) and a "
            "measured curvature (kappa); at least 10 are needed."
        )
    t_s = (frame["t_ns"].to_numpy() - frame["t_ns"][0]) / 1e9
    kappa = frame["kappa"].to_numpy()
    psi = frame["psi"].to_numpy()
    v = frame["v"].to_numpy() if "v" in frame.columns else None

    progress("segmenting by command type")
    segments = _segments(t_s, frame)
    methods, notes = _method_tables(kappa, psi, segments, cfg, rng, progress)

    from calib.estimators.recommend import calibrate_link_lengths

    progress("recommended estimate (errors-in-variables and transient fits)")
    estimate, own_rows = calibrate_link_lengths(t_s, kappa, psi, v, segments=segments, rng=rng)
    methods = methods + list(own_rows)

    discovery = None
    if cfg.discovery:
        from calib.discovery import discover

        progress("model-mismatch discovery")
        L1 = estimate.parameters["L1"].value
        L2 = estimate.parameters["L2"].value
        discovery = discover(frame, L1, L2, baseline=cfg.baseline, segments=segments, rng=rng)

    source = {
        "path": str(loaded.path),
        "samples": frame.height,
        "duration_s": float(t_s[-1]),
        "signals": {k: f"{s.topic}:{s.field}" for k, s in loaded.signals.sources.items()},
    }
    return AnalysisResult(
        robot=str(loaded.robot),
        segments=segments,
        methods=methods,
        estimate=estimate,
        discovery=discovery,
        truth=dict(loaded.truth),
        source=source,
        warnings=list(loaded.problems) + notes,
    )
