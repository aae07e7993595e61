"""Read a TUM trajectory file: a ground-truth pose per line, ``t x y z qx qy qz qw``.

The format of the TUM RGB-D benchmark, written by evo (``evo_traj --save_as_tum``), ORB-SLAM,
motion-capture exporters and many SLAM tools: space (or tab) separated, time ``t`` in seconds
(usually epoch), position in m, orientation as a unit quaternion, ``#`` starting a comment.

The file becomes the single topic ``csv`` (the pseudo-topic of a text table, so that its
columns are read by their logical names): ``x``, ``y``, ``yaw`` (rad, from the quaternion) and
the raw ``z``, ``qx``, ``qy``, ``qz``, ``qw``. Read on its own (``logcal info FILE.tum``) it is a
log holding a pose; joined to another log (``--ground-truth FILE.tum``, see
:func:`logtools.load.load_log`) it is that log's ground-truth pose.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import polars as pl

from logtools.errors import NotAnMcapError
from logtools.problems import Problem, ProblemKind
from logtools.readers.base import TIME_COLUMN, LogData, TopicInfo
from logtools.readers.csv_reader import CSV_TOPIC

__all__ = ["TUM_COLUMNS", "TUM_SUFFIXES", "is_tum", "read_tum", "write_tum"]

TUM_COLUMNS = ("t", "x", "y", "z", "qx", "qy", "qz", "qw")
"""The eight columns of a TUM line, in order."""
TUM_SUFFIXES = (".tum",)
"""File suffixes read as TUM without looking inside (``.txt`` files are recognised by content)."""
_SCHEMA = "tum/trajectory"
_INT64_NS_LIMIT_S = 9.2e9


def _data_lines(text: str) -> list[str]:
    return [ln for ln in (raw.strip() for raw in text.splitlines()) if ln and ln[0] != "#"]


def is_tum(path: str | os.PathLike[str], head: bytes | None = None) -> bool:
    """True for a ``.tum`` file, or a ``.txt`` whose first data line is 8 numbers separated
    by blanks (no commas)."""
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix in TUM_SUFFIXES:
        return True
    if suffix != ".txt":
        return False
    if head is None:
        try:
            with p.open("rb") as fh:
                head = fh.read(4096)
        except OSError:
            return False
    lines = _data_lines(head.decode("utf-8", "replace"))
    if not lines or "," in lines[0]:
        return False
    cells = lines[0].split()
    try:
        [float(c) for c in cells]
    except ValueError:
        return False
    return len(cells) == len(TUM_COLUMNS)


def _exact_ns(text: str, value: float) -> int:
    """The stamp ``text`` (s) in integer ns, exactly for plain decimals (an epoch time with 9
    decimals does not fit a float64 to the nanosecond); ``value`` rounded otherwise (0 for a
    non-finite value, whose line is dropped)."""
    whole, _, frac = text.lstrip("+").partition(".")
    negative = whole.startswith("-")
    whole = whole.lstrip("-")
    if (whole or frac) and (whole.isdigit() or not whole) and (frac.isdigit() or not frac):
        ns = int(whole or "0") * 10**9 + int((frac + "0" * 9)[:9])
        return -ns if negative else ns
    return round(value * 1e9) if math.isfinite(value) else 0


def read_tum(path: str | os.PathLike[str]) -> LogData:
    """Read a TUM trajectory file into a :class:`LogData` with the topic ``csv``.

    Lines that are not 8 numbers are refused with their line number; rows out of time order are
    sorted (with a problem), repeated stamps keep their first row; a quaternion far from unit
    length is normalised (with a problem).

    Raises:
        NotAnMcapError: the file cannot be read, holds no pose, or a line is not 8 numbers.
    """
    name = os.fspath(path)
    try:
        text = Path(name).read_text(encoding="utf-8", errors="replace")
    except OSError as err:
        raise NotAnMcapError(name, f"cannot read it: {err.strerror or err}") from err
    rows: list[list[float]] = []
    stamps: list[int] = []
    for number, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        cells = line.split()
        try:
            values = [float(c) for c in cells]
        except ValueError:
            values = []
        if len(values) != len(TUM_COLUMNS):
            raise NotAnMcapError(
                name,
                f"line {number} of the TUM trajectory is {line[:60]!r}; expected 8 numbers "
                "'t x y z qx qy qz qw' separated by spaces ('#' starts a comment)",
            )
        if abs(values[0]) > _INT64_NS_LIMIT_S:
            raise NotAnMcapError(
                name,
                f"line {number} of the TUM trajectory has the time {cells[0]}, which is no "
                "time in seconds (beyond +-9.2e9 s)",
            )
        rows.append(values)
        stamps.append(_exact_ns(cells[0], values[0]))
    if len(rows) < 2:
        raise NotAnMcapError(name, f"a TUM trajectory needs at least 2 poses; it has {len(rows)}")
    raw_rows = np.asarray(rows, dtype=np.float64)
    exact = np.asarray(stamps, dtype=np.int64)
    problems: list[Problem] = []
    finite = np.all(np.isfinite(raw_rows), axis=1)
    if not finite.all():
        n_bad = int((~finite).sum())
        problems.append(
            Problem(
                ProblemKind.NO_TIME,
                CSV_TOPIC,
                count=n_bad,
                message=f"{name}: {n_bad} TUM lines with non-finite values dropped",
            )
        )
        raw_rows, exact = raw_rows[finite], exact[finite]
    if np.any(np.diff(exact) < 0):
        problems.append(
            Problem(
                ProblemKind.UNSORTED,
                CSV_TOPIC,
                count=int(np.sum(np.diff(exact) < 0)),
                message=f"{name}: TUM time is not increasing; lines were sorted",
            )
        )
        order = np.argsort(exact, kind="stable")
        raw_rows, exact = raw_rows[order], exact[order]
    t_ns = exact
    keep = np.concatenate(([True], np.diff(t_ns) > 0))
    if not keep.all():
        problems.append(
            Problem(
                ProblemKind.UNSORTED,
                CSV_TOPIC,
                count=int((~keep).sum()),
                message=f"{name}: {int((~keep).sum())} TUM lines repeat the "
                "previous stamp; the first of each was kept",
            )
        )
        raw_rows, t_ns = raw_rows[keep], t_ns[keep]
    q = raw_rows[:, 4:8]
    norm = np.linalg.norm(q, axis=1)
    if np.any(norm == 0):
        raise NotAnMcapError(
            name,
            "a TUM line has the quaternion (0, 0, 0, 0); expected a unit quaternion qx qy qz qw",
        )
    if np.any(np.abs(norm - 1) > 1e-3):
        problems.append(
            Problem(
                ProblemKind.SIGNAL,
                CSV_TOPIC,
                count=int(np.sum(np.abs(norm - 1) > 1e-3)),
                message=f"{name}: TUM quaternions of length up to "
                f"{float(np.max(np.abs(norm - 1))) + 1:.4g} were normalised",
            )
        )
    qx, qy, qz, qw = (q / norm[:, None]).T
    yaw = np.arctan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
    frame = pl.DataFrame(
        {
            TIME_COLUMN: t_ns,
            "x": raw_rows[:, 1],
            "y": raw_rows[:, 2],
            "yaw": yaw,
            "z": raw_rows[:, 3],
            "qx": raw_rows[:, 4],
            "qy": raw_rows[:, 5],
            "qz": raw_rows[:, 6],
            "qw": raw_rows[:, 7],
        }
    )
    info = TopicInfo(
        topic=CSV_TOPIC,
        schema_name=_SCHEMA,
        schema_encoding="tum",
        message_encoding="tum",
        message_count=frame.height,
        first_ns=int(t_ns[0]),
        last_ns=int(t_ns[-1]),
    )
    return LogData(name, {CSV_TOPIC: frame}, {CSV_TOPIC: info}, {"tum": {"file": name}}, problems)


def write_tum(
    path: str | os.PathLike[str],
    t_s: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    yaw: np.ndarray,
    *,
    header: str = "",
) -> None:
    """Write a planar pose track as a TUM trajectory (z = 0, rotation about z by ``yaw``)."""
    lines = [f"# {header}"] if header else []
    lines.append("# t x y z qx qy qz qw")
    for ti, xi, yi, wi in zip(t_s, x, y, yaw, strict=True):
        lines.append(
            f"{ti:.9f} {xi:.9g} {yi:.9g} 0 0 0 {math.sin(wi / 2):.12g} {math.cos(wi / 2):.12g}"
        )
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")
