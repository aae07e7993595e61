"""The independent generators of the diff drive, the arm and the tractor-trailer kinds."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from indgen.arm import (
    ArmParams,
    arm_log,
    forward_dynamics,
    inverse_dynamics,
    rigid_torque,
    urdf_text,
)
from indgen.diffdrive import diff_drive_log
from indgen.kinds import HELD_OUT_KINDS, KINDS, NEW_KINDS, ROBOTS, kinds_of
from indgen.refit import refit_effect
from indgen.robot_writers import write_log
from indgen.robotlog import effect_size
from indgen.robots import generate_log
from indgen.tractor_kinds import backlash, tractor_log
from scipy.integrate import solve_ivp

INDGEN = Path(__file__).parent / "indgen"


def test_generators_import_nothing_of_logcal() -> None:
    pat = re.compile(r"^\s*(from|import)\s+(calib|logtools|viz)\b", re.M)
    for src in INDGEN.glob("*.py"):
        assert not pat.search(src.read_text()), f"{src.name} imports code under test"


def test_kinds_cover_the_robots() -> None:
    assert len(KINDS) >= 10
    assert {"hitch_nonlinearity", "dropped_increments", "cogging"} <= HELD_OUT_KINDS
    assert set(KINDS) >= HELD_OUT_KINDS
    for robot in ROBOTS:
        assert kinds_of(robot), robot
        assert set(kinds_of(robot, include_held_out=True)) - set(kinds_of(robot))


def test_new_kinds_span_the_robots_with_a_third_held_out() -> None:
    assert len(NEW_KINDS) >= 12
    assert len(set(NEW_KINDS)) == len(NEW_KINDS)
    assert set(NEW_KINDS) <= set(KINDS)
    held = set(NEW_KINDS) & HELD_OUT_KINDS
    assert len(NEW_KINDS) // 4 <= len(held) <= len(NEW_KINDS) // 2
    for robot in ROBOTS:
        mine = {k for k in NEW_KINDS if KINDS[k].robot == robot}
        assert mine - HELD_OUT_KINDS, robot
        assert mine & HELD_OUT_KINDS, robot
    for d in KINDS.values():
        assert all(isinstance(n, str) and n for n in d.accepted_names)


@pytest.mark.parametrize("kind", NEW_KINDS)
def test_new_kind_at_zero_is_the_clean_log(kind: str) -> None:
    robot = KINDS[kind].robot
    a = generate_log(robot, 5, kind, 0.0, duration_s=20.0, refit=False)
    b = generate_log(robot, 5, None, duration_s=20.0, refit=False)
    assert a.truth["max_effect_size"] == 0.0
    for topic, s in a.streams.items():
        for f, v in s.fields.items():
            assert np.array_equal(v, b.streams[topic].fields[f]), (topic, f)


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_each_kind_changes_the_recording(kind: str) -> None:
    d = KINDS[kind]
    m = math.sqrt(d.lo * d.hi)
    log = generate_log(d.robot, 11, kind, m, duration_s=25.0)
    assert log.truth["max_effect_size"] > 0
    assert log.truth["kind"] == kind
    assert log.truth["magnitude"] == m
    for key in ("refit_effect_size", "heldout_effect_size"):
        assert math.isfinite(log.truth[key])
        assert log.truth[key] >= 0
    assert log.truth["refit_effect_size"] == max(log.truth["refit_effect_channels"].values())
    json.dumps(log.truth)


@pytest.mark.parametrize("robot", ROBOTS)
def test_clean_log_has_zero_effect_and_is_deterministic(robot: str) -> None:
    a = generate_log(robot, 4, None, duration_s=25.0)
    b = generate_log(robot, 4, None, duration_s=25.0)
    assert a.truth["max_effect_size"] == 0.0
    assert all(v == 0.0 for v in a.truth["effect_size"].values())
    assert a.truth["refit_effect_size"] == 0.0
    assert a.truth["heldout_effect_size"] == 0.0
    for topic, s in a.streams.items():
        assert np.array_equal(s.stamps_ns, b.streams[topic].stamps_ns)
        for f, v in s.fields.items():
            assert np.array_equal(v, b.streams[topic].fields[f])


@pytest.mark.parametrize(
    ("gen", "param", "rel", "raw_min"),
    [
        (tractor_log, "L2", 0.01, 0.5),
        (tractor_log, "L2", 0.1, 5.0),
        (diff_drive_log, "r_R", 0.01, 50.0),
        (arm_log, "m2", 0.05, 5.0),
    ],
)
def test_refit_absorbs_a_pure_parameter_change(gen, param: str, rel: float, raw_min: float) -> None:
    """A 'physics' that is only the robot's own parameter changed (the clean recording with
    L2 / r_R / m2 scaled) changes the recording a lot, but a refit takes all of it."""
    seed = 1
    clean = gen(seed, duration_s=30.0)
    base = clean.truth["arm"][param] if param == "m2" else clean.truth[param]
    changed = gen(seed, duration_s=30.0, perturb={param: rel * base})
    raw = max(effect_size(changed, clean).values())
    rf = refit_effect(gen, seed, changed, clean, duration_s=30.0)
    assert raw > raw_min
    assert max(rf["refit"].values()) < 0.02 * raw
    assert max(rf["refit"].values()) < 0.05
    assert max(rf["heldout"].values()) < 0.05


def test_refit_effect_keeps_what_a_refit_cannot_absorb() -> None:
    """A mid-log radius change is partly absorbed (one constant radius fits both halves
    halfway), a stuck encoder hardly at all; the held-out flavour is not below the in-sample."""
    rc = generate_log("diff_drive", 11, "radius_change", 0.1, duration_s=30.0).truth
    assert 0.5 < rc["refit_effect_size"] < 0.2 * rc["max_effect_size"]
    assert rc["heldout_effect_size"] >= 0.9 * rc["refit_effect_size"]
    beta = rc["refit"]["beta"]["r_R" if rc["wheel"] == "right" else "r_L"]
    assert 0 < beta / (0.1 * rc["params"]["r_R" if rc["wheel"] == "right" else "r_L"]) < 1
    st = generate_log("diff_drive", 11, "stuck_encoder", 3.0, duration_s=30.0).truth
    assert st["refit_effect_size"] > 5.0


def test_backlash_operator() -> None:
    u = np.concatenate([np.linspace(0, 1, 11), np.linspace(1, 0, 11)])
    y = backlash(u, 0.2)
    assert np.all(np.abs(u - y) <= 0.1 + 1e-12)
    assert y[11] == pytest.approx(0.9)  # turning point: the output holds
    assert y[12] == pytest.approx(0.9)


def _energy(p: ArmParams, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    M = np.stack(
        [
            rigid_torque(p, q, np.zeros_like(q), np.tile(e, (len(q), 1)))
            - rigid_torque(p, q, np.zeros_like(q), np.zeros_like(q))
            for e in np.eye(2)
        ],
        axis=-1,
    )
    kin = 0.5 * np.einsum("ni,nij,nj->n", qd, M, qd)
    q12 = q[:, 0] + q[:, 1]
    pot = p.g * (
        (p.m1 * p.cx1 + p.m2 * p.l1) * np.sin(q[:, 0])
        + p.m1 * p.cy1 * np.cos(q[:, 0])
        + p.m2 * p.cx2 * np.sin(q12)
        + p.m2 * p.cy2 * np.cos(q12)
    )
    return kin + pot


def test_arm_dynamics_conserve_energy_and_invert() -> None:
    p = ArmParams(cy1=0.01, cy2=-0.02, Fc=(0.0, 0.0), Fv=(0.0, 0.0))

    def rhs(_: float, s: np.ndarray) -> np.ndarray:
        a = forward_dynamics(p, s[None, :2], s[None, 2:], np.zeros((1, 2)))[0]
        return np.concatenate([s[2:], a])

    sol = solve_ivp(
        rhs, (0, 3), [0.3, -0.5, 0.0, 1.0], rtol=1e-11, atol=1e-12, t_eval=np.linspace(0, 3, 50)
    )
    e = _energy(ArmParams(cy1=0.01, cy2=-0.02), sol.y[:2].T, sol.y[2:].T)
    assert np.ptp(e) < 1e-6 * max(1.0, np.abs(e).max())
    rng = np.random.default_rng(0)
    q, qd, qdd = rng.normal(size=(3, 20, 2))
    pf = ArmParams()
    tau = inverse_dynamics(pf, q, qd, qdd)
    assert np.allclose(forward_dynamics(pf, q, qd, tau), qdd)


def test_urdf_matches_own_dynamics(tmp_path: Path) -> None:
    pin = pytest.importorskip("pinocchio")
    p = ArmParams(cy1=0.01, cy2=-0.015)
    path = tmp_path / "arm.urdf"
    path.write_text(urdf_text(p))
    model = pin.buildModelFromUrdf(str(path))
    data = model.createData()
    rng = np.random.default_rng(1)
    for _ in range(5):
        q, qd, qdd = rng.normal(size=(3, 2))
        ref = pin.rnea(model, data, q, qd, qdd)
        ours = rigid_torque(p, q[None], qd[None], qdd[None])[0]
        assert np.allclose(ours, ref, atol=1e-9), (ours, ref)


def test_diff_drive_truth_recovered_from_its_own_log() -> None:
    """Wheel increments and pose increments of a clean log give back r_R, r_L, b."""
    log = generate_log("diff_drive", 8, None, duration_s=40.0, variant="logcal")
    w, pose = log.streams["/wheels"], log.streams["/pose"]
    tw, tp = w.t_true, pose.t_true
    k = np.arange(0, tw.size, max(1, round(0.5 / np.median(np.diff(tw)))))
    yaw = np.interp(tw[k], tp, np.unwrap(pose.fields["yaw"]))
    x, y = np.interp(tw[k], tp, pose.fields["x"]), np.interp(tw[k], tp, pose.fields["y"])
    dl, dr = np.diff(w.fields["left"][k]), np.diff(w.fields["right"][k])
    mid = 0.5 * (yaw[1:] + yaw[:-1])
    ds = np.diff(x) * np.cos(mid) + np.diff(y) * np.sin(mid)
    A = np.column_stack([dr, dl]) / 2
    rr, rl = np.linalg.lstsq(A, ds, rcond=None)[0]
    ab = np.linalg.lstsq(
        np.column_stack([dr * rr, -dl * rl]).sum(1, keepdims=True), np.diff(yaw), rcond=None
    )[0][0]
    t = log.truth
    assert rr == pytest.approx(t["r_R"], rel=0.01)
    assert rl == pytest.approx(t["r_L"], rel=0.01)
    assert 1 / ab == pytest.approx(t["b"], rel=0.02)


def test_writers_round_trip(tmp_path: Path) -> None:
    from mcap.reader import make_reader

    log = generate_log("arm", 2, None, duration_s=5.0)
    paths = write_log(tmp_path, log)
    assert paths["arm.urdf"].read_text().startswith("<?xml")
    with open(paths["log"], "rb") as fh:
        msgs = [(c.topic, json.loads(m.data)) for _, c, m in make_reader(fh).iter_messages()]
    assert {t for t, _ in msgs} == {"/joint_states"}
    assert msgs[0][1]["name"] == ["joint1", "joint2"]
    assert len(msgs[0][1]["effort"]) == 2
    dd = generate_log("diff_drive", 2, None, duration_s=5.0, variant="gyro")
    p = write_log(tmp_path, dd, name="dd", fmt="csv")["log"]
    assert p.read_text().splitlines()[0].split(",")[:3] == ["t", "wheel_left", "wheel_right"]
    p = write_log(tmp_path, dd, name="dd")["log"]
    with open(p, "rb") as fh:
        topics = {c.topic for _, c, _ in make_reader(fh).iter_messages()}
    assert topics == {"/wheels", "/pose", "/cmd/vel", "/odom", "/imu/data"}
