"""Colours and names shared by the rerun recording, the PNG report and the screenshot test."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import rerun as rr
from numpy.typing import NDArray

if TYPE_CHECKING:
    from calib.results import AnalysisResult

__all__ = [
    "COLORS",
    "TIMELINE",
    "application_id",
    "hex_color",
    "robot_of_application_id",
    "start_words",
    "time_index",
    "ui_points",
]

#: Name of the rerun timeline of every robot: seconds from the log's start (a duration), as in
#: the text report and the PNG; the absolute start is stated once, in the recording's summary.
TIMELINE = "time"


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


#: RGB colours (0-255) of the plotted things; saturated so a screenshot test can find them.
COLORS: dict[str, tuple[int, int, int]] = {
    "C1": (230, 25, 75),  # red: front wheel centre
    "P": (255, 165, 0),  # orange: joint
    "C2": (0, 130, 200),  # blue: rear wheel centre
    "links": (240, 240, 240),
    "O": (60, 180, 75),  # green: instantaneous centre
    "Q": (145, 30, 180),  # purple
    "triangle_OQC2": (70, 240, 240),
    "triangle_QC1P": (240, 50, 230),
    "radius": (60, 180, 75),
    "kappa_cmd": (255, 225, 25),  # yellow
    "kappa": (255, 110, 40),  # orange-red
    "psi": (40, 80, 255),  # blue-violet
    "psi_estimate": (0, 210, 140),
    "psi_method": (200, 120, 255),
    "psi_steady": (255, 120, 190),  # pink: the steady-state relation
    "residual": (220, 190, 255),
    "truth": (250, 250, 250),
    "L1": (230, 25, 75),
    "L2": (0, 130, 200),
    # the differential drive's paths (viz.diff_drive.views draws them; the screenshot looks for
    # them)
    "dd_nominal": (220, 60, 60),
    "dd_calibrated": (40, 120, 220),
    # the arm's links and joints (viz.manipulator.views)
    "arm_links": (0, 158, 115),
    "arm_joints": (213, 94, 0),
}

#: Per robot, the colours of ``COLORS`` that only show once its viewer has drawn the data (the
#: screenshot waits for them): the tractor's C1 and C2 paths and measured kappa, the
#: differential drive's dead-reckoned paths, the arm's links and joints.
READY_COLORS: dict[str, tuple[str, ...]] = {
    "tractor_trailer": ("C1", "C2", "kappa"),
    "diff_drive": ("dd_nominal", "dd_calibrated"),
    "manipulator": ("arm_links", "arm_joints"),
}


def hex_color(name: str) -> str:
    """The colour ``name`` as ``#rrggbb`` (for matplotlib)."""
    r, g, b = COLORS[name]
    return f"#{r:02x}{g:02x}{b:02x}"


def ui_points(points: float) -> float:
    """A radius in screen points: rerun reads a negative radius as UI points (the value
    ``rr.Radius.ui_points`` returns; spelled here as a float for the type checker)."""
    return -abs(points)


def robot_of_application_id(app_id: str) -> str | None:
    """The robot a recording's application id names (:func:`application_id`), None when it
    names none of :data:`READY_COLORS`'s robots."""
    for robot in sorted(READY_COLORS, key=len, reverse=True):
        if app_id == f"logcal_{robot}" or app_id.startswith(f"logcal_{robot}_"):
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
