"""Curvature: the measured ``kappa`` (1/m) of an aligned frame, and ``kappa_cmd`` from steering.

Measured curvature, three sources, chosen per row in this order (column ``kappa_source``):

* ``"omega/v"``: kappa = omega / v where both are present and |v| > ``v_min``. This is the
  curvature in the vehicle's sense (positive = turning left when driving forward; it keeps its
  sign when reversing).
* ``"path"``: elsewhere, from the geometry of the (x, y) path, kappa = d(theta)/ds with
  theta = atan2(y', x') the direction of travel and ds/dt = |(x', y')|. Every time derivative
  is a Savitzky-Golay differentiator (cubic, window ``window_s``, default 2.0 s, rounded to an
  odd number of samples, at least 5) run on each stretch of rows without nulls. On the
  simulator's pose (1 cm noise at 50 Hz, 1 m/s) the error of kappa has a standard deviation of
  about 0.05 1/m with a 1 s window, 0.009 with 2 s and 0.002 with 4 s; longer windows smear
  fast curvature changes over the window. (This equals
  (x' y'' - y' x'') / (x'^2 + y'^2)^(3/2), but is exact on circles: the smoothing shrinks x'
  and y' alike and leaves theta linear in time.) The sign is turned
  into the vehicle's sense with the heading ``yaw`` when present (travel against the heading =
  reversing); without ``yaw`` the path is assumed driven forward. Rows where the path speed is
  at most ``v_min`` (the curvature is undefined there) stay null.
* ``"steer"``: elsewhere, kappa = tan(steer) / wheelbase from a measured steering angle
  ``steer`` (rad) when the wheelbase (m) is known (bicycle model: the curvature of the middle
  of the fixed axle). Rows with a saturated steering angle (:data:`STEER_SATURATION_RAD`) stay
  null.

Rows where no source applies have a null ``kappa`` and ``kappa_source``. Signals that carry
nothing (an all-zero odometry twist) never reach this module: the channel map drops them
(:mod:`logtools.channel_map`), so ``kappa`` comes from the path instead of 0/0.

The commanded curvature ``kappa_cmd`` is logged, or derived while the log's signals are
resolved: :func:`derive_kappa_cmd` is this robot's derived signal (``RobotPlugin.derived_signals``)
and its :class:`~logtools.signals.SignalOrigin` says how (:class:`KappaCmdKind`). From a steering
command ``steer_cmd`` and the wheelbase, :func:`kappa_from_steering` gives tan(delta) /
wheelbase and says which samples are saturated (|delta| >= 85 deg, where the curvature runs to
infinity); those are reported and left out. Else from a velocity command, omega_cmd / v_cmd
where |v_cmd| > :data:`V_CMD_MIN`. :func:`saturated_steer_notes` reports a saturated measured
steering angle.
"""

from __future__ import annotations

import math
from enum import StrEnum

import numpy as np
import polars as pl

from calib.kinematics.bicycle import bicycle_curvature
from calib.smoothing import savgol_filter
from logtools.align import common_times
from logtools.errors import LogcalInputError
from logtools.readers import TIME_COLUMN
from logtools.robots.base import Derived, FoundSignals
from logtools.signals import DERIVED_TOPIC, SignalOrigin, SignalSource

__all__ = [
    "KAPPA_SOURCES",
    "STEER_SATURATION_RAD",
    "V_CMD_MIN",
    "KappaCmdKind",
    "derive_kappa",
    "derive_kappa_cmd",
    "kappa_from_steering",
    "path_curvature",
    "saturated_steer_notes",
]

KAPPA_SOURCES = ("omega/v", "path", "steer")

STEER_SATURATION_RAD = math.radians(85.0)
"""|steering angle| at or beyond this (rad) is saturated: tan(delta) / wheelbase is not used."""


V_CMD_MIN = 0.05
"""|v_cmd| (m/s) above which kappa_cmd = omega_cmd / v_cmd is derived."""


class KappaCmdKind(StrEnum):
    """How a derived curvature command ``kappa_cmd`` was obtained (``SignalOrigin.kind``; a
    logged one or a channel-map formula has the shared kinds ``logged``, ``formula``)."""

    STEERING = "steering"  # tan(steer_cmd) / wheelbase
    TWIST = "twist"  # omega_cmd / v_cmd of a velocity command


def kappa_from_steering(
    delta: np.ndarray, wheelbase: float, *, saturation_rad: float = STEER_SATURATION_RAD
) -> tuple[np.ndarray, np.ndarray]:
    """Curvature (1/m) tan(delta) / wheelbase of a car-like vehicle, and the saturated samples.

    Args:
        delta: steering angle (rad), positive to the left.
        wheelbase: distance (m) between the steered and the fixed axle, > 0.
        saturation_rad: |delta| at or beyond which the sample is saturated.

    Returns:
        (kappa with NaN where saturated, mask of the saturated samples).

    Raises:
        LogcalInputError: the wheelbase is not a positive number.
    """
    if not (math.isfinite(wheelbase) and wheelbase > 0):
        raise LogcalInputError(f"the wheelbase must be a positive length (m), got {wheelbase}")
    d = np.asarray(delta, dtype=float)
    saturated = np.abs(d) >= saturation_rad
    kappa = bicycle_curvature(d, wheelbase)
    kappa[saturated] = np.nan
    return kappa, saturated


def _col(frame: pl.DataFrame, name: str) -> np.ndarray | None:
    if name not in frame.columns:
        return None
    return frame[name].cast(pl.Float64).fill_null(np.nan).to_numpy()


def _runs(ok: np.ndarray) -> list[tuple[int, int]]:
    """[start, end) index ranges of consecutive True values."""
    d = np.diff(np.concatenate([[0], ok.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1), strict=True))


def path_curvature(
    x: np.ndarray,
    y: np.ndarray,
    dt_s: float,
    *,
    yaw: np.ndarray | None = None,
    window_s: float = 2.0,
    v_min: float = 0.05,
) -> np.ndarray:
    """Signed curvature (1/m) of a uniformly sampled path; NaN where undefined.

    Args:
        x, y: positions (m), sampled every ``dt_s`` seconds; NaN marks missing rows.
        dt_s: sample period (s).
        yaw: heading (rad) to sign the curvature in the vehicle's sense; None: forward.
        window_s: Savitzky-Golay window (s).
        v_min: path speed (m/s) at or below which the curvature is left NaN.
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    out = np.full(x.shape, np.nan)
    win = max(5, round(window_s / dt_s) | 1)
    for a, b in _runs(np.isfinite(x) & np.isfinite(y)):
        if b - a < win:
            continue
        d1x = savgol_filter(x[a:b], win, 3, deriv=1, delta=dt_s)
        d1y = savgol_filter(y[a:b], win, 3, deriv=1, delta=dt_s)
        speed = np.hypot(d1x, d1y)
        heading = np.unwrap(np.arctan2(d1y, d1x))
        turn_rate = savgol_filter(heading, win, 3, deriv=1, delta=dt_s)
        with np.errstate(divide="ignore", invalid="ignore"):
            k = turn_rate / speed
        if yaw is not None:
            h = yaw[a:b]
            forward = d1x * np.cos(h) + d1y * np.sin(h)
            k = np.where(forward < 0, -k, k)
            k[~np.isfinite(h)] = np.nan
        k[speed <= v_min] = np.nan
        out[a:b] = k
    return out


def derive_kappa(
    frame: pl.DataFrame,
    *,
    v_min: float = 0.05,
    window_s: float = 2.0,
    wheelbase: float | None = None,
) -> pl.DataFrame:
    """Add ``kappa`` (1/m) and ``kappa_source`` ("omega/v" | "path" | "steer" | null).

    Args:
        frame: output of ``align_signals`` (uniform ``t_ns``; ``v``, ``omega``, ``x``, ``y``,
            ``yaw``, ``steer`` used where present).
        v_min: speed (m/s) below which omega/v is not used and the path is not trusted.
        window_s: Savitzky-Golay window (s) of the path differentiator.
        wheelbase: wheelbase (m) turning a measured steering angle ``steer`` into a curvature;
            None: ``steer`` is not used.

    Raises:
        LogcalInputError: the frame has neither (v, omega), (x, y) nor (steer and a wheelbase).
    """
    n = frame.height
    v, omega = _col(frame, "v"), _col(frame, "omega")
    x, y = _col(frame, "x"), _col(frame, "y")
    steer = _col(frame, "steer") if wheelbase is not None else None
    if (v is None or omega is None) and (x is None or y is None) and steer is None:
        raise LogcalInputError(
            "cannot derive the measured curvature kappa: the log needs (v, omega) or (x, y), or a "
            "steering angle steer with a wheelbase; aligned signals are "
            f"{[c for c in frame.columns if c != 't_ns']}"
        )
    kappa = np.full(n, np.nan)
    source = np.full(n, None, dtype=object)
    if v is not None and omega is not None:
        ok = np.isfinite(v) & np.isfinite(omega) & (np.abs(v) > v_min)
        kappa[ok] = omega[ok] / v[ok]
        source[ok] = KAPPA_SOURCES[0]
    need = ~np.isfinite(kappa)
    if x is not None and y is not None and np.any(need) and n >= 2:
        t = frame["t_ns"].to_numpy()
        dt_s = float(np.median(np.diff(t))) / 1e9
        kp = path_curvature(x, y, dt_s, yaw=_col(frame, "yaw"), window_s=window_s, v_min=v_min)
        use = need & np.isfinite(kp)
        kappa[use] = kp[use]
        source[use] = KAPPA_SOURCES[1]
    need = ~np.isfinite(kappa)
    if steer is not None and wheelbase is not None and np.any(need):
        ks, _ = kappa_from_steering(steer, wheelbase)
        use = need & np.isfinite(ks)
        kappa[use] = ks[use]
        source[use] = KAPPA_SOURCES[2]
    return frame.with_columns(
        pl.Series("kappa", kappa, dtype=pl.Float64).fill_nan(None),
        pl.Series("kappa_source", source.tolist(), dtype=pl.String),
    )


def derive_kappa_cmd(found: FoundSignals) -> Derived:
    """``kappa_cmd`` for a log without one: tan(steer_cmd) / wheelbase from a steering command
    (none without a wheelbase: a note says what to set), else omega_cmd / v_cmd from a velocity
    command where |v_cmd| > :data:`V_CMD_MIN` (with a note: on some robots ``angular.z`` is a
    steering angle). Saturated steering samples are left out and reported."""
    if "steer_cmd" in found.signals:
        return _from_steering(found)
    if "omega_cmd" in found.signals and "v_cmd" in found.signals:
        return _from_twist(found)
    return Derived()


def _from_steering(found: FoundSignals) -> Derived:
    wheelbase = found.robot.number("wheelbase")
    steer = found.sources["steer_cmd"]
    if wheelbase is None:
        return Derived(
            notes=(
                f"{found.path}: a steering command steer_cmd ({steer.describe()}) is there but no "
                "wheelbase is known, so kappa_cmd = tan(steer_cmd) / wheelbase is not derived; set "
                "[robot] wheelbase = … (m) in the channel map or 'wheelbase' in the logcal "
                "metadata record",
            )
        )
    frame = found.signals["steer_cmd"]
    kappa, saturated = kappa_from_steering(frame["value"].to_numpy(), wheelbase)
    notes = []
    n_sat = int(saturated.sum())
    if n_sat:
        peak = math.degrees(float(np.max(np.abs(frame["value"].to_numpy()))))
        notes.append(
            f"{found.path}: {n_sat} of {frame.height} samples of steer_cmd ({steer.describe()}) "
            f"are saturated (|delta| >= {math.degrees(STEER_SATURATION_RAD):.0f} deg, up to "
            f"{peak:.1f} deg): tan(delta) / wheelbase runs to infinity there, so kappa_cmd is "
            "left out on those samples"
            + (
                '; beyond 360 deg the values look like degrees: set unit = "deg"'
                if peak > 360
                else ""
            )
        )
    expr = f"tan(steer_cmd) / {wheelbase:g}"
    out = frame.with_columns(pl.Series("value", kappa).fill_nan(None)).drop_nulls("value")
    if not out.height:
        return Derived(notes=tuple(notes))
    origin = SignalOrigin(
        KappaCmdKind.STEERING,
        expr,
        f"tan(steer_cmd) / wheelbase from the steering command {steer.describe()}, wheelbase "
        f"{wheelbase:g} m from {found.params_from.get('wheelbase', '')}",
    )
    return Derived(out, SignalSource(DERIVED_TOPIC, expr, formula=expr), origin, tuple(notes))


def _from_twist(found: FoundSignals) -> Derived:
    t_ns, values = common_times({n: found.signals[n] for n in ("omega_cmd", "v_cmd")}, hold=True)
    v_cmd, omega_cmd = values["v_cmd"], values["omega_cmd"]
    ok = np.isfinite(v_cmd) & np.isfinite(omega_cmd) & (np.abs(v_cmd) > V_CMD_MIN)
    if not ok.any():
        return Derived()
    expr = "omega_cmd / v_cmd"
    out = pl.DataFrame(
        {TIME_COLUMN: pl.Series(t_ns[ok], dtype=pl.Int64), "value": omega_cmd[ok] / v_cmd[ok]}
    )
    w, v = found.sources["omega_cmd"], found.sources["v_cmd"]
    origin = SignalOrigin(
        KappaCmdKind.TWIST,
        expr,
        f"omega_cmd / v_cmd from {w.describe()} and {v.describe()} where |v_cmd| > {V_CMD_MIN} m/s",
    )
    note = (
        f"{found.path}: kappa_cmd is derived as omega_cmd / v_cmd ({w.describe()} / "
        f"{v.describe()}); if that field is a steering angle rather than a yaw rate, map it as "
        "steer_cmd and set [robot] wheelbase in a channel map"
    )
    return Derived(out, SignalSource(DERIVED_TOPIC, expr, formula=expr), origin, (note,))


def saturated_steer_notes(found: FoundSignals) -> list[str]:
    """A measured steering angle ``steer`` at or beyond saturation gives no curvature there (see
    :func:`derive_kappa`): one note saying how many samples, for the log's problems."""
    if "steer" not in found.signals:
        return []
    values = found.signals["steer"]["value"].to_numpy()
    n_sat = int(np.count_nonzero(np.abs(values) >= STEER_SATURATION_RAD))
    if not n_sat:
        return []
    return [
        f"{found.path}: {n_sat} of {values.size} samples of steer "
        f"({found.sources['steer'].describe()}) are saturated (|delta| >= "
        f"{math.degrees(STEER_SATURATION_RAD):.0f} deg, up to "
        f"{math.degrees(float(np.max(np.abs(values)))):.1f} deg): no curvature is taken from them"
    ]
