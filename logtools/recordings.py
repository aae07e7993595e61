"""Recordings, not files: the same drive recorded once but given as several files.

A folder may hold each recording as ``.csv`` and ``.mcap`` (or a JSON and a ROS 2 MCAP of it),
and ``logcal analyze a.mcap a_ros2.mcap a.csv`` names one recording three times. Pooling those
would count the same data thrice (and narrow its interval for nothing), so
:func:`distinct_recordings` tells them apart by what they hold: the same time span (the same
start and end stamps, or, when one clock starts at 0, the same duration) and the same values of
the logical signals they share at the same times (measured ones among them: repeated runs of
one plan share their commands). Each recording is then analysed once and the
duplicates are named (:class:`SameRecording`).

:func:`merge_recordings` writes several rerun recordings into the one ``.rrd`` file a user named
(rerun's own ``rrd merge``; each run stays its own recording in the file).
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from logtools.channel_map.names import command_signals, signal_spec
from logtools.errors import LogcalError, LogcalInputError
from logtools.signals import SignalSource

__all__ = ["SameRecording", "distinct_recordings", "merge_recordings"]

_PREFERRED = ("psi", "wheel_left", "wheel_right", "q1", "tau1", "x", "y", "yaw", "v", "omega")
"""Signals compared first (measured ones: commands may be identical across different runs)."""
_SPAN_TOL_S = 0.5
"""Start/end stamps (or durations) this close (s) are the same span."""
_VALUE_RTOL = 1e-6
"""Values equal to this relative tolerance (text formats round the last digits)."""


@dataclass(frozen=True)
class SameRecording:
    """Files holding one recording.

    Attributes:
        kept: the file analysed (the first given).
        same: the other files holding that recording (left out).
        evidence: why they are the same, for people ("same start and end stamps, same psi").
    """

    kept: Path
    same: tuple[Path, ...]
    evidence: str

    def sentence(self, outcome: str = "counted once") -> str:
        """One sentence for the report (``outcome``: what was done about it)."""
        others = ", ".join(str(p) for p in self.same)
        return (
            f"{others} {'holds' if len(self.same) == 1 else 'hold'} the same recording as "
            f"{self.kept} ({self.evidence}): {outcome}"
        )


@dataclass(frozen=True)
class _Print:
    """What a log holds, enough to compare: its span and its signals' times and values."""

    start_ns: int
    end_ns: int
    signals: Mapping[str, tuple[np.ndarray, np.ndarray]]


def _fingerprint(path: Path, channel_map: Mapping[str, SignalSource] | None) -> _Print | None:
    from logtools.channel_map import resolve_signals
    from logtools.load import read_input

    try:
        log = read_input(path, channel_map)  # cropped as a LoadRequest says
        resolved = resolve_signals(log, channel_map)
    except LogcalError:
        return None  # the analysis reads it again and reports why it cannot
    if not resolved.signals:
        return None
    sig = {n: (f["t_ns"].to_numpy(), f["value"].to_numpy()) for n, f in resolved.signals.items()}
    return _Print(
        min(int(t[0]) for t, _ in sig.values()), max(int(t[-1]) for t, _ in sig.values()), sig
    )


def _duration_ns(path: Path) -> int | None:
    """The log's span from its topic summaries (MCAP and bags: without decoding a message);
    None when that cheap look fails (the log is then compared in full)."""
    from logtools.readers import read_log
    from logtools.readers.tum import is_tum

    if path.suffix.lower() == ".csv" or is_tum(path):
        return None  # a text table is read whole anyway
    try:
        log = read_log(path, topics=())
    except LogcalError:
        return None
    firsts = [i.first_ns for i in log.info.values() if i.first_ns is not None]
    lasts = [i.last_ns for i in log.info.values() if i.last_ns is not None]
    return max(lasts) - min(firsts) if firsts and lasts else None


def _is_heading(name: str) -> bool:
    """A heading is the same whether unwrapped or wrapped to +-pi (``SignalSpec.heading``)."""
    spec = signal_spec(name)
    return spec is not None and spec.heading


def _same(a: _Print, b: _Print) -> str | None:
    """Why ``a`` and ``b`` hold one recording, or None when they do not."""
    tol = round(_SPAN_TOL_S * 1e9)
    same_stamps = abs(a.start_ns - b.start_ns) <= tol and abs(a.end_ns - b.end_ns) <= tol
    da, db = a.end_ns - a.start_ns, b.end_ns - b.start_ns
    if not same_stamps and abs(da - db) > tol:
        return None
    shift_a, shift_b = (0, 0) if same_stamps else (a.start_ns, b.start_ns)
    common = sorted(
        set(a.signals) & set(b.signals),
        key=lambda n: (_PREFERRED.index(n) if n in _PREFERRED else 99, n),
    )
    varying = [n for n in common if np.ptp(a.signals[n][1]) > 0]
    commands = command_signals()
    measured = [n for n in varying if n not in commands]
    if not measured:
        return None  # commands alone are the same in repeated runs of one plan
    for name in varying:
        (ta, va), (tb, vb) = a.signals[name], b.signals[name]
        ra = (ta - shift_a).astype(np.float64)
        rb = (tb - shift_b).astype(np.float64)
        inside = (ra >= rb[0] - 1e6) & (ra <= rb[-1] + 1e6)  # within 1 ms of b's samples
        if len(rb) < 2 or inside.sum() < 0.9 * max(len(ra), len(rb)):
            return None
        other = np.interp(ra[inside], rb, np.unwrap(vb) if _is_heading(name) else vb)
        diff = va[inside] - other
        if _is_heading(name):  # one log's heading unwrapped, the other's from a quaternion
            diff, scale = np.angle(np.exp(1j * diff)), float(np.pi)
        else:
            scale = max(float(np.max(np.abs(va))), 1e-12)
        if np.max(np.abs(diff)) > _VALUE_RTOL * scale:
            return None
    span = (
        "same start and end stamps"
        if same_stamps
        else f"same duration ({da * 1e-9:.3f} s; one clock starts at 0)"
    )
    more = f" and {len(varying) - 1} other signals" if len(varying) > 1 else ""
    return f"{span}, the same values of {measured[0]}{more} at the same times"


def distinct_recordings(
    runs: Sequence[Path], channel_map: Mapping[str, SignalSource] | None = None
) -> tuple[list[Path], list[SameRecording]]:
    """The runs that are distinct recordings (in the order given) and the groups of files that
    hold one recording (each analysed once, as its first file).

    A file that cannot be read is kept (the analysis says why it cannot be read).
    """
    if len(runs) < 2:
        return list(runs), []
    durations = [_duration_ns(Path(p)) for p in runs]
    tol = round(_SPAN_TOL_S * 1e9)
    prints = [
        _fingerprint(Path(p), channel_map)
        if d is None
        or any(j != i and e is not None and abs(d - e) <= tol for j, e in enumerate(durations))
        else None
        for i, (p, d) in enumerate(zip(runs, durations, strict=True))
    ]  # only logs with a twin of the same length are read whole
    kept: list[int] = []
    groups: dict[int, list[tuple[int, str]]] = {}
    for i, fp in enumerate(prints):
        match = None
        if fp is not None:
            for k in kept:
                other = prints[k]
                why = _same(other, fp) if other is not None else None
                if why is not None:
                    match = (k, why)
                    break
        if match is None:
            kept.append(i)
        else:
            groups.setdefault(match[0], []).append((i, match[1]))
    same = [
        SameRecording(
            Path(runs[k]),
            tuple(Path(runs[i]) for i, _ in members),
            "; ".join(dict.fromkeys(why for _, why in members)),
        )
        for k, members in groups.items()
    ]
    return [Path(runs[i]) for i in kept], same


def merge_recordings(parts: Sequence[Path], out: Path) -> Path:
    """Write the rerun recordings ``parts`` into the one file ``out`` (each stays its own
    recording, with its blueprint), with rerun's ``rrd merge``; returns ``out``.

    Raises:
        LogcalInputError: rerun could not merge them (its message).
    """
    if len(parts) == 1:
        os.replace(parts[0], out)
        return out
    cmd = [sys.executable, "-m", "rerun", "rrd", "merge", "-o", str(out), *map(str, parts)]
    try:
        done = subprocess.run(
            cmd,
            capture_output=True,
            text=True,
            timeout=600,
            check=False,
            env={**os.environ, "RUST_LOG": "warn"},
        )
    except (OSError, subprocess.TimeoutExpired) as err:
        raise LogcalInputError(f"{out}: the runs' recordings could not be merged ({err})") from err
    if done.returncode != 0 or not out.is_file():
        why = (done.stderr or done.stdout).strip().splitlines()[-1:] or ["no message"]
        raise LogcalInputError(
            f"{out}: the runs' recordings could not be merged into one file (rerun rrd merge: "
            f"{why[0]})"
        )
    return out
