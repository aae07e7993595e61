"""A ground truth on another clock, as evo names it (issue 33, item 7): ``--t-offset`` shifts
its time stamps onto the log's clock, ``--t-max-diff`` pairs a log row with it only within that
many seconds of a pose; both are refused without ``--ground-truth``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from logtools.cli.main import main
from logtools.load import LoadRequest, load_log
from logtools.readers.tum import write_tum

EPOCH = 1_700_000_000.0
OFFSET = 1000.0  # the mocap's clock runs 1000 s ahead of the robot's


def _drive(d: Path) -> tuple[Path, Path]:
    """20 s of wheel angles at 50 Hz (ours CSV), and a 10 Hz TUM ground truth stamped
    ``OFFSET`` s late with a 2 s hole in it (8 s .. 10 s)."""
    t = np.arange(0, 20, 0.02)
    wheels = d / "wheels.csv"
    rows = ["t,wheel_left,wheel_right"] + [
        f"{EPOCH + ti:.3f},{ti * 10:.5f},{ti * 10.5:.5f}" for ti in t
    ]
    wheels.write_text("\n".join(rows) + "\n", encoding="utf-8")
    tg = np.arange(0, 20, 0.1)
    tg = tg[(tg < 8.0) | (tg > 10.0)]
    gt = d / "mocap.tum"
    write_tum(gt, tg + EPOCH + OFFSET, 0.4 * tg, 0.01 * tg**2, 0.02 * tg)
    return wheels, gt


def test_a_ground_truth_on_another_clock_is_refused_then_shifted(tmp_path, capsys) -> None:
    wheels, gt = _drive(tmp_path)
    assert main(["info", str(wheels), "--ground-truth", str(gt)]) == 2
    assert "--t-offset" in capsys.readouterr().err
    args = ["info", str(wheels), "--ground-truth", str(gt), "--t-offset", str(-OFFSET)]
    assert main([*args, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["signals"]["x"]["topic"] == "mocap.tum"
    assert doc["signals"]["x"]["first_ns"] == round(EPOCH * 1e9)
    assert any("shifted by -1000 s (--t-offset)" in p for p in doc["problems"])


def test_t_max_diff_pairs_only_near_a_pose(tmp_path) -> None:
    wheels, gt = _drive(tmp_path)

    def frame(max_diff: float | None):  # type: ignore[no-untyped-def]
        req = LoadRequest(ground_truth=str(gt), t_offset_s=-OFFSET, t_max_diff_s=max_diff)
        return load_log(wheels, req).frame

    t = (frame(None)["t_ns"].to_numpy() - round(EPOCH * 1e9)) * 1e-9
    assert t[0] == 0.0
    hole = (t > 8.06) & (t < 9.94)  # farther than 0.06 s from every pose
    for max_diff in (0.06, 5.0):
        x = frame(max_diff)["x"].fill_null(np.nan).to_numpy()
        if max_diff < 1.0:
            assert np.isnan(x[hole]).all()
        else:
            assert not np.isnan(x[hole]).any()  # a 2 s hole is within 5 s of a pose


def test_the_clock_options_need_a_ground_truth(tmp_path, capsys) -> None:
    wheels, gt = _drive(tmp_path)
    assert main(["info", str(wheels), "--t-offset", "1.5"]) == 2
    assert "give --ground-truth FILE" in capsys.readouterr().err
    assert main(["info", str(wheels), "--ground-truth", str(gt), "--t-max-diff", "0"]) == 2
    assert "--t-max-diff 0: expected seconds above 0" in capsys.readouterr().err


def test_t_offset_auto_finds_the_offset(tmp_path, capsys) -> None:
    """A turning drive (yaw rate varying) whose mocap clock is 1000.25 s ahead: ``auto`` finds
    the offset from the wheels' difference rate and the ground truth's yaw rate."""
    t = np.arange(0, 40, 0.02)
    rate = 0.5 * np.sin(0.4 * t) + 0.3 * np.sin(1.3 * t + 1.0)  # turn rate, rad/s
    yaw = np.cumsum(rate) * 0.02
    wheels = tmp_path / "wheels.csv"
    rows = ["t,wheel_left,wheel_right"] + [
        f"{EPOCH + ti:.3f},{10 * ti - 2 * y:.6f},{10 * ti + 2 * y:.6f}"
        for ti, y in zip(t, yaw, strict=True)
    ]
    wheels.write_text("\n".join(rows) + "\n", encoding="utf-8")
    keep = slice(250, 1800, 5)  # 10 Hz poses from 5 s to 36 s
    gt = tmp_path / "mocap.tum"
    write_tum(gt, t[keep] + EPOCH - 1000.25, np.cos(yaw[keep]), np.sin(yaw[keep]), yaw[keep])
    args = ["info", str(wheels), "--ground-truth", str(gt), "--t-offset", "auto", "--json"]
    assert main(args) == 0
    doc = json.loads(capsys.readouterr().out)
    (note,) = [p for p in doc["problems"] if "--t-offset auto" in p]
    offset = float(note.split("shifted by ")[1].split(" s")[0])
    assert abs(offset - 1000.25) < 0.01
    assert abs(doc["signals"]["x"]["first_ns"] * 1e-9 - (EPOCH + 5.0)) < 0.02
    assert main(["info", str(wheels), "--ground-truth", str(gt), "--t-offset", "soon"]) == 2
    assert "expected a number of seconds or auto" in capsys.readouterr().err
