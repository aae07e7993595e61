"""The report images' facts, read from the matplotlib objects (not from pixels): what each axes
shows, its ticks and its texts."""

from __future__ import annotations

import numpy as np
import pytest

from calib.results import AnalysisResult, CalibrationResult, Estimate
from viz.diff_drive.views import report_figure
from viz.style import hex_color


def _texts(fig) -> list[str]:
    return [t.get_text() for t in fig.findobj(lambda a: hasattr(a, "get_text"))]


def _dd_result() -> AnalysisResult:
    t = np.linspace(0.0, 2 * np.pi, 40)
    path = {"x": np.cos(t), "y": np.sin(t)}
    params = {
        "track_width": Estimate("track_width", 0.2015, 4e-4, (0.2007, 0.2023)),
        "wheel_radius_left": Estimate(
            "wheel_radius_left", 0.04183, 2e-3, (0.0379, 0.0458), identifiable=False
        ),
    }
    return AnalysisResult(
        robot="diff_drive",
        segments=[],
        methods=[CalibrationResult("LSQ", params, "ok")],
        estimate=None,
        sections={"nominal": {"track_width": 0.2, "wheel_radius_left": 0.042}},
        artifacts={"trajectories": {"/l/run-01.csv": {"truth": path, "calibrated": path}}},
    )


def test_diff_drive_figure_fills_its_rows_and_says_not_determined() -> None:
    fig = report_figure(_dd_result())
    axes = fig.get_axes()
    assert len(axes) == 3  # one run's path across the top, one panel per parameter below
    path_ax, *param_axes = axes
    assert path_ax.get_position().width > 0.7  # the top row is not left half empty (was 1/3)
    texts = _texts(fig)
    assert "41.830 (not determined)" in texts  # as the table writes it
    assert not any("201.500 (not determined)" in t for t in texts)
    for ax in axes:
        assert len(ax.get_xticks()) >= 2
        assert len(ax.get_yticks()) >= 1
        assert ax.get_xlabel()
    # the determined value is drawn with its interval, in the palette's blue
    colours = {line.get_color() for line in param_axes[0].get_lines()}
    assert hex_color("dd_calibrated") in colours
    assert {ln.get_label() for ln in path_ax.get_lines()} == {"truth", "calibrated"}


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    import matplotlib.pyplot as plt

    plt.close("all")


def test_arm_figure_shows_the_recommended_parameters_as_the_report() -> None:
    from viz.manipulator.views import report_figure as arm_figure

    a1 = Estimate("a1", 0.3399, 5.2e-4, (0.3389, 0.341), unit="kg*m^2", identifiable=False)
    fc = Estimate("Fc[joint1]", 0.1, 0.0097, (0.081, 0.119), unit="N*m")
    est = CalibrationResult("momentum-WLS", {"a1": a1, "Fc[joint1]": fc}, "ok")
    result = AnalysisResult(
        robot="manipulator",
        segments=[],
        methods=[est],
        estimate=est,
        artifacts={
            "joint_names": ["joint1"],
            "holdout_t_s": np.array([1.0, 2.0, 3.0]),
            "holdout_measured": np.zeros((3, 1)),
            "holdout_predicted": np.ones((3, 1)),
        },
    )
    fig = arm_figure(result)
    text = "\n".join(_texts(fig))
    assert a1.report() in text  # "(not determined by this log)" with it
    assert "not determined" in a1.report()
    assert fc.report() in text
    torque = fig.get_axes()[0]
    assert torque.get_xlabel().startswith("time (s from the log's start)")
    assert len(torque.get_xticks()) >= 2


def test_set_apart_method_rows_take_less_room_than_read_ones() -> None:
    """24 grey rows not to be read took half the tractor's figure: they are packed closer."""
    from viz.tractor_trailer.plots import row_positions

    ys = row_positions([False, False, True, True])
    np.testing.assert_allclose(ys, [0.0, 1.0, 1.725, 2.175])
    many = row_positions([False] * 6 + [True] * 24)
    read, apart = many[5] - many[0], many[-1] - many[6]
    assert apart < 2.1 * read  # 24 set-apart rows in about the room of 11 read ones


@pytest.mark.parametrize("robot", ["diff_drive", "manipulator"])
def test_a_robots_views_need_no_other_robots_colours(robot: str) -> None:
    """Each robot's views draw with its own colours and the shared ones only (the arm's PNG
    used the tractor's "P" and failed when the tractor's views were not imported)."""
    import subprocess
    import sys

    code = (
        f"import viz.{robot}.views as v, viz.style as s, viz.{robot}.style as own\n"
        "import sys\n"
        "assert not any(m.startswith('viz.tractor_trailer') for m in sys.modules), 'tractor'\n"
        "src = open(v.__file__).read()\n"
        "import re\n"
        "used = set(re.findall(r'(?:hex_color\\(|COLORS\\[)\"([a-zA-Z0-9_]+)\"', src))\n"
        "missing = used - set(s.COLORS)\n"
        "assert not missing, missing\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
