"""Docs and help true to the program (issue 33, item 9, text): the README's Python API example
prints plain numbers; ``logcal reproduce -h`` lists each entry whole; a log without a robot's
signals lists each robot's identifying signals (none empty); a file no format reads names every
format."""

from __future__ import annotations

import re
import runpy
from pathlib import Path

import numpy as np

from calib.results import Estimate
from logtools.cli.main import main
from logtools.readers.formats import formats

ROOT = Path(__file__).resolve().parents[2]


def test_an_estimate_holds_plain_floats() -> None:
    e = Estimate("L1", np.float64(1.25), np.float32(0.5), (np.float64(1.0), np.float64(1.5)))
    assert type(e.value) is float
    assert type(e.std) is float
    assert all(type(x) is float for x in e.ci95)
    assert "np." not in repr(e)


def test_the_readme_api_example_prints_plain_numbers(tmp_path, monkeypatch, capsys) -> None:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text[text.index("## Python API") :]
    code = re.search(r"```python\n(.*?)```", section, re.S)
    assert code is not None
    script = tmp_path / "api_example.py"
    script.write_text(code.group(1), encoding="utf-8")
    monkeypatch.chdir(ROOT)
    runpy.run_path(str(script))
    out = capsys.readouterr().out
    assert "L1 = " in out
    assert "np.float64" not in out
    assert re.search(r"L1 = \d\.\d{4} m, 95 % interval \[\d\.\d{4}, \d\.\d{4}\]", out)


def test_reproduce_help_lists_each_entry_whole(capsys) -> None:
    assert main(["reproduce", "-h"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "Recompute the patent's Figs. 8-13 beside the published numbers." in out
    commands = out[out.index("Commands:") :]
    assert "..." not in commands  # click's cut at 45 columns


def test_no_robot_found_lists_each_robots_signals(tmp_path, capsys) -> None:
    log = tmp_path / "battery.csv"
    log.write_text("t,voltage\n0.0,12.1\n0.1,12.0\n0.2,12.0\n", encoding="utf-8")
    assert main(["analyze", str(log)]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "psi (tractor_trailer)" in err
    assert "wheel_left, wheel_right or odom_omega, gyro_z (diff_drive)" in err
    assert "q1, tau1 (manipulator)" in err
    assert " (diff_drive)" in err
    assert ";  (" not in err  # no robot listed without signals


def test_a_file_no_format_reads_names_every_format(tmp_path, capsys) -> None:
    log = tmp_path / "notes.log"
    log.write_bytes(b"hello, not a log\n")
    assert main(["info", str(log)]) == 2
    err = " ".join(capsys.readouterr().err.split())
    for f in formats():
        assert " ".join(f.title.split()) in err
