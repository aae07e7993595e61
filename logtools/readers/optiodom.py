"""Read OptiOdom recordings (Sousa et al., INESC TEC / FEUP; ``sousarbarb/odometry-calibration``):
a differential drive with wheel encoders and OptiTrack ground truth.

A session folder holds ``<id>_metadata.csv`` (``key,value,...`` rows: ``type`` diff, ``ngear``
gear ratio, ``encRes`` encoder counts per motor revolution, ``Li`` nominal track (m), ``Di``
nominal wheel diameters right and left (m), ``N`` runs, ``L`` square side (m), ...) and run files
``<id>_run-NN.csv`` without header, 20 Hz: ``time (s), x_gt (m), y_gt (m), theta_gt (rad),
ticks_right, ticks_left`` with the ticks counted in each cycle.

This is the documented channel map of the format: each run becomes the single topic ``csv``
holding the logical signals ``wheel_right``, ``wheel_left`` (cumulative wheel angle, rad, =
2 pi cumsum(ticks) / (ngear encRes)), ``x``, ``y``, ``yaw`` (ground truth) and the raw
``ticks_right``, ``ticks_left``. Metadata: record ``logcal`` names the robot (``diff_drive``);
record ``logcal.nominal`` holds the nominal ``wheel_radius_right``, ``wheel_radius_left``,
``track_width`` (m), ``gear_ratio``, ``encoder_counts``, ``square_side`` (m) where given.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import polars as pl

from logtools.errors import LogcalInputError
from logtools.problems import Problem, ProblemKind
from logtools.readers.base import TIME_COLUMN, LogData, TopicInfo
from logtools.readers.csv_reader import CSV_TOPIC

__all__ = [
    "METADATA_SUFFIX",
    "NOMINAL_RECORD",
    "is_optiodom_metadata",
    "is_optiodom_run",
    "read_optiodom",
    "session_runs",
]

METADATA_SUFFIX = "_metadata.csv"
NOMINAL_RECORD = "logcal.nominal"
"""Metadata record with a diff drive's nominal parameters (not truth)."""

_COLUMNS = ("t", "x", "y", "yaw", "ticks_right", "ticks_left")


def _metadata_file(run: Path) -> Path | None:
    """``<id>_metadata.csv`` beside ``<id>_run-NN.csv`` (or any ``*_metadata.csv`` there)."""
    stem = run.name.split("_run-")[0]
    cand = run.with_name(stem + METADATA_SUFFIX)
    if cand.is_file():
        return cand
    found = sorted(run.parent.glob("*" + METADATA_SUFFIX))
    return found[0] if len(found) == 1 else None


def _read_metadata(path: Path) -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as err:
        raise LogcalInputError(f"{path}: cannot read the OptiOdom metadata ({err})") from err
    for line in text.splitlines():
        cells = [c.strip() for c in line.split(",")]
        if cells and cells[0]:
            out[cells[0]] = [c for c in cells[1:] if c]
    return out


def is_optiodom_run(path: str | os.PathLike[str], head: bytes = b"") -> bool:
    """True for a run CSV without header whose sibling ``*_metadata.csv`` says ``type,diff``."""
    p = Path(path)
    if p.suffix.lower() != ".csv" or p.name.endswith(METADATA_SUFFIX):
        return False
    first = head.split(b"\n", 1)[0] if head else b""
    if first and any(
        c.isalpha() for c in first.decode("utf-8", "replace").lower().replace("e", "")
    ):
        return False  # a header row: our own CSV format
    meta = _metadata_file(p)
    if meta is None:
        return False
    return _read_metadata(meta).get("type", [""])[0].lower() == "diff"


def is_optiodom_metadata(path: str | os.PathLike[str]) -> bool:
    """True for a session's ``*_metadata.csv`` (first row ``type,...``): not a run to read."""
    p = Path(path)
    if not p.name.endswith(METADATA_SUFFIX):
        return False
    try:
        with p.open("rb") as fh:
            return fh.read(5) == b"type,"
    except OSError:
        return False


def session_runs(folder: str | os.PathLike[str]) -> list[Path]:
    """The run files of an OptiOdom session folder (empty if it is not one), sorted."""
    p = Path(folder)
    if not p.is_dir() or not list(p.glob("*" + METADATA_SUFFIX)):
        return []
    return sorted(q for q in p.glob("*_run-*.csv") if is_optiodom_run(q))


def _number(meta: dict[str, list[str]], key: str, index: int, path: Path) -> float | None:
    vals = meta.get(key, [])
    if len(vals) <= index:
        return None
    try:
        v = float(vals[index])
    except ValueError:
        raise LogcalInputError(
            f"{path}: field {key!r} holds {vals[index]!r}; expected a number"
        ) from None
    return v if math.isfinite(v) else None


def read_optiodom(path: str | os.PathLike[str]) -> LogData:
    """Read one OptiOdom run file (its metadata from the sibling ``*_metadata.csv``).

    Raises:
        LogcalInputError: no metadata, metadata without ``ngear``/``encRes``, or a run file
            that is not 6 numeric columns (the message names the file and field).
    """
    p = Path(path)
    meta_path = _metadata_file(p)
    if meta_path is None:
        raise LogcalInputError(
            f"{p}: an OptiOdom run needs its session's <id>{METADATA_SUFFIX} beside it"
        )
    meta = _read_metadata(meta_path)
    ngear = _number(meta, "ngear", 0, meta_path)
    enc = _number(meta, "encRes", 0, meta_path)
    if not ngear or not enc:
        raise LogcalInputError(
            f"{meta_path}: fields 'ngear' and 'encRes' (gear ratio, encoder counts per motor "
            "revolution) are needed to turn ticks into wheel angles"
        )
    try:
        raw = np.loadtxt(p, delimiter=",", ndmin=2)
    except (OSError, ValueError) as err:
        raise LogcalInputError(
            f"{p}: not an OptiOdom run ({err}); expected rows of 6 numbers: time, x_gt, y_gt, "
            "theta_gt, ticks_right, ticks_left"
        ) from err
    if raw.shape[1] != 6 or raw.shape[0] < 2:
        raise LogcalInputError(
            f"{p}: {raw.shape[1]} columns, {raw.shape[0]} rows; expected at least 2 rows of 6: "
            "time, x_gt, y_gt, theta_gt, ticks_right, ticks_left"
        )
    problems: list[Problem] = []
    keep = np.all(np.isfinite(raw), axis=1)
    if not keep.all():
        n_bad = int((~keep).sum())
        problems.append(
            Problem(
                ProblemKind.NO_TIME,
                count=n_bad,
                message=f"{p}: {n_bad} rows with non-finite values dropped",
            )
        )
        raw = raw[keep]
    if np.any(np.diff(raw[:, 0]) <= 0):
        raise LogcalInputError(f"{p}: field 'time' (column 1) is not strictly increasing")
    k = 2 * math.pi / (ngear * enc)
    frame = pl.DataFrame(
        {
            TIME_COLUMN: np.round(raw[:, 0] * 1e9).astype(np.int64),
            "wheel_right": np.cumsum(raw[:, 4]) * k,
            "wheel_left": np.cumsum(raw[:, 5]) * k,
            "x": raw[:, 1],
            "y": raw[:, 2],
            "yaw": raw[:, 3],
            "ticks_right": raw[:, 4],
            "ticks_left": raw[:, 5],
        }
    )
    nominal: dict[str, str] = {"gear_ratio": repr(ngear), "encoder_counts": repr(enc)}
    track = _number(meta, "Li", 0, meta_path)
    d_r, d_l = _number(meta, "Di", 0, meta_path), _number(meta, "Di", 1, meta_path)
    side = _number(meta, "L", 0, meta_path)
    if track:
        nominal["track_width"] = repr(track)
    if d_r:
        nominal["wheel_radius_right"] = repr(d_r / 2)
        nominal["wheel_radius_left"] = repr((d_l or d_r) / 2)
    if side:
        nominal["square_side"] = repr(side)
    t = frame[TIME_COLUMN]
    info = TopicInfo(
        topic=CSV_TOPIC,
        schema_name="optiodom/run",
        schema_encoding="csv",
        message_encoding="csv",
        message_count=frame.height,
        first_ns=int(t[0]),
        last_ns=int(t[-1]),
    )
    metadata = {
        "logcal": {"robot": "diff_drive"},
        NOMINAL_RECORD: nominal,
        "optiodom": {"metadata_file": str(meta_path), "session": meta_path.parent.name},
    }
    return LogData(os.fspath(path), {CSV_TOPIC: frame}, {CSV_TOPIC: info}, metadata, problems)
