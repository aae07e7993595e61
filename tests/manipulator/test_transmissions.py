"""A ROS arm's effort logged on the actuator side: the URDF's transmissions (both ROS forms)
are read within budgets, ``--effort actuator`` multiplies each joint's effort by its mechanical
reduction (and a torque constant from the channel map), and recovers what the joint-side log
gives; without it the effort check names the option; a joint without a transmission, or a
hostile URDF, is one clear error (exit 2)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from calib.errors import CalibError
from calib.manipulator import serial
from logtools.cli.main import main

_REDUCTIONS = {"j1": 50.0, "j2": -20.0}
_NEW_FORM = (
    '<transmission name="t1"><type>transmission_interface/SimpleTransmission</type>'
    '<joint name="j1"><hardwareInterface>hardware_interface/EffortJointInterface'
    '</hardwareInterface></joint><actuator name="m1"><mechanicalReduction>50'
    "</mechanicalReduction></actuator></transmission>"
)
_OLD_FORM = (
    '<transmission name="t2" type="pr2_mechanism_model/SimpleTransmission">'
    '<actuator name="m2"/><joint name="j2"/><mechanicalReduction>-20'
    "</mechanicalReduction></transmission>"
)


def _link(name: str, m: float, com: str) -> str:
    return (
        f'<link name="{name}"><inertial><origin xyz="{com}"/><mass value="{m}"/>'
        '<inertia ixx="0.02" iyy="0.03" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>'
        "</link>"
    )


def _urdf(transmissions: str) -> str:
    limit = '<limit lower="-2" upper="2" effort="50" velocity="3"/>'
    return (
        '<?xml version="1.0"?><robot name="two"><link name="base"/>'
        + _link("l1", 2.0, "0.2 0 0")
        + _link("l2", 1.5, "0.2 0 0.02")
        + '<joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>'
        f'<axis xyz="0 1 0"/>{limit}</joint>'
        '<joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>'
        f'<origin xyz="0.4 0 0"/><axis xyz="0 1 0"/>{limit}</joint>' + transmissions + "</robot>"
    )


@pytest.fixture(scope="module")
def arm(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with the URDF, a joint-side log, the same log actuator-side (efforts divided
    by the reductions) and one whose j1 effort is a current (also divided by a torque
    constant of 2 N·m/A)."""
    from calib.manipulator.simulate import Friction, Sensors, simulate_trajectory
    from logtools.writers.manipulator import write_arm_run

    out = tmp_path_factory.mktemp("arm")
    (out / "arm.urdf").write_text(_urdf(_NEW_FORM + _OLD_FORM))
    model = serial.load_serial_arm(str(out / "arm.urdf"), None, 2)
    run = simulate_trajectory(
        model,
        Friction(coulomb=(0.3, 0.3), viscous=(0.2, 0.2)),
        duration_s=8,
        rate_hz=250,
        sensors=Sensors(torque_noise=0.05),
        seed=3,
        center=np.zeros(2),
        amplitude=np.full(2, 1.2),
    )
    red = np.array([_REDUCTIONS["j1"], _REDUCTIONS["j2"]])
    write_arm_run(out / "joint.mcap", run, encoding="json", metadata={})
    write_arm_run(
        out / "actuator.mcap",
        dataclasses.replace(run, tau=run.tau / red),
        encoding="json",
        metadata={},
    )
    write_arm_run(
        out / "current.mcap",
        dataclasses.replace(run, tau=run.tau / (red * np.array([2.0, 1.0]))),
        encoding="json",
        metadata={},
    )
    return out


def _analyse(capsys: pytest.CaptureFixture[str], *args: str) -> dict:
    assert main(["analyze", *args, "--json"]) == 0
    doc: dict = json.loads(capsys.readouterr().out)
    return doc


def _estimate(doc: dict) -> dict[str, float]:
    est = doc["estimate"]
    pars = est["parameters"] if isinstance(est.get("parameters"), dict) else est
    return {k: v["value"] for k, v in pars.items() if isinstance(v, dict) and "value" in v}


def _values(doc: dict) -> np.ndarray:
    return np.array(list(_estimate(doc).values()))


def test_both_forms_are_read(arm: Path) -> None:
    found = {t.name: t for t in serial.read_transmissions(arm / "arm.urdf")}
    assert set(found) == {"t1", "t2"}
    assert (found["t1"].joints, found["t1"].actuators, found["t1"].reduction) == (
        ("j1",),
        ("m1",),
        50.0,
    )
    assert (found["t2"].joints, found["t2"].kind, found["t2"].reduction) == (
        ("j2",),
        "SimpleTransmission",
        -20.0,
    )
    assert found["t1"].simple
    assert found["t2"].simple


def test_a_differential_is_read_but_not_simple(tmp_path: Path) -> None:
    diff = (
        '<transmission name="w"><type>transmission_interface/DifferentialTransmission'
        '</type><actuator name="a"><mechanicalReduction>2</mechanicalReduction></actuator>'
        '<actuator name="b"><mechanicalReduction>2</mechanicalReduction></actuator>'
        '<joint name="j1"/><joint name="j2"/></transmission>'
    )
    (tmp_path / "w.urdf").write_text(_urdf(diff))
    (t,) = serial.read_transmissions(tmp_path / "w.urdf")
    assert (t.kind, t.joints, t.simple, t.reduction) == (
        "DifferentialTransmission",
        ("j1", "j2"),
        False,
        None,
    )


def test_actuator_side_log_recovers_the_joint_side_parameters(
    arm: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    urdf = str(arm / "arm.urdf")
    joint = _analyse(capsys, str(arm / "joint.mcap"), "--urdf", urdf)
    actuator = _analyse(capsys, str(arm / "actuator.mcap"), "--urdf", urdf, "--effort", "actuator")
    assert list(_estimate(actuator)) == list(_estimate(joint))
    assert len(_estimate(joint)) >= 8
    np.testing.assert_allclose(_values(actuator), _values(joint), rtol=1e-6, atol=1e-9)
    scaling = actuator["effort_scaling"]
    assert scaling["side"] == "actuator"
    assert {j: s["factor"] for j, s in scaling["joints"].items()} == _REDUCTIONS
    assert scaling["joints"]["j2"]["transmission"] == "t2"
    assert joint["effort_scaling"]["side"] == "joint"
    assert not any("disagree" in w for w in actuator["warnings"])


def test_without_the_option_the_effort_check_names_it(
    arm: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    doc = _analyse(capsys, str(arm / "actuator.mcap"), "--urdf", str(arm / "arm.urdf"))
    assert "j1" in doc["effort_scale"]["suspect"]
    assert doc["effort_scaling"]["side"] == "joint"
    (note,) = [w for w in doc["warnings"] if "disagree" in w]
    assert "--effort actuator" in note
    assert "j1 x50" in note


def test_a_torque_constant_from_the_channel_map(
    arm: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cmap = tmp_path / "map.toml"
    cmap.write_text("[robot]\ntorque_constant_j1 = 2.0\n")
    urdf = str(arm / "arm.urdf")
    joint = _analyse(capsys, str(arm / "joint.mcap"), "--urdf", urdf)
    current = _analyse(
        capsys,
        str(arm / "current.mcap"),
        "--urdf",
        urdf,
        "--effort",
        "actuator",
        "--channel-map",
        str(cmap),
    )
    np.testing.assert_allclose(_values(current), _values(joint), rtol=1e-6, atol=1e-9)
    j1 = current["effort_scaling"]["joints"]["j1"]
    assert (j1["factor"], j1["reduction"], j1["torque_constant"]) == (100.0, 50.0, 2.0)
    # given without --effort actuator: not applied, and said
    as_logged = _analyse(
        capsys, str(arm / "current.mcap"), "--urdf", urdf, "--channel-map", str(cmap)
    )
    assert any("applied with --effort actuator only" in w for w in as_logged["warnings"])
    cmap.write_text("[robot]\ntorque_constant_j9 = 2.0\n")
    assert (
        main(["analyze", str(arm / "joint.mcap"), "--urdf", urdf, "--channel-map", str(cmap)]) == 2
    )
    assert "torque_constant_j9" in capsys.readouterr().err


def test_a_joint_without_a_transmission_is_one_error(
    arm: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    partial = tmp_path / "partial.urdf"
    partial.write_text(_urdf(_NEW_FORM))
    assert (
        main(
            ["analyze", str(arm / "actuator.mcap"), "--urdf", str(partial), "--effort", "actuator"]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert "partial.urdf" in err
    assert "joint j2 has no <transmission>" in err
    assert "Traceback" not in err
    assert (
        main(
            ["analyze", str(arm / "actuator.mcap"), "--urdf", str(partial), "--effort", "sideways"]
        )
        == 2
    )


def test_info_lists_the_transmissions(arm: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log, urdf = str(arm / "actuator.mcap"), str(arm / "arm.urdf")
    assert main(["info", log, "--urdf", urdf]) == 0
    out = capsys.readouterr().out
    assert "Transmissions in" in out
    assert "\n  t1 (SimpleTransmission): joint j1 <- actuator m1, mechanical reduction 50\n" in out
    assert "\n  t2 (SimpleTransmission): joint j2 <- actuator m2, mechanical reduction -20" in out
    assert main(["info", log, "--urdf", urdf, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [t["reduction"] for t in doc["urdf"]["transmissions"]] == [50.0, -20.0]


_ENTITY = (
    '<?xml version="1.0"?><!DOCTYPE robot [<!ENTITY a "aaaaaaaaaa">'
    '<!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">]><robot name="x">&b;</robot>'
)


def test_a_hostile_urdf_is_refused_cleanly(
    arm: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "entity.urdf"
    bad.write_text(_ENTITY)
    with pytest.raises(CalibError, match="DOCTYPE"):
        serial.read_transmissions(bad)
    with pytest.raises(CalibError, match="DOCTYPE"):
        serial.load_serial_arm(str(bad), None, 2)
    for cmd in (
        ["analyze", str(arm / "actuator.mcap"), "--effort", "actuator"],
        ["info", str(arm / "actuator.mcap")],
    ):
        assert main([*cmd, "--urdf", str(bad)]) == 2
        err = capsys.readouterr().err
        assert "entity.urdf" in err
        assert "DOCTYPE" in err
        assert "Traceback" not in err
    deep = tmp_path / "deep.urdf"
    deep.write_text(_urdf(_NEW_FORM).replace("</robot>", "<a>" * 100 + "</a>" * 100 + "</robot>"))
    with pytest.raises(CalibError, match="nested more than 64"):
        serial.read_transmissions(deep)
    broken = tmp_path / "broken.urdf"
    broken.write_text(_urdf(_NEW_FORM)[:-5])
    with pytest.raises(CalibError, match="not well-formed"):
        serial.read_transmissions(broken)
    monkeypatch.setattr(serial, "MAX_URDF_BYTES", 1000)  # a huge file, without writing one
    with pytest.raises(CalibError, match="a URDF logcal reads is at most 1000 bytes"):
        serial.read_transmissions(arm / "arm.urdf")
