"""Measured curvature: circles (closed form), rigid motions, the omega/v path."""

from __future__ import annotations

import numpy as np
import polars as pl
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from calib.tractor_trailer.results import CommandType as C
from calib.tractor_trailer.sim.commands import CommandSequence
from calib.tractor_trailer.sim.commands import CommandSpec as S
from calib.tractor_trailer.sim.tractor_trailer import TractorTrailerSim, simulate_tractor_trailer
from logtools.align import align_signals
from logtools.errors import LogcalInputError
from logtools.robots.tractor_trailer.curvature import derive_kappa, path_curvature

RATE = 50.0


def _circle(R, cx, cy, theta0, speed, ccw, n=400):
    """Driving forward around a circle: pose (x, y, yaw) sampled at RATE."""
    t = np.arange(n) / RATE
    s = 1.0 if ccw else -1.0
    th = theta0 + s * speed * t / R
    x, y = cx + R * np.cos(th), cy + R * np.sin(th)
    yaw = th + s * np.pi / 2
    return t, x, y, (yaw + np.pi) % (2 * np.pi) - np.pi


def _frame(t, **cols):
    return pl.DataFrame({"t_ns": (np.asarray(t) * 1e9).round().astype(np.int64), **cols})


circles = {
    "R": st.floats(2.0, 200.0),
    "cx": st.floats(-1e3, 1e3),
    "cy": st.floats(-1e3, 1e3),
    "theta0": st.floats(-np.pi, np.pi),
    "speed": st.floats(0.2, 5.0),
    "ccw": st.booleans(),
}


@settings(max_examples=40, deadline=None)
@given(**circles, reverse=st.booleans())
def test_circle_path_gives_plus_minus_one_over_R(R, cx, cy, theta0, speed, ccw, reverse):
    speed = min(speed, R / 2)  # at most 1 rad of arc per 2 s smoothing window
    t, x, y, yaw = _circle(R, cx, cy, theta0, speed, ccw)
    if reverse:  # same path, driven backwards: heading flipped, vehicle curvature flips sign
        yaw = (yaw + np.pi + np.pi) % (2 * np.pi) - np.pi
    out = derive_kappa(_frame(t, x=x, y=y, yaw=yaw))
    k = out["kappa"].to_numpy()
    expected = (1.0 if ccw else -1.0) * (-1.0 if reverse else 1.0) / R
    win = 100  # the 2 s Savitzky-Golay window at 50 Hz: one-sided fits within it of the ends
    np.testing.assert_allclose(k[win:-win], expected, rtol=5e-4, atol=1e-9)
    np.testing.assert_allclose(k, expected, rtol=0.1, atol=1e-9)
    assert set(out["kappa_source"].to_list()) == {"path"}


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    angle=st.floats(-np.pi, np.pi),
    dx=st.floats(-1e4, 1e4),
    dy=st.floats(-1e4, 1e4),
)
def test_rigid_motion_leaves_path_curvature_unchanged(seed, angle, dx, dy):
    rng = np.random.default_rng(seed)
    t = np.arange(600) / RATE
    kappa = 0.2 * np.sin(rng.uniform(0.05, 0.5) * t + rng.uniform(0, 6))
    yaw = np.cumsum(kappa) / RATE  # unit speed
    x, y = np.cumsum(np.cos(yaw)) / RATE, np.cumsum(np.sin(yaw)) / RATE
    k0 = path_curvature(x, y, 1 / RATE, yaw=yaw)
    c, s = np.cos(angle), np.sin(angle)
    k1 = path_curvature(c * x - s * y + dx, s * x + c * y + dy, 1 / RATE, yaw=yaw + angle)
    np.testing.assert_allclose(k1, k0, atol=1e-6)
    inner = slice(100, -100)  # the integrated path has curvature kappa (up to O(dt) and smoothing)
    np.testing.assert_allclose(k0[inner], kappa[inner], atol=5e-3)


@settings(max_examples=40, deadline=None)
@given(
    v=st.lists(st.floats(-3.0, 3.0), min_size=2, max_size=50),
    omega_scale=st.floats(-1.0, 1.0),
)
def test_omega_over_v_where_speed_is_not_near_zero(v, omega_scale):
    v = np.asarray(v)
    omega = omega_scale * (1 + np.arange(v.size) / v.size)
    out = derive_kappa(_frame(np.arange(v.size) / RATE, v=v, omega=omega), v_min=0.05)
    k = out["kappa"].to_numpy()
    src = np.asarray(out["kappa_source"].to_list(), dtype=object)
    fast = np.abs(v) > 0.05
    np.testing.assert_allclose(k[fast], omega[fast] / v[fast], rtol=1e-12)
    assert np.all(src[fast] == "omega/v")
    assert out["kappa"].is_null().to_numpy()[~fast].all()  # no pose to fall back on


def test_path_fills_rows_where_the_robot_is_slow():
    t, x, y, yaw = _circle(10.0, 0.0, 0.0, 0.0, 1.0, True)
    v = np.ones_like(t)
    v[100:150] = 0.0  # a wheel-odometry dropout to zero speed while the pose keeps moving
    out = derive_kappa(_frame(t, x=x, y=y, yaw=yaw, v=v, omega=v / 10.0))
    src = np.asarray(out["kappa_source"].to_list(), dtype=object)
    assert np.all(src[100:150] == "path")
    assert np.all(src[:100] == "omega/v")
    np.testing.assert_allclose(out["kappa"].to_numpy(), 0.1, rtol=1e-3)


def test_path_curvature_on_a_noisy_simulated_pose():
    """Pose only (1 cm noise at 50 Hz): the path curvature tracks the simulated truth."""
    seq = CommandSequence([S(C.HARMONIC, 126, 0.2, 0.1)])
    run = simulate_tractor_trailer(TractorTrailerSim(commands=seq), seed=1)
    pose = run.frames["pose"]
    sig = {n: pose.select("t_ns", pl.col(n).alias("value")) for n in ("x", "y", "yaw")}
    out = derive_kappa(align_signals(sig))
    truth_t = run.truth["t_ns"].to_numpy()
    k_true = np.interp(out["t_ns"].to_numpy(), truth_t, run.truth["kappa"].to_numpy())
    err = (out["kappa"].to_numpy() - k_true)[300:-300]  # after the speed ramp
    assert abs(np.mean(err)) < 2e-3
    assert np.std(err) < 0.02  # measured 0.009 with the default 2 s window


def test_stationary_path_has_no_curvature():
    t = np.arange(200) / RATE
    out = derive_kappa(_frame(t, x=np.zeros(200), y=np.zeros(200)))
    assert out["kappa"].null_count() == 200


def test_needs_odometry_or_pose():
    with pytest.raises(LogcalInputError, match=r"\(v, omega\) or \(x, y\)"):
        derive_kappa(_frame([0.0, 1.0], psi=[0.0, 0.0]))
