"""The path-driven transient fit, checked against facts from outside its own code.

Truth comes from the independent generator (tests/indgen: solve_ivp on the continuous model,
no code shared with calib) and from the steady-state relation of METHODS.md. These are
deterministic checks on fixed, noise-free or fixed-seed logs; the coverage of the intervals
over many seeds and conditions is bench/path_coverage_study.py's job.
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np
import pytest
from indgen import Command, Scenario, Speed, TopicSpec, generate, small_robot_scenario

from calib.errors import InsufficientDataError
from calib.tractor_trailer.estimators.drive_path import DrivePath, pool_runs
from calib.tractor_trailer.estimators.path_transient import PathTransientFit
from calib.tractor_trailer.models.hitch_path import advance_psi


def _clean_scenario(rate_hz: float, **kw: object) -> Scenario:
    topics = {g: TopicSpec(rate_hz) for g in ("cmd", "odom", "pose", "hitch")}
    base = Scenario(
        L1=1.25,
        L2=2.48,
        duration_s=60.0,
        command=Command(
            "random",
            M=0.15,
            freqs_hz=(0.02, 0.07, 0.13),
            phases=(0.3, 1.0, 2.0),
            weights=(0.5, 0.3, 0.2),
        ),
        speed=Speed(base=1.5),
        topics=topics,
    )
    return dc.replace(base, **kw)


def _arrays(gen, source: str) -> tuple[DrivePath, np.ndarray, np.ndarray]:
    t0 = gen.truth["start_ns"]

    def ts(topic: str) -> np.ndarray:
        return (gen.topics[topic].stamps_ns - t0) / 1e9

    f = {k: v.fields for k, v in gen.topics.items()}
    if source == "pose":
        path = DrivePath.from_pose(ts("/pose"), f["/pose"]["x"], f["/pose"]["y"], f["/pose"]["yaw"])
    else:
        path = DrivePath.from_rates(ts("/odom"), f["/odom"]["v"], f["/odom"]["omega"])
    return path, ts("/hitch/angle"), f["/hitch/angle"]["angle"]


def test_kernel_reaches_the_steady_state_relation() -> None:
    """Along a circle the integrated joint angle settles where sin psi = kappa (L2 + L1 cos psi)
    (METHODS.md), for a hitch behind, on and ahead of the axle."""
    kappa = 0.2
    ds = np.full((10000, 1), 0.01)  # 100 m in 1 cm steps
    for L1 in (1.25, 0.0, -0.3):
        L2 = 2.48
        psi = advance_psi(kappa * ds, ds, np.array([L1]), np.array([L2]), np.zeros((1, 1)))
        end = float(psi[-1, 0, 0])
        assert math.sin(end) - kappa * (L2 + L1 * math.cos(end)) == pytest.approx(0, abs=1e-9)


@pytest.mark.parametrize("rate_hz", [5.0, 10.0, 50.0, pytest.param(200.0, marks=pytest.mark.slow)])
@pytest.mark.parametrize("source", ["pose", "odometry"])
def test_noise_free_logs_give_the_truth_at_any_rate(rate_hz: float, source: str) -> None:
    gen = generate(_clean_scenario(rate_hz), seed=1)
    path, t, psi = _arrays(gen, source)
    fit = PathTransientFit().fit(path, t, psi)
    tol = {5.0: 5e-3, 10.0: 1.5e-3}.get(rate_hz, 5e-4)  # the path's discretisation, O(h^2)
    assert pytest.approx(1.25, abs=tol) == fit.L1_
    assert pytest.approx(2.48, abs=tol) == fit.L2_
    for est, truth in ((fit.verdict_.L1, 1.25), (fit.verdict_.L2, 2.48)):
        assert est.ci95[0] <= truth <= est.ci95[1]  # the resolution check widens them


def test_asynchronous_rates_and_jitter() -> None:
    """Per-topic rates (hitch 54 Hz, pose 29 Hz, commands 7 Hz) with jittered sampling."""
    topics = {
        "cmd": TopicSpec(7.0),
        "pose": TopicSpec(29.0, sample_jitter_s=0.004),
        "hitch": TopicSpec(54.0, sample_jitter_s=0.002),
    }
    gen = generate(_clean_scenario(10.0, topics=topics), seed=2)
    path, t, psi = _arrays(gen, "pose")
    fit = PathTransientFit().fit(path, t, psi)
    assert pytest.approx(1.25, abs=1e-3) == fit.L1_
    assert pytest.approx(2.48, abs=1e-3) == fit.L2_


def test_negative_L1_and_stalls_restart_pieces() -> None:
    """The small robot (hitch 2 cm ahead of the axle) with recorder stalls: each stall starts a
    new piece and the negative L1 is found."""
    rng = np.random.default_rng(5)
    scn = small_robot_scenario(rng)
    scn = dc.replace(
        scn,
        topics={
            k: dc.replace(v, noise={}, quantum={}, stamp_noise_s=0.0, sample_jitter_s=0.0)
            for k, v in scn.topics.items()
        },
    )
    gen = generate(scn, seed=3)
    t0 = gen.truth["start_ns"]
    pose = gen.topics["/truck_trailer/truck_pose"]
    hitch = gen.topics["/encoder/angle"]
    path = DrivePath.from_pose(
        (pose.stamps_ns - t0) / 1e9, pose.fields["x"], pose.fields["y"], pose.fields["yaw"]
    )
    fit = PathTransientFit().fit(path, (hitch.stamps_ns - t0) / 1e9, hitch.fields["angle"])
    long = [b - a for a, b in gen.truth["stalls"] if b - a > 0.2]  # default_gap_s here
    assert long
    assert fit.n_pieces_ == len(long) + 1
    assert pytest.approx(-0.02, abs=2e-3) == fit.L1_
    assert pytest.approx(0.537, abs=2e-3) == fit.L2_


def test_pooled_runs_do_not_overlap_and_fit_together() -> None:
    runs = []
    for seed, M in ((1, 0.15), (2, -0.1)):
        scn = _clean_scenario(20.0, duration_s=30.0, command=Command("H", M=M))
        gen = generate(scn, seed=seed)
        path, t, psi = _arrays(gen, "odometry")
        runs.append((path, t, psi, []))
    pooled, t, psi, gaps, offsets = pool_runs(runs)
    assert np.all(np.diff(pooled.t_s) > 0)
    assert offsets[1] > runs[0][0].t_s[-1] + offsets[0]
    fit = PathTransientFit().fit(pooled, t, psi, gaps=gaps)
    assert fit.n_pieces_ == 2
    assert pytest.approx(1.25, abs=1e-3) == fit.L1_


def test_a_robot_that_stands_still_is_refused() -> None:
    t = np.linspace(0, 10, 200)
    path = DrivePath.from_rates(t, np.zeros_like(t), np.zeros_like(t))
    with pytest.raises(InsufficientDataError, match="move"):
        PathTransientFit().fit(path, t, np.zeros_like(t))


def test_noslip_regression_from_the_trailer_pose_is_exact_on_clean_data() -> None:
    """The tractor axle's no-slip constraint written on the trailer pose
    (calib.tractor_trailer.estimators.
    noslip) holds exactly on the independent generator's noise-free trailer (L1 < 0)."""
    from calib.tractor_trailer.estimators.noslip import NoSlipRegression

    scn = small_robot_scenario(np.random.default_rng(100))
    scn = dc.replace(
        scn,
        topics={
            k: dc.replace(v, noise={}, quantum={}, stamp_noise_s=0.0, sample_jitter_s=0.0)
            for k, v in scn.topics.items()
        },
    )
    gen = generate(scn, seed=0)
    t0 = gen.truth["start_ns"]
    odom, hitch = gen.topics["/odom"], gen.topics["/encoder/angle"]
    t = (odom.stamps_ns - t0) / 1e9
    psi = np.interp(t, (hitch.stamps_ns - t0) / 1e9, hitch.fields["angle"])
    fit = NoSlipRegression().fit(t, odom.fields["x"], odom.fields["y"], odom.fields["yaw"], psi)
    assert pytest.approx(-0.02, abs=1e-4) == fit.L1_
    assert pytest.approx(0.537, abs=1e-4) == fit.L2_


def test_steering_geometry_recovers_the_wheelbase_and_offset() -> None:
    """kappa = tan(delta - delta0) / wheelbase on the generator's small robot (wheelbase
    0.42 m), with a steering sensor zero offset of 0.03 rad added."""
    from calib.kinematics.bicycle import fit_steering_geometry

    scn = small_robot_scenario(np.random.default_rng(101))
    gen = generate(scn, seed=1)
    kelo = gen.topics["/kelo_angle"]
    truth = gen.trajectory.signals(kelo.t_true)
    geo = fit_steering_geometry(truth["kappa"], kelo.fields["angle"] + 0.03)
    assert geo.wheelbase.value == pytest.approx(0.42, abs=0.01)
    assert geo.offset.value == pytest.approx(0.03, abs=0.003)


def test_fill_spacing_thins_the_path_knots_between_sparse_samples() -> None:
    """With the joint angle at 2 Hz and the path at 50 Hz, every path knot between samples is
    an integration node; ``fill_spacing_s`` keeps at most one per cell of that many seconds,
    and the model at the samples stays that of the full grid to well inside the noise."""
    gen = generate(_clean_scenario(50.0))
    path, t, psi = _arrays(gen, "pose")
    t2, psi2 = t[::25], psi[::25]
    full = PathTransientFit(resolution_check=False, rate_noise_check=False)
    thin = PathTransientFit(resolution_check=False, rate_noise_check=False, fill_spacing_s=0.1)
    for f in (full, thin):
        f._prepare(path, t2, psi2, [])
    n_obs = full._t.size
    nodes_full = int(full._layout.chunk_end_step.sum()) + 1
    nodes_thin = int(thin._layout.chunk_end_step.sum()) + 1
    span = float(full._t[-1] - full._t[0])
    assert nodes_full > n_obs + 0.9 * 24 * (n_obs - 1)  # 24 knots inside each 0.5 s interval
    assert nodes_thin <= n_obs + span / 0.1 + 1
    x = np.array([1.25, 2.48])
    psi0 = np.array([float(psi2[0])])
    y_full = full._simulate_jacobian(*x, psi0)[0]
    y_thin = thin._simulate_jacobian(*x, psi0)[0]
    assert y_full.shape == y_thin.shape == (n_obs,)
    assert 0 < np.max(np.abs(y_full - y_thin)) < 1e-3
