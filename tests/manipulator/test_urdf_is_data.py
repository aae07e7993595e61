"""A log is data, never instructions (arms): a URDF named by a log's own metadata is never
opened, model names are never globbed, and a URDF is read within budgets (a 4,000-link chain
once crashed the process); what the C++ parser prints is captured, not echoed raw."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from calib.errors import CalibError
from calib.manipulator import serial
from logtools.cli.main import main


def test_a_urdf_named_by_the_log_is_never_opened(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    log = tmp_path / "arm.mcap"
    assert (
        main(["simulate", "manipulator", "--arm", "panda", "--duration", "2", "--out", str(log)])
        == 0
    )
    opened: list[str] = []
    monkeypatch.setattr(serial, "load_serial_arm", lambda *a, **k: opened.append(a[0]))
    assert main(["analyze", str(log)]) == 2
    err = capsys.readouterr().err
    assert "never opens a file a log names" in err
    assert "'panda'" in err
    assert opened == []


@pytest.mark.parametrize("name", ["*", "?????", "pan*", "../panda", "[a-z]anda"])
def test_model_names_are_never_patterns(name: str) -> None:
    with pytest.raises(CalibError, match=r"not a file|no such file"):
        serial.load_serial_arm(name, None, 2)


def _chain(n: int) -> str:
    links = "".join(
        f'<link name="l{i}"><inertial><mass value="1"/><inertia ixx="1" iyy="1" '
        f'izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        for i in range(n + 1)
    )
    joints = "".join(
        f'<joint name="j{i}" type="revolute"><parent link="l{i}"/>'
        f'<child link="l{i + 1}"/><axis xyz="0 0 1"/>'
        f'<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        for i in range(n)
    )
    return f'<robot name="chain">{links}{joints}</robot>'


def test_a_deep_chain_is_refused_before_the_parser(tmp_path: Path) -> None:
    urdf = tmp_path / "deep.urdf"
    urdf.write_text(_chain(4000))
    with pytest.raises(CalibError, match="4001 links"):
        serial.load_serial_arm(str(urdf), None, 2)
    deep = tmp_path / "deep300.urdf"
    deep.write_text(_chain(300))  # within the link budget, beyond the chain budget
    with pytest.raises(CalibError, match="chain of 300 joints"):
        serial.load_serial_arm(str(deep), None, 2)
    ok = tmp_path / "short.urdf"
    ok.write_text(_chain(3))
    arm = serial.load_serial_arm(str(ok), None, 2)
    assert arm is not None


def test_what_the_parser_prints_is_captured_and_escaped() -> None:
    with serial._quiet_stderr() as said:
        os.write(2, b"\x1b]0;pwned\x07 link \x1b[2J\n")
    assert "pwned" in said[0]
    shown = serial._escaped(said[0])
    assert "\x1b" not in shown
    assert "\x07" not in shown
    assert "\\x1b" in shown
