"""The tractor's path and the joint angle, from a loaded log's own per-signal samples.

The transient fit (calib.tractor_trailer.estimators.path_transient) reads every signal at its own
time stamps
(no common grid), so that asynchronous sensors and any sampling rate give the same answer.
This module picks the path source, best first: the pose of link 1 (x, y, yaw), odometry
(v, omega), the command (v or v_cmd times kappa_cmd). A source whose values do not move (an
all-zero odometry twist) is passed over with a note.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import polars as pl

from calib.errors import InsufficientDataError
from calib.tractor_trailer.estimators.drive_path import DrivePath, pose_smoothing
from logtools.loaded import LoadedLog

__all__ = [
    "PathInputs",
    "RobotDidNotMoveError",
    "path_inputs",
    "relaxation_window_s",
    "trailer_pose_inputs",
]


class RobotDidNotMoveError(InsufficientDataError):
    """No source of the path shows the robot travelling far enough to calibrate it."""


_MIN_TRAVEL_M = 0.1  # m: less than this calibrates nothing (the robot did not move)
_SIGNALS = {
    "pose": ("x", "y", "yaw"),
    "odometry": ("v", "omega"),
    "command": ("v", "v_cmd", "kappa_cmd"),
}


@dataclass(frozen=True)
class PathInputs:
    """What the path-driven fit needs, times in s from ``t0_ns``.

    Attributes:
        path: link 1's cumulative arc length and heading.
        t_psi_s, psi_rad: the joint-angle samples.
        gaps: (t0, t1) spans (s) where the recorder stalled.
        t0_ns: the time origin (the aligned frame's first row).
        notes: sources passed over and why.
    """

    path: DrivePath
    t_psi_s: np.ndarray
    psi_rad: np.ndarray
    gaps: list[tuple[float, float]]
    t0_ns: int
    notes: list[str]


def _signal(loaded: LoadedLog, name: str) -> pl.DataFrame | None:
    return loaded.signals.signals.get(name)


def _times(frame: pl.DataFrame, t0_ns: int) -> np.ndarray:
    return (frame["t_ns"].to_numpy() - t0_ns) / 1e9


def _on_common_times(
    loaded: LoadedLog, names: tuple[str, ...], t0_ns: int
) -> tuple[np.ndarray, list[np.ndarray]] | None:
    """The signals ``names`` at the first one's stamps (others interpolated), or None."""
    frames = [_signal(loaded, n) for n in names]
    if any(f is None or f.height < 2 for f in frames):
        return None
    base = frames[0]
    assert base is not None
    t = _times(base, t0_ns)
    cols = []
    for f in frames:
        assert f is not None
        tf = _times(f, t0_ns)
        v = f["value"].to_numpy().astype(float)
        if f is base:
            cols.append(v)
        else:
            out = np.interp(t, tf, v)
            out[(t < tf[0]) | (t > tf[-1])] = np.nan
            cols.append(out)
    return t, cols


def _candidates(
    loaded: LoadedLog, t0_ns: int, psi: np.ndarray, max_window_s: float
) -> list[tuple[str, DrivePath | None, str]]:
    """Path sources, best first: a pose (measured motion, immune to actuator and odometry
    scale errors; its noise is smoothed within ``max_window_s`` and its remaining bias
    corrected in the fit), odometry, the command."""
    out: list[tuple[str, DrivePath | None, str]] = []
    pose = _on_common_times(loaded, ("x", "y", "yaw"), t0_ns)
    if pose is not None:
        t, (x, y, yaw) = pose
        n = pose_smoothing(t, x, y, yaw, psi, max_window_s=max_window_s)
        if n is None:
            n = _odd(max_window_s * _rate(t))
        out.append(("pose", DrivePath.from_pose(t, x, y, yaw, smooth_samples=n), ""))
    else:
        out.append(("pose", None, "no pose with yaw (x, y, yaw)"))
    odo = _on_common_times(loaded, ("omega", "v"), t0_ns)
    if odo is not None:
        t, (w, v) = odo
        out.append(("odometry", DrivePath.from_rates(t, v, w), ""))
    else:
        out.append(("odometry", None, "no odometry (v, omega)"))
    for speed in ("v", "v_cmd"):
        cmd = _on_common_times(loaded, (speed, "kappa_cmd"), t0_ns)
        if cmd is not None:
            t, (v, k) = cmd
            out.append(("command", DrivePath.from_rates(t, v, v * k, source="command"), ""))
            break
    else:
        out.append(("command", None, "no speed with a curvature command"))
    return out


def _rate(t: np.ndarray) -> float:
    return 1.0 / float(np.median(np.diff(t))) if t.size > 1 else 1.0


def _odd(n: float) -> int:
    k = int(n)
    return k if k % 2 else k - 1


def path_inputs(
    loaded: LoadedLog, *, prefer: str | None = None, max_window_s: float = 0.25
) -> PathInputs:
    """The best path source of ``loaded`` and its joint-angle samples.

    Args:
        loaded: a loaded log with a ``psi`` signal.
        prefer: "pose", "odometry" or "command" to use that source when the log has it.
        max_window_s: longest smoothing window (s) for a noisy pose; it should be short next
            to the trailer's relaxation time L2 / v (``relaxation_window_s``).

    Raises:
        InsufficientDataError: no joint angle, or no source of the path that moves.
    """
    psi = _signal(loaded, "psi")
    if psi is None or psi.height < 2:
        raise InsufficientDataError("the log has no joint-angle (psi) samples")
    t0_ns = int(loaded.frame["t_ns"][0]) if loaded.frame.height else int(psi["t_ns"][0])
    notes: list[str] = []
    cands = _candidates(loaded, t0_ns, psi["value"].to_numpy().astype(float), max_window_s)
    if prefer is not None:
        cands.sort(key=lambda c: c[0] != prefer)
    chosen: DrivePath | None = None
    for name, path, why in cands:
        if path is None:
            notes.append(f"path from {name}: {why}")
            continue
        try:
            moved = path.distance_m
        except InsufficientDataError as err:  # pragma: no cover - guarded by _on_common_times
            notes.append(f"path from {name}: {err}")
            continue
        if moved < _MIN_TRAVEL_M:
            if name in ("pose", "odometry"):  # measured: the robot did not move
                cmd = [p for n, p, _ in cands if n == "command" and p is not None]
                told = f"; it was commanded to go {cmd[0].distance_m:.3g} m" if cmd else ""
                raise RobotDidNotMoveError(
                    f"the robot did not move: its {name} shows {moved:.3g} m of travel "
                    f"(at least {_MIN_TRAVEL_M} m is needed to calibrate anything){told}"
                )
            notes.append(f"path from {name}: it does not move ({moved:.3g} m in all)")
            continue
        chosen = path
        break
    if chosen is None:
        raise RobotDidNotMoveError(
            f"the robot did not move enough to calibrate anything (less than {_MIN_TRAVEL_M} m "
            "by every source): " + "; ".join(notes)
        )
    used = {"psi", *_SIGNALS[chosen.source]}
    gaps = [
        ((g.t0_ns - t0_ns) / 1e9, (g.t1_ns - t0_ns) / 1e9)
        for g in getattr(loaded, "gaps", [])
        if used & set(g.signals)
    ]
    return PathInputs(
        chosen, _times(psi, t0_ns), psi["value"].to_numpy().astype(float), gaps, t0_ns, notes
    )


def relaxation_window_s(path: DrivePath, L2_m: float, share: float = 0.1) -> float:
    """``share`` of the trailer's relaxation time L2 / v at the path's median moving speed (s):
    the longest a pose may be smoothed without blurring the joint angle's transients."""
    dt = np.diff(path.t_s)
    ds = np.abs(np.diff(path.s_m))
    moving = (dt > 0) & (ds > 0)
    if not moving.any():
        return 0.25
    v = float(np.median(ds[moving] / dt[moving]))
    return float(share * abs(L2_m) / max(v, 1e-3))


def trailer_pose_inputs(loaded: LoadedLog) -> tuple[np.ndarray, list[np.ndarray]]:
    """The trailer pose (x2, y2, yaw2) and the joint angle at the pose's stamps (s from the
    aligned frame's first row), for the no-slip regression.

    Raises:
        InsufficientDataError: the log has no trailer pose or no joint angle.
    """
    t0_ns = int(loaded.frame["t_ns"][0]) if loaded.frame.height else 0
    got = _on_common_times(loaded, ("x2", "y2", "yaw2", "psi"), t0_ns)
    if got is None:
        raise InsufficientDataError("no trailer pose (x2, y2, yaw2) with a joint angle (psi)")
    return got
