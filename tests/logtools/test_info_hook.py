"""``logcal info`` asks each robot (``RobotPlugin.info``) about the options it takes (declared
``option(..., info=True)``): the shared command names no robot's option or reader."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from logtools.cli.main import main
from logtools.robot_options import option_specs
from logtools.robots import plugins
from logtools.robots.manipulator.info import info_section
from logtools.robots.manipulator.options import ManipulatorOptions

SAMPLES = Path(__file__).resolve().parents[2] / "sample_logs"


def test_info_offers_the_options_declared_for_it(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info", "-h"]) == 0
    flags = set(re.findall(r"^\s+(--[\w-]+)", capsys.readouterr().out, flags=re.MULTILINE))
    declared = [s for p in plugins() for s in option_specs(p)]
    assert {s.flag for s in declared if s.info} == {"--urdf"}
    assert {s.flag for s in declared if s.info} <= flags
    assert not {s.flag for s in declared if not s.info} & flags  # --baseline, --cutoff-hz


def test_no_option_no_section(capsys: pytest.CaptureFixture[str]) -> None:
    assert info_section(ManipulatorOptions()) is None
    assert main(["info", str(SAMPLES / "tt_mixed.csv"), "--json"]) == 0
    assert "urdf" not in json.loads(capsys.readouterr().out)


def test_a_bad_urdf_names_the_flag(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "none.urdf"
    assert main(["info", str(SAMPLES / "tt_mixed.csv"), "--urdf", str(missing)]) == 2
    err = capsys.readouterr().err
    assert f"--urdf {missing}" in err
    assert "Traceback" not in err
