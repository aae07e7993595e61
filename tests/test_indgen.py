"""Self-checks of the independent log generator (tests/indgen) against facts that do not come
from logcal: the steady-state relation, no side slip of the trailer axle, the METHODS.md
transient numbers, the definitions of the injected effects, the sampling rules, and that the
files open with the plain mcap reader and rosbags' AnyReader."""

from __future__ import annotations

import csv
import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from indgen import (
    SMALL_ROBOT,
    Command,
    Effects,
    Generated,
    Scenario,
    Speed,
    TopicSpec,
    generate,
    integrate,
    random_scenario,
    small_robot_scenario,
    write_csv,
    write_mcap_json,
    write_mcap_ros2,
    write_rosbag1,
    write_rosbag2,
)
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory


def _steady_psi(kappa: np.ndarray, L1: float, L2: float) -> np.ndarray:
    """Root of sin psi = kappa (L2 + L1 cos psi) near kappa (L1 + L2), by Newton."""
    p = np.arcsin(np.clip(kappa * (L1 + L2), -0.99, 0.99))
    for _ in range(60):
        f = np.sin(p) - kappa * (L2 + L1 * np.cos(p))
        p = p - f / (np.cos(p) + kappa * L1 * np.sin(p))
    return p


def _lateral_slip(gen_or_traj: Generated, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Velocity of C2 across and along th2, by central differences of the trailer pose."""
    h = 1e-4
    sm, sp, s0 = (gen_or_traj.trajectory.signals(t + d) for d in (-h, h, 0.0))
    vx = (sp["x2"] - sm["x2"]) / (2 * h)
    vy = (sp["y2"] - sm["y2"]) / (2 * h)
    th2 = s0["th2"]
    return -vx * np.sin(th2) + vy * np.cos(th2), vx * np.cos(th2) + vy * np.sin(th2)


# ---- physics ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("L1", "L2", "kappa"), [(1.25, 2.48, 0.15), (-0.3, 1.5, -0.4), (0.0, 2.0, 0.3)]
)
def test_steady_state_relation(L1: float, L2: float, kappa: float) -> None:
    scn = Scenario(
        L1=L1, L2=L2, duration_s=60.0, command=Command("constant", M=kappa), speed=Speed(base=3.0)
    )
    psi = integrate(scn).signals(np.array([60.0]))["psi"][0]
    assert math.sin(psi) == pytest.approx(kappa * (L2 + L1 * math.cos(psi)), abs=1e-9)
    assert np.sign(psi) == np.sign(kappa)


def test_methods_transient_lag_numbers() -> None:
    """METHODS.md section 1: with kappa = 0.2 sin(0.1 t) the joint angle lags the steady state
    by up to 0.18 rad at 1 m/s and 0.6 rad at 0.2 m/s (L1 = 1.25, L2 = 2.48, 63 s)."""
    for v, lag in ((1.0, 0.18), (0.2, 0.6)):
        scn = Scenario(duration_s=63.0, command=Command("H", M=0.2), speed=Speed(base=v))
        s = integrate(scn).signals(np.linspace(0, 63, 1261))
        err = np.abs(s["psi"] - _steady_psi(s["kappa"], 1.25, 2.48)).max()
        assert err == pytest.approx(lag, abs=0.01)


def test_trailer_axle_never_slips_sideways() -> None:
    spd_k, spd_f = Speed.envelope(40.0, ramp_s=2.0, stops=((12.0, 2.0),), reverse=(25.0, 1.5, 0.2))
    scn = Scenario(
        L1=0.8,
        L2=1.6,
        duration_s=40.0,
        speed=Speed(base=2.0, knots_t=spd_k, knots_f=spd_f),
        command=Command("chirp", M=0.25, f0_hz=0.01, f1_hz=0.3, chirp_s=40.0),
        effects=Effects(actuator_lag_s=0.3, actuator_delay_s=0.2, understeer_K=0.05),
        topics={},
    )
    gen = generate(scn, 0)
    t = np.linspace(0.01, 39.99, 4001)
    lat, lon = _lateral_slip(gen, t)
    assert np.abs(lat).max() < 1e-6
    assert np.abs(lon).max() > 0.5  # it does move
    # the tractor's reference point moves along its heading at speed v
    h = 1e-4
    sm, sp, s0 = (gen.trajectory.signals(t + d) for d in (-h, h, 0.0))
    vx, vy = (sp["x"] - sm["x"]) / (2 * h), (sp["y"] - sm["y"]) / (2 * h)
    assert np.abs(-vx * np.sin(s0["yaw"]) + vy * np.cos(s0["yaw"])).max() < 1e-6
    assert np.abs(vx * np.cos(s0["yaw"]) + vy * np.sin(s0["yaw"]) - s0["v"]).max() < 1e-6
    # hitch: P is both C1 - L1 e(th1) and C2 + L2 e(th2), so |P - C2| = L2 exactly
    d = np.hypot(s0["xP"] - s0["x2"], s0["yP"] - s0["y2"])
    assert np.abs(d - 1.6).max() < 1e-12


def test_trailer_slip_effect_slips_and_shrinks_psi() -> None:
    base = Scenario(
        L1=1.0,
        L2=2.0,
        duration_s=40.0,
        command=Command("constant", M=0.2),
        speed=Speed(base=4.0),
        topics={},
    )
    slip = Scenario(**{**base.__dict__, "effects": Effects(trailer_slip=0.03)})
    g0, g1 = generate(base, 0), generate(slip, 0)
    assert g1.truth["effects"] == {"trailer_slip": {"c": 0.03}}
    lat, _ = _lateral_slip(g1, np.array([39.0]))
    assert abs(lat[0]) > 1e-3
    p0 = g0.trajectory.signals(np.array([40.0]))["psi"][0]
    p1 = g1.trajectory.signals(np.array([40.0]))["psi"][0]
    assert 0 < p1 < p0


def test_steered_small_robot_geometry() -> None:
    """Steady turn of the small robot: kappa = tan(delta)/0.42, hitch 2 cm ahead of the axle."""
    scn = small_robot_scenario(
        np.random.default_rng(0),
        duration_s=23.0,
        command=Command("constant", M=0.3),
        speed=Speed(base=1.0),
        topics={},
    )
    s = integrate(scn).signals(np.array([23.0]))
    k = math.tan(0.3) / 0.42
    assert s["kappa"][0] == pytest.approx(k, rel=1e-12)
    assert s["delta"][0] == pytest.approx(0.3, rel=1e-12)
    L1, L2 = SMALL_ROBOT["L1"], SMALL_ROBOT["L2"]
    assert L1 == -0.02
    psi = s["psi"][0]
    assert math.sin(psi) == pytest.approx(k * (L2 + L1 * math.cos(psi)), abs=1e-6)


def test_command_shapes() -> None:
    t = np.linspace(0.0, 63.0, 631)
    np.testing.assert_allclose(Command("H", M=0.2).values(t), 0.2 * np.sin(0.1 * t))
    np.testing.assert_allclose(Command("C", M=0.1).values(t), 0.1 * np.tanh(0.1 * t))
    np.testing.assert_allclose(Command("L", M=0.2).values(t), 0.2 * (0.1 * t / np.pi - 1))
    steps = Command("steps", step_times=(10.0, 30.0), step_levels=(0.0, 0.3, -0.1), rate=0.05)
    u = steps.values(t)
    assert np.abs(np.diff(u) / np.diff(t)).max() <= 0.05 + 1e-12
    assert (u[0], u[-1]) == (0.0, -0.1)
    assert steps.breaks() == (10.0, 16.0, 30.0, 38.0)
    assert [steps(10.0, left=True), steps(16.0)] == [0.0, 0.3]
    rng = np.random.default_rng(0)
    for _ in range(20):
        scn = random_scenario(rng, duration_s=40.0)
        u = scn.command.values(np.linspace(0, 40, 801))
        assert np.abs(u).max() <= scn.command.max_abs() + 1e-12
        v = scn.speed.values(np.linspace(0, 40, 801))
        assert v.max() <= 8.0


# ---- effects ------------------------------------------------------------------------------


def _noise_free(**kw: object) -> Scenario:
    base: dict[str, object] = {
        "L1": 1.0,
        "L2": 2.0,
        "duration_s": 30.0,
        "speed": Speed(base=2.0),
        "command": Command("steps", step_times=(10.0,), step_levels=(0.0, 0.2)),
        "topics": {g: TopicSpec(50.0) for g in ("cmd", "cmd_vel", "odom", "pose", "hitch")},
    }
    base.update(kw)
    return Scenario(**base)  # type: ignore[arg-type]


def test_actuator_delay_lag_understeer() -> None:
    d, tau, K, v = 0.4, 0.7, 0.1, 2.0
    gen = generate(
        _noise_free(effects=Effects(actuator_delay_s=d, actuator_lag_s=tau, understeer_K=K)), 3
    )
    od = gen.topics["/odom"]
    kappa = od.fields["omega"] / od.fields["v"]
    expect = np.where(od.t_true >= 10 + d, 0.2 * (1 - np.exp(-(od.t_true - 10 - d) / tau)), 0.0)
    np.testing.assert_allclose(kappa, expect / (1 + K * v * v), atol=1e-9)
    assert gen.truth["effects"] == {
        "actuator_delay": {"delay": d},
        "actuator_lag": {"time_constant": tau},
        "understeer": {"K": K},
    }
    cmd = gen.topics["/cmd/curvature"]
    np.testing.assert_array_equal(cmd.fields["curvature"], np.where(cmd.t_true >= 10, 0.2, 0.0))


def test_sensor_offset_scale_and_clock_offset() -> None:
    eff = Effects(
        sensor_offset={"psi": 0.05},
        sensor_scale={"omega": 1.1},
        clock_offset_s={"hitch": 0.25, "odom": -0.1},
    )
    gen = generate(_noise_free(effects=eff), 4)
    h, od = gen.topics["/hitch/angle"], gen.topics["/odom"]
    s = gen.trajectory.signals(h.t_true)
    np.testing.assert_allclose(h.fields["angle"], s["psi"] + 0.05, atol=1e-12)
    s = gen.trajectory.signals(od.t_true)
    np.testing.assert_allclose(od.fields["omega"], 1.1 * s["omega"], atol=1e-12)
    t0 = gen.scenario.start_ns
    np.testing.assert_allclose((h.stamps_ns - t0) / 1e9 - h.t_true, 0.25, atol=2e-9)
    np.testing.assert_allclose((od.stamps_ns - t0) / 1e9 - od.t_true, -0.1, atol=2e-9)
    p = gen.topics["/pose"]
    np.testing.assert_allclose((p.stamps_ns - t0) / 1e9 - p.t_true, 0.0, atol=2e-9)
    assert set(gen.truth["effects"]) == {
        "sensor_offset(psi)",
        "sensor_scale(omega)",
        "clock_offset(hitch)",
        "clock_offset(odom)",
    }


# ---- sampling -----------------------------------------------------------------------------


def test_stamps_rates_jitter_stalls_dropouts() -> None:
    topics = {
        "cmd": TopicSpec(7.0),
        "odom": TopicSpec(29.0, sample_jitter_s=0.002),
        "pose": TopicSpec(29.0, stamp_noise_s=0.002, drop_prob=0.1),
        "hitch": TopicSpec(
            54.0,
            bursts_per_min=6.0,
            burst_s=(0.5, 1.0),
            quantum={"angle": 2 * math.pi / 4096},
            noise={"angle": 0.01},
        ),
    }
    scn = _noise_free(duration_s=60.0, topics=topics, n_stalls=3, max_stall_s=4.0)
    gen = generate(scn, 11)
    t0 = scn.start_ns
    stalls = gen.truth["stalls"]
    assert len(stalls) == 3
    assert all(0.2 <= b - a <= 4.0 for a, b in stalls)
    for td in gen.topics.values():
        assert np.all(np.diff(td.stamps_ns) > 0)
        for a, b in stalls:
            assert not np.any((td.t_true >= a) & (td.t_true < b))
        rate = gen.truth["topics"][td.topic]["rate_hz"]
        phase = gen.truth["topics"][td.topic]["phase_s"]
        k = np.round((td.t_true - phase) * rate)
        dev = td.t_true - (phase + k / rate)
        stamp_dev = (td.stamps_ns - t0) / 1e9 - td.t_true
        if td.group == "cmd":  # regular: exact grid, exact stamps
            assert np.abs(dev).max() < 1e-12
            assert np.abs(stamp_dev).max() < 1e-9
            lost = sum(b - a for a, b in stalls)
            assert abs(td.t_true.size - rate * (60 - lost)) <= 3 * len(stalls) + 1
        elif td.group == "odom":  # irregular instants, stamped correctly
            assert 0.001 < np.std(dev) < 0.003
            assert np.abs(dev).max() <= 0.2 / rate + 1e-12
            assert np.abs(stamp_dev).max() < 1e-9
        elif td.group == "pose":  # regular instants, noisy stamps, random dropouts
            assert np.abs(dev).max() < 1e-12
            assert 0.001 < np.std(stamp_dev) < 0.003
            assert np.abs(stamp_dev).max() <= 0.2 / rate + 1e-9
        else:  # hitch: quantised
            q = 2 * math.pi / 4096
            np.testing.assert_allclose(
                td.fields["angle"] / q, np.round(td.fields["angle"] / q), atol=1e-6
            )
    # stalls hit every topic at once: each stall is a gap in every topic
    for a, b in stalls:
        for td in gen.topics.values():
            before, after = td.t_true[td.t_true < a], td.t_true[td.t_true >= b]
            if before.size and after.size:
                assert after[0] - before[-1] >= b - a


def test_deterministic_and_random_sweep_fast() -> None:
    rng = np.random.default_rng(2024)
    worst = 0.0
    for i in range(12):
        scn = random_scenario(
            rng,
            duration_s=60.0,
            effects=("actuator_delay", "understeer", "clock_offset(hitch)") if i % 3 == 0 else (),
        )
        t = time.perf_counter()
        gen = generate(scn, i)
        worst = max(worst, time.perf_counter() - t)
        assert gen.truth["max_abs_psi"] < 0.7
        assert 0.5 <= scn.L1 + scn.L2 <= 5.0
        assert -0.05 <= scn.L1 / (scn.L1 + scn.L2) <= 0.6
        assert {"/cmd/curvature", "/hitch/angle"} <= set(gen.topics)
    assert worst < 1.0
    # a topic's draws do not depend on which other topics are present
    only = generate(Scenario(**{**scn.__dict__, "topics": {"hitch": scn.topics["hitch"]}}), 5)
    full = generate(scn, 5)
    np.testing.assert_array_equal(
        only.topics["/hitch/angle"].fields["angle"], full.topics["/hitch/angle"].fields["angle"]
    )
    a, b = generate(scn, 5), generate(scn, 5)
    for k in a.topics:
        np.testing.assert_array_equal(a.topics[k].stamps_ns, b.topics[k].stamps_ns)
        for f in a.topics[k].fields:
            np.testing.assert_array_equal(a.topics[k].fields[f], b.topics[k].fields[f])


def test_small_robot_barely_moves_and_stalls() -> None:
    rng = np.random.default_rng(9)
    scn = small_robot_scenario(rng, barely_moves=True)
    gen = generate(scn, 1)
    assert 10 <= scn.duration_s <= 23
    assert gen.truth["distance_m"] == pytest.approx(0.02, rel=0.02)
    assert all(b - a <= 2.3 for a, b in gen.truth["stalls"])
    cv = gen.topics["/cmd_vel"]
    assert np.all((cv.fields["v"] > 0) & (cv.fields["v"] <= 0.3))  # commanded as usual
    rates = {k: v["rate_hz"] for k, v in gen.truth["topics"].items()}
    assert rates == {
        "/cmd_vel": 7.0,
        "/encoder/angle": 54.0,
        "/odom": 29.0,
        "/truck_trailer/truck_pose": 29.0,
        "/kelo_angle": 20.0,
        "/tf": 29.0,
    }


# ---- files --------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def tt_log() -> Generated:
    topics = {
        "cmd": TopicSpec(7.0),
        "cmd_vel": TopicSpec(10.0),
        "odom": TopicSpec(29.0),
        "pose": TopicSpec(29.0, noise={"x": 0.01}),
        "hitch": TopicSpec(54.0),
    }
    scn = Scenario(
        duration_s=20.0,
        command=Command("H", M=0.2),
        speed=Speed(base=1.5),
        topics=topics,
        n_stalls=1,
        max_stall_s=2.0,
    )
    return generate(scn, 2)


def _counts(gen: Generated) -> dict[str, int]:
    return {k: int(v.stamps_ns.size) for k, v in gen.topics.items()}


def test_mcap_json_opens_with_plain_reader(tt_log: Generated, tmp_path: Path) -> None:
    path = tmp_path / "a.mcap"
    write_mcap_json(path, tt_log)
    with open(path, "rb") as fh:
        r = make_reader(fh)
        summ = r.get_summary()
        assert summ is not None
        meta = {m.name: m.metadata for m in r.iter_metadata()}
        assert meta["logcal"] == {"robot": "tractor_trailer", "L1": "1.25", "L2": "2.48"}
        got: dict[str, list[tuple[int, dict[str, float]]]] = {}
        for schema, ch, msg in r.iter_messages():
            assert schema is not None
            assert (schema.encoding, ch.message_encoding) == ("jsonschema", "json")
            got.setdefault(ch.topic, []).append((msg.log_time, json.loads(msg.data)))
    assert {k: len(v) for k, v in got.items()} == _counts(tt_log)
    h = tt_log.topics["/hitch/angle"]
    assert [t for t, _ in got["/hitch/angle"]] == h.stamps_ns.tolist()
    assert [m["angle"] for _, m in got["/hitch/angle"]] == h.fields["angle"].tolist()
    assert set(got["/pose"][0][1]) == {"x", "y", "yaw"}


def test_mcap_ros2_opens_with_plain_reader(tt_log: Generated, tmp_path: Path) -> None:
    path = tmp_path / "b.mcap"
    write_mcap_ros2(path, tt_log)
    with open(path, "rb") as fh:
        r = make_reader(fh, decoder_factories=[DecoderFactory()])
        assert next(r.iter_metadata()).name == "logcal"
        got: dict[str, list[tuple[int, Any]]] = {}
        types: dict[str, str] = {}
        for schema, ch, msg, ros in r.iter_decoded_messages():
            assert schema is not None
            assert (schema.encoding, ch.message_encoding) == ("ros2msg", "cdr")
            types[ch.topic] = schema.name
            got.setdefault(ch.topic, []).append((msg.log_time, ros))
    assert {k: len(v) for k, v in got.items()} == _counts(tt_log)
    assert types == {
        "/cmd/curvature": "std_msgs/msg/Float64",
        "/cmd/vel": "geometry_msgs/msg/Twist",
        "/odom": "nav_msgs/msg/Odometry",
        "/pose": "nav_msgs/msg/Odometry",
        "/hitch/angle": "std_msgs/msg/Float64",
    }
    pose, od = tt_log.topics["/pose"], tt_log.topics["/odom"]
    t, m = got["/pose"][5]
    assert t == pose.stamps_ns[5]
    assert m.pose.pose.position.x == pose.fields["x"][5]
    q = m.pose.pose.orientation
    assert 2 * math.atan2(q.z, q.w) == pytest.approx(pose.fields["yaw"][5], abs=1e-12)
    _, m = got["/odom"][3]
    assert m.twist.twist.linear.x == od.fields["v"][3]
    assert m.twist.twist.angular.z == od.fields["omega"][3]
    assert m.header.stamp.sec * 10**9 + m.header.stamp.nanosec == od.stamps_ns[3]


def test_csv_columns(tt_log: Generated, tmp_path: Path) -> None:
    path = tmp_path / "c.csv"
    write_csv(path, tt_log)
    with open(path) as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0]) == ["t", "kappa_cmd", "v_cmd", "v", "omega", "x", "y", "yaw", "psi"]
    assert sum(r["psi"] != "" for r in rows) == tt_log.topics["/hitch/angle"].stamps_ns.size
    assert sum(r["x"] != "" for r in rows) == tt_log.topics["/pose"].stamps_ns.size
    t = np.array([float(r["t"]) for r in rows])
    assert np.all(np.diff(t) > 0)


@pytest.mark.parametrize("fmt", ["sqlite3", "mcap", "ros1"])
def test_rosbags_small_robot(fmt: str, tmp_path: Path) -> None:
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    gen = generate(small_robot_scenario(np.random.default_rng(5)), 3)
    path = tmp_path / ("bag.bag" if fmt == "ros1" else "bag")
    if fmt == "ros1":
        write_rosbag1(path, gen)
    else:
        write_rosbag2(path, gen, storage=fmt)  # type: ignore[arg-type]
    if fmt == "sqlite3":
        assert list(path.glob("*.db3"))
    got: dict[str, list[tuple[int, Any]]] = {}
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_FOXY)) as r:
        types = {c.topic: c.msgtype for c in r.connections}
        for conn, t, raw in r.messages():
            got.setdefault(conn.topic, []).append((t, r.deserialize(raw, conn.msgtype)))
    assert types == {
        "/cmd_vel": "geometry_msgs/msg/Twist",
        "/encoder/angle": "std_msgs/msg/Float32",
        "/odom": "nav_msgs/msg/Odometry",
        "/truck_trailer/truck_pose": "geometry_msgs/msg/PoseStamped",
        "/kelo_angle": "std_msgs/msg/Float32",
        "/tf": "tf2_msgs/msg/TFMessage",
    }
    assert {k: len(v) for k, v in got.items()} == _counts(gen)
    cv, od, tp = (
        gen.topics["/cmd_vel"],
        gen.topics["/odom"],
        gen.topics["/truck_trailer/truck_pose"],
    )
    t, m = got["/cmd_vel"][4]
    assert (t, m.linear.x, m.angular.z) == (
        cv.stamps_ns[4],
        cv.fields["v"][4],
        cv.fields["delta"][4],
    )
    t, m = got["/odom"][7]
    assert m.pose.pose.position.x == od.fields["x"][7]  # trailer pose C2
    assert m.twist.twist.linear.x == 0.0
    assert m.header.stamp.sec * 10**9 + m.header.stamp.nanosec == t == od.stamps_ns[7]
    _, m = got["/truck_trailer/truck_pose"][7]
    assert m.pose.position.y == tp.fields["y"][7]
    _, m = got["/tf"][0]
    assert (m.transforms[0].header.frame_id, m.transforms[0].child_frame_id) == (
        "map",
        "truck_link",
    )
    _, m = got["/encoder/angle"][0]
    assert m.data == pytest.approx(gen.topics["/encoder/angle"].fields["angle"][0], abs=1e-6)
