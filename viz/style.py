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
    "CANVASES",
    "COLORS",
    "OKABE_ITO",
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

#: RGB colours (0-255) of the plotted things; a screenshot test finds the ready ones
#: (``READY_COLORS``) by colour, so those are used by nothing else on their canvas.
COLORS: dict[str, tuple[int, int, int]] = {
    "C1": _OI["vermillion"],  # front wheel centre
    "P": _OI["orange"],  # joint
    "C2": _OI["blue"],  # rear wheel centre
    "links": (240, 240, 240),  # neutral: on the viewer's dark background
    "O": _OI["bluish_green"],  # instantaneous centre
    "Q": _OI["reddish_purple"],
    "triangle_OQC2": (
        171,
        218,
        244,
    ),  # sky blue half-mixed with white (kappa's colour is the full one)
    "triangle_QC1P": (248, 242, 161),  # yellow half-mixed with white
    "radius": _OI["bluish_green"],  # from O, in O's colour
    "kappa_cmd": _OI["yellow"],
    "kappa": _OI["sky_blue"],
    "psi": _OI["blue"],
    "psi_estimate": _OI["bluish_green"],
    "psi_method": _OI["reddish_purple"],
    "psi_steady": _OI["vermillion"],  # the steady-state relation
    "residual": (153, 153, 153),  # neutral grey: the baseline's residual
    "truth": (250, 250, 250),  # neutral: on the viewer's dark background
    "L1": _OI["vermillion"],
    "L2": _OI["blue"],
    # the differential drive's paths (viz.diff_drive.views draws them; the screenshot looks for
    # them)
    "dd_nominal": _OI["vermillion"],
    "dd_calibrated": _OI["blue"],
    # the arm's links and joints (viz.manipulator.views)
    "arm_links": _OI["bluish_green"],
    "arm_joints": _OI["orange"],
}

#: Colours drawn together on one canvas (a view or a figure's axes): each group's are pairwise
#: distinct.
CANVASES: dict[str, tuple[str, ...]] = {
    "tractor world": ("C1", "P", "C2", "links", "O", "Q", "triangle_OQC2", "triangle_QC1P"),
    "curvature": ("kappa_cmd", "kappa"),
    "joint angle": ("psi", "psi_estimate", "psi_method", "psi_steady"),
    "residuals": ("residual", "psi_estimate"),
    "lengths": ("L1", "L2"),
    "differential drive paths": ("dd_nominal", "dd_calibrated"),
    "arm": ("arm_links", "arm_joints"),
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
