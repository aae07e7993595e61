"""The robots' options are typed declarations (``RobotPlugin.options``): ``analyze`` and ``view``
offer them from the declarations, one given for another robot is warned about (never an
internal error), and ``AnalysisConfig`` carries them typed by robot."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import pytest

from logtools.analyze import AnalysisConfig, options_from_settings
from logtools.cli.main import main
from logtools.errors import LogcalInputError
from logtools.robot_options import RobotOptions, option_specs
from logtools.robots import plugin_for, plugins
from logtools.robots.manipulator.options import ManipulatorOptions
from logtools.robots.tractor_trailer.options import TractorTrailerOptions


def _flags(help_text: str) -> set[str]:
    return set(re.findall(r"^\s+(?:-\w, )?(--[\w-]+)", help_text, flags=re.MULTILINE))


def test_analyze_and_view_offer_the_declared_options(capsys: pytest.CaptureFixture[str]) -> None:
    specs = [s for p in plugins() for s in option_specs(p)]
    assert {s.flag for s in specs} >= {"--urdf", "--cutoff-hz", "--discovery-span", "--method"}
    assert main(["analyze", "-h"]) == 0
    analyze = _flags(capsys.readouterr().out)
    assert main(["view", "-h"]) == 0
    view = _flags(capsys.readouterr().out)
    assert {s.flag for s in specs} <= analyze
    assert {s.flag for s in specs if s.view} <= view
    assert not {s.flag for s in specs if not s.view} & view  # e.g. --discovery-span
    assert option_specs(plugin_for("diff_drive")) == ()  # no options of its own


def test_view_of_an_arm_with_a_tractor_option_warns(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Was: "internal error: TypeError: log_views() got an unexpected keyword argument
    'method_for_psi'"."""
    log = tmp_path / "arm.mcap"
    assert main(["simulate", "manipulator", "--out", str(log), "--duration", "6"]) == 0
    capsys.readouterr()
    rrd = tmp_path / "arm.rrd"
    assert (
        main(
            [
                "view",
                str(log),
                "--no-viewer",
                "--rrd",
                str(rrd),
                "--repeats",
                "2",
                "--method",
                "OLS1(EM1)",
            ]
        )
        == 0
    )
    err = capsys.readouterr().err
    assert "--method applies to tractor_trailer logs" in err
    assert "manipulator log" in err
    assert "internal error" not in err
    assert rrd.is_file()


def test_analysis_config_carries_each_robots_options_typed() -> None:
    cfg = AnalysisConfig(
        robot_options={
            "manipulator": ManipulatorOptions(urdf="panda", cutoff_hz=5.0),
            "tractor_trailer": TractorTrailerOptions(method_for_psi="PMLS/PM1"),
        }
    )
    assert cfg.options(ManipulatorOptions).cutoff_hz == 5.0
    assert cfg.options(TractorTrailerOptions).discovery_span_s is None
    assert AnalysisConfig().options(ManipulatorOptions) == ManipulatorOptions()
    assert not hasattr(cfg, "extra")  # no untyped mapping beside the typed options
    # settings keys (a logcal.toml) become typed options, each checked
    given = options_from_settings({"urdf": "panda", "discovery_span_s": 100})
    old = AnalysisConfig(repeats=3, robot_options=given)
    assert old.options(ManipulatorOptions) == ManipulatorOptions(urdf="panda")
    assert old.options(TractorTrailerOptions).discovery_span_s == 100.0
    assert dataclasses.replace(old, seed=4).robot_options == old.robot_options
    with pytest.raises(LogcalInputError, match=r"cutoff_hz = 'fast': expected a number > 0"):
        options_from_settings({"cutoff_hz": "fast"})
    with pytest.raises(TypeError):
        AnalysisConfig(robot_options={"manipulator": {"urdf": "panda"}})  # type: ignore[dict-item]
    assert isinstance(RobotOptions(), RobotOptions)


def test_a_bad_option_value_is_one_message_naming_the_flag(
    capsys: pytest.CaptureFixture[str],
) -> None:
    log = Path(__file__).resolve().parents[2] / "sample_logs" / "tt_mixed.csv"
    assert main(["analyze", str(log), "--discovery-span", "-5"]) == 2
    err = capsys.readouterr().err
    assert "--discovery-span -5.0: expected a number >= 0" in err
    assert "Traceback" not in err
