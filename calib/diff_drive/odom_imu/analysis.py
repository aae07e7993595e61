"""The odometry + IMU analysis of one aligned log (see :mod:`calib.diff_drive.odom_imu`)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from calib.adequacy import ResidualChannel, assess, not_assessed
from calib.diff_drive.odom_imu.effects import GAIN, ICR_SLIP, SPEED_SLIP, TURN_SLIP
from calib.diff_drive.odom_imu.explain import explain
from calib.diff_drive.odom_imu.fitter import GainFitter
from calib.diff_drive.odom_imu.gain import (
    N_BOOT,
    binned,
    block_boot,
    fit_gain,
    gain_under_misfit,
    interval,
)
from calib.diff_drive.odom_imu.gps import gps_scale
from calib.diff_drive.odom_imu.result import OdomImuResult
from calib.diff_drive.odom_imu.windows import FOLD_S, MIN_TURN_RAD_S, WINDOW_S, lag, windows
from calib.discovery import select_effects
from calib.errors import InsufficientDataError
from calib.results import Estimate

__all__ = ["analyze_odom_imu"]

Array = NDArray[np.float64]


def analyze_odom_imu(
    t: Array,
    odom_omega: Array,
    gyro_z: Array,
    *,
    odom_v: Array | None = None,
    gps: tuple[Array, Array] | None = None,
    geometric_track: float | None = None,
    seed: int = 0,
) -> OdomImuResult:
    """The analysis of the module docstring on one aligned log (``t`` in s).

    Raises:
        InsufficientDataError: too few samples, or the robot hardly turns.
    """
    t = np.asarray(t, float)
    odo = np.asarray(odom_omega, float)
    gyr = np.asarray(gyro_z, float)
    vv = np.zeros_like(t) if odom_v is None else np.asarray(odom_v, float)
    ok = np.isfinite(t) & np.isfinite(odo) & np.isfinite(gyr) & np.isfinite(vv)
    t, odo, gyr, vv = t[ok], odo[ok], gyr[ok], vv[ok]
    if t.size < 50:
        raise InsufficientDataError("the odometry + IMU analysis needs at least 50 samples")
    shift = lag(t, odo, gyr)
    if shift:  # shift the gyro onto the odometry's clock
        gyr = np.interp(t + shift, t, gyr)
    w = windows(t, odo, gyr, vv)
    use = np.flatnonzero(w.rate >= MIN_TURN_RAD_S).astype(np.intp)
    turned = float(np.sum(np.abs(w.odo[use])))
    if use.size < 10 or turned < math.pi / 2:
        raise InsufficientDataError(
            f"the robot turns only {turned:.2f} rad in all: the yaw-rate gain is not determined"
        )
    rng = np.random.default_rng(seed)
    g, bias = fit_gain(w, use)
    boots = [fit_gain(w, use[i]) for i in block_boot(use.size, rng, N_BOOT)]
    blk = max(1, round(use.size ** (1 / 3)))
    dof = max(1, int(np.ceil(use.size / blk)) - 1)
    note = (
        f"gyro yaw change = odometry's / G + bias x duration on {use.size} windows of "
        f"{WINDOW_S:g} s that turn; moving-block bootstrap (blocks of {blk}), t on {dof} "
        "degrees of freedom"
    )
    gain = interval("yaw_rate_gain", g, np.array([b[0] for b in boots]), dof, "1", note)
    bias_e = interval(
        "gyro_bias", bias, np.array([b[1] for b in boots]), dof, "rad/s", "fitted with the gain"
    )
    eff = None
    if geometric_track is not None and math.isfinite(gain.std):
        eff = Estimate(
            "effective_track",
            geometric_track * g,
            geometric_track * gain.std,
            (geometric_track * gain.ci95[0], geometric_track * gain.ci95[1]),
            True,
            "m",
            f"geometric track {geometric_track:g} m x yaw-rate gain",
        )
    hi_rate = float(np.max(w.rate[use]))
    edges = [MIN_TURN_RAD_S, *np.linspace(0.0, hi_rate, 5)[1:-1].tolist(), hi_rate + 1e-9]
    edges = sorted(set(edges))
    use_mask = np.zeros(w.t.size, bool)
    use_mask[use] = True
    by_turn = binned(w, w.rate, edges, use_mask, rng)
    by_speed: list[dict[str, float]] = []
    if odom_v is not None and float(np.max(w.speed)) > 0:
        sp_edges = np.quantile(w.speed[use], [0, 0.25, 0.5, 0.75, 1.0]).tolist()
        sp_edges[-1] += 1e-9
        by_speed = binned(w, w.speed, sorted(set(sp_edges)), use_mask, rng)
    # adequacy of the constant-gain model on every window (held out: two folds)
    pred = w.odo / g + bias * w.dt
    resid = w.gyro - pred
    blocks = ((w.t - w.t[0]) // FOLD_S).astype(int) % 2
    held = np.full(w.t.size, math.nan)
    for f in (0, 1):
        train = np.intersect1d(use, np.flatnonzero(blocks != f)).astype(np.intp)
        if train.size >= 8:
            gf, bf = fit_gain(w, train)
            test = blocks == f
            held[test] = w.gyro[test] - (w.odo[test] / gf + bf * w.dt[test])
    chan = ResidualChannel(
        "gyro yaw change",
        "rad",
        w.t - w.t[0],
        resid,
        held,
        timescale_s=WINDOW_S,
        covariates={"|turn rate| (rad/s)": w.rate, "speed (m/s)": w.speed},
    )
    model = "constant yaw-rate gain + gyro bias"
    try:
        adequacy = assess([chan], model=model)
    except (ValueError, FloatingPointError):
        adequacy = not_assessed(model, "the residual could not be judged")
    if not adequacy.explains and adequacy.channels:
        pieces = []
        for f0 in np.arange(w.t[0], w.t[-1], FOLD_S):
            rows = np.intersect1d(use, np.flatnonzero((w.t >= f0) & (w.t < f0 + FOLD_S)))
            if rows.size >= 8 and float(np.sum(np.abs(w.odo[rows]))) >= 1.0:
                pieces.append(fit_gain(w, rows.astype(np.intp))[0])
        gain = gain_under_misfit(gain, adequacy, pieces)
        if eff is not None and geometric_track is not None:
            eff = Estimate(
                "effective_track",
                geometric_track * gain.value,
                geometric_track * gain.std,
                (geometric_track * gain.ci95[0], geometric_track * gain.ci95[1]),
                False,
                "m",
                gain.note,
            )
    sigma = (adequacy.channels[0].noise_floor if adequacy.channels else 0.0) or float(np.std(resid))
    notes: list[str] = []
    selection = None
    explained = None
    try:
        cat = [GAIN, TURN_SLIP, SPEED_SLIP, ICR_SLIP] if odom_v is not None else [GAIN, TURN_SLIP]
        fitter = GainFitter(w, use, max(sigma, 1e-9), cat)
        selection = select_effects(fitter, cat, max_effects=3)
        if selection is not None:
            explained = explain(fitter, selection, t, vv, odo, adequacy.explains, cat)
            notes += list(explained.dropped)
    except (ValueError, np.linalg.LinAlgError) as err:
        notes.append(f"discovery did not run: {err}")
    if shift:
        notes.append(
            f"the gyro was shifted by {shift:+.3f} s onto the odometry (cross-correlation)"
        )
    dist = None
    if gps is not None and odom_v is not None:
        lat, lon = (np.asarray(a, float)[ok] for a in gps)
        dist = gps_scale(t, vv, lat, lon, rng)
    elif gps is None:
        notes.append("no GPS: the distance scale (wheel radius) is not determined")
    return OdomImuResult(
        gain,
        bias_e,
        shift,
        eff,
        by_turn,
        by_speed,
        dist,
        adequacy,
        selection,
        int(use.size),
        notes,
        explained,
    )
