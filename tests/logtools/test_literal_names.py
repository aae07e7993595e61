"""Text from logs and parameter names are printed literally: rich markup in a name (``[bold]``,
``[/x]``, ``[torso_lift_joint]``, ``Fc[joint1]``) is never interpreted, unicode is kept, and
control characters are shown as visible escapes."""

from __future__ import annotations

import io

import pytest
from rich.console import Console

from calib.results import AnalysisResult, CalibrationResult, Estimate, StageStatus
from logtools.robots import plugins, register
from logtools.robots.base import RobotPlugin
from logtools.safe_text import printable

NAMES = (
    "[bold]",
    "[/x]",
    "[torso_lift_joint]",
    "Fc[joint1]",
    "[red]Fv[joint2][/red]",
    "Länge_µ[°]",
    "关节[3]",
    "evil\x1b[2Jname",
)


def _estimate(names: tuple[str, ...]) -> CalibrationResult:
    params = {
        n: Estimate(n, 0.1 * (i + 1), 0.01, (0.08, 0.12 + i), unit="N·m")
        for i, n in enumerate(names)
    }
    return CalibrationResult(
        method="LSQ [ridge]", parameters=params, verdict="determined for [torso_lift_joint]"
    )


def _result(robot: str, path: str = "runs/[bold]run.mcap") -> AnalysisResult:
    return AnalysisResult(
        robot=robot,
        segments=[],
        methods=[],
        estimate=_estimate(NAMES),
        source={"path": path, "signals": {"q1": "/joint_states:position.0 [rad]"}},
        warnings=[f"{n} has a note" for n in NAMES],
        stages=[StageStatus("discovery", "skipped", "needs [/x] and Fc[joint1]")],
    )


def _render(result: AnalysisResult) -> str:
    from logtools.report import render_analysis

    console = Console(record=True, width=250, file=io.StringIO(), color_system=None)
    console.print(render_analysis(result))
    return console.export_text()


@pytest.fixture(scope="module")
def plain_plugin() -> str:
    """A robot whose own report part is empty: the frame of the report alone."""
    name = "literal_names_test"
    if not any(p.name == name for p in plugins()):
        register(
            RobotPlugin(
                name=name,
                title="test robot",
                signals=(),
                identify=lambda _: None,
                analyze=lambda *a: None,  # type: ignore[arg-type,return-value]
                report=lambda _: [],
            )
        )
    return name


def test_report_frame_prints_every_name_literally(plain_plugin):
    text = _render(_result(plain_plugin))
    for name in NAMES:
        shown = printable(name)
        assert f"{shown} = " in text, name  # the estimate panel
        assert f"{shown} has a note" in text, name  # the notes
    assert "\x1b" not in text
    assert "evil\\x1b[2Jname" in text
    assert "runs/[bold]run.mcap" in text  # the header (a path from the log)
    assert "needs [/x] and Fc[joint1]" in text  # a stage's reason
    assert "LSQ [ridge]" in text
    assert "determined for [torso_lift_joint]" in text
    assert "/joint_states:position.0 [rad]" in text


def test_pooled_report_prints_run_paths_and_parameter_names_literally(plain_plugin):
    runs = [_result(plain_plugin, f"runs/[bold]run{i}.mcap") for i in (1, 2)]
    pooled = AnalysisResult(
        robot=plain_plugin,
        segments=[],
        methods=[],
        estimate=_estimate(NAMES),
        runs=runs,
        source={"runs_pooled": 2},
    )
    text = _render(pooled)
    for i in (1, 2):  # runs by their shortest unique names, printed literally
        assert f"[bold]run{i}.mcap" in text
    for name in NAMES:
        assert printable(name) in text, name


@pytest.mark.parametrize("robot", ["tractor_trailer", "diff_drive", "manipulator"])
def test_robot_report_parts_keep_names(robot):
    """The robots' own report parts (logtools/robots/*/report.py) on a result of that robot
    carrying hostile names; a part that cannot draw this minimal result is skipped."""
    result = _result(robot)
    try:
        text = _render(result)
    except (KeyError, AttributeError, TypeError, ValueError, IndexError) as err:
        pytest.skip(f"{robot}'s report needs more than a minimal result ({err!r})")
    for name in NAMES:
        assert printable(name) in text, (robot, name)
