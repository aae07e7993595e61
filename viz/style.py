"""Colours and names shared by the rerun recording, the PNG report and the screenshot test.

The shared palette holds only what every robot's views draw (a residual, the truth) and the
Okabe-Ito palette every robot's colours are taken from; each robot declares the colours of its
own things in its own room (``viz/<robot>/style.py``: its ``COLORS`` added with
:func:`register_colors`, the ``READY_COLORS`` its screenshot waits for and the ``CANVASES``
drawn together), so this module names no robot's signal. One timeline for every robot:
seconds from the log's start (:data:`TIMELINE`, :func:`time_index`).
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import rerun as rr
from numpy.typing import NDArray

if TYPE_CHECKING:
    from calib.results import AnalysisResult

__all__ = [
    "COLORS",
    "MIN_LINE_CONTRAST",
    "OKABE_ITO",
    "THEME_BACKGROUNDS",
    "TIMELINE",
    "application_id",
    "contrast_ratio",
    "hex_color",
    "register_colors",
    "robot_of_application_id",
    "robot_style",
    "start_words",
    "time_index",
    "ui_points",
    "y_up",
    "y_up_bounds",
]

#: Name of the rerun timeline of every robot: seconds from the log's start (a duration), as in
#: the text report and the PNG; the absolute start is stated once, in the recording's summary.
TIMELINE = "time"

RGB = tuple[int, int, int]

#: The Okabe-Ito palette (Okabe & Ito 2008, "Color Universal Design"): eight colours told
#: apart with every common colour-vision deficiency. Every plotted colour below is one of them,
#: a tint of one (drawn apart on the same canvas), or a neutral grey.
OKABE_ITO: dict[str, tuple[int, int, int]] = {
    "black": (0, 0, 0),
    "orange": (230, 159, 0),
    "sky_blue": (86, 180, 233),
    "bluish_green": (0, 158, 115),
    "yellow": (240, 228, 66),
    "blue": (0, 114, 178),
    "vermillion": (213, 94, 0),
    "reddish_purple": (204, 121, 167),
}
_OI = OKABE_ITO

#: RGB colours (0-255) of the plotted things by name: the shared ones here (neutral greys), each
#: robot's (from :data:`OKABE_ITO`) added by :func:`register_colors`.
COLORS: dict[str, RGB] = {
    "residual": (153, 153, 153),  # neutral grey: the baseline's residual
    # neutral mid grey: read on the viewer's light theme and on its dark one (contrast 4.2 to
    # 4.5, :func:`contrast_ratio` against :data:`THEME_BACKGROUNDS`); white was invisible on
    # the light theme (the one a browser gets by default)
    "truth": (119, 119, 119),
}

#: The background of rerun's 2-D and plot views in its two themes (RGB, 0-255).
THEME_BACKGROUNDS: dict[str, RGB] = {"light": (255, 255, 255), "dark": (18, 18, 18)}

#: The lowest contrast (WCAG 2 ratio) a line drawn on either theme's background is given.
MIN_LINE_CONTRAST = 3.0


def register_colors(colors: Mapping[str, RGB]) -> None:
    """Add a robot's colours to :data:`COLORS` (called once by its style module on import).

    Raises:
        ValueError: a name already has another colour (two robots naming one thing differently).
    """
    clash = sorted(n for n, rgb in colors.items() if COLORS.get(n, rgb) != rgb)
    if clash:
        raise ValueError(f"colours {', '.join(clash)} are registered with other values")
    COLORS.update(colors)


def _relative_luminance(rgb: RGB) -> float:
    """WCAG 2 relative luminance of an sRGB colour (0-255 channels)."""
    lin = [
        c / 255 / 12.92 if c / 255 <= 0.03928 else ((c / 255 + 0.055) / 1.055) ** 2.4 for c in rgb
    ]
    return 0.2126 * lin[0] + 0.7152 * lin[1] + 0.0722 * lin[2]


def contrast_ratio(a: RGB, b: RGB) -> float:
    """WCAG 2 contrast ratio of two colours: 1 (the same) to 21 (black on white)."""
    la, lb = sorted((_relative_luminance(a), _relative_luminance(b)), reverse=True)
    return (la + 0.05) / (lb + 0.05)


def y_up(rec: rr.RecordingStream, path: str) -> None:
    """Draw everything below ``path`` with y up: rerun's 2-D views use the image convention (y
    down; not configurable in rerun-sdk 0.2x, its ``image_view_coordinates``), so a plane's
    path would read mirrored (a left turn turning right). A static mirror transform at
    ``path`` flips it once; text labels stay upright and name the plane's own coordinates."""
    rec.log(path, rr.Transform3D(scale=[1.0, -1.0, 1.0]), static=True)


def y_up_bounds(
    x_range: tuple[float, float], y_range: tuple[float, float]
) -> tuple[tuple[float, float], tuple[float, float]]:
    """The visual bounds (x range, y range) of a 2-D view showing the plane's ``x_range`` and
    ``y_range`` under :func:`y_up`: the view's y is minus the plane's."""
    return (x_range[0], x_range[1]), (-y_range[1], -y_range[0])


def start_words(start_ns: int) -> str:
    """The log's absolute start, once, for people: ``started 2024-05-01 15:07:12.250 UTC``
    (a clock that starts near 0, as a simulation's: ``its clock starts at 3.000 s``)."""
    if start_ns < 10**9 * 86400 * 365:  # before 1971: not a wall clock
        return f"its clock starts at {start_ns / 1e9:.3f} s"
    stamp = np.datetime64(int(start_ns), "ns").astype("datetime64[ms]")
    return "started " + str(stamp).replace("T", " ") + " UTC"


def time_index(t_ns: NDArray[np.int64], origin_ns: int) -> list[rr.TimeColumn]:
    """The rerun time index of the stamps ``t_ns`` (absolute ns): seconds from ``origin_ns``
    (the log's start) on :data:`TIMELINE`."""
    rel = np.asarray(t_ns, dtype=np.int64) - np.int64(origin_ns)
    return [rr.TimeColumn(TIMELINE, duration=rel.astype("timedelta64[ns]"))]


def hex_color(name: str) -> str:
    """The colour ``name`` as ``#rrggbb`` (for matplotlib)."""
    r, g, b = COLORS[name]
    return f"#{r:02x}{g:02x}{b:02x}"


def ui_points(points: float) -> float:
    """A radius in screen points: rerun reads a negative radius as UI points (the value
    ``rr.Radius.ui_points`` returns; spelled here as a float for the type checker)."""
    return -abs(points)


def robot_style(robot: str) -> object | None:
    """The style module of ``robot`` (``viz.<robot>.style``, imported), None when it has none."""
    if not robot.isidentifier():
        return None
    try:
        return importlib.import_module(f"viz.{robot}.style")
    except ModuleNotFoundError:
        return None


def robot_of_application_id(app_id: str) -> str | None:
    """The robot a recording's application id names (:func:`application_id`): the longest
    ``logcal_<robot>`` prefix whose robot has a style module; None when none has."""
    if not app_id.startswith("logcal_"):
        return None
    words = app_id[len("logcal_") :].split("_")
    for n in range(len(words), 0, -1):
        robot = "_".join(words[:n])
        if robot_style(robot) is not None:
            return robot
    return None


def application_id(result: AnalysisResult) -> str:
    """The rerun application id of ``result``'s recording: ``logcal_<robot>_<log file stem>`` for
    one run, ``logcal_<robot>_pooled_<n>_runs`` for a pooled answer (letters, digits, ``_`` and
    ``-`` only: rerun renames any other id with a warning).

    rerun keeps one blueprint per application id: the runs of a pooled ``.rrd`` must each have
    their own id, or every run is shown through the last run's layout (its title, its path
    panel's entity, so "No data" for any other run).
    """
    if result.runs:
        name = f"logcal_{result.robot}_pooled_{len(result.runs)}_runs"
    else:
        path = str(result.source.get("path", "") or "")
        name = f"logcal_{result.robot}_{Path(path).stem}" if path else f"logcal_{result.robot}"
    return "".join(c if c.isascii() and (c.isalnum() or c in "_-") else "_" for c in name)
