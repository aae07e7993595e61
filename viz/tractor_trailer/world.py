"""World view of the recording: paths of C1, P, C2, the robot's links and the ICR construction.

Time-varying data goes through ``rr.send_columns`` on the log's own timeline. Each time step
costs one row per entity, so the robot (points C1, P, C2 and the two links) is one entity and
the ICR construction (points O, Q; triangles O Q C2, Q C1 P; radius O C1) another, each
carrying a Points2D and a LineStrips2D archetype. The points come computed with the analysis
(``calib.tractor_trailer.views_data``); this module only draws them.

Sizes are in screen points (``rr.Radius.ui_points``) so that the robot, O, Q and the triangles
read at any zoom. ``world/follow`` is a frame placed at C1 at every step (and mirrored like the
world): a view with that origin follows link 1. Labels (C1, P, C2, O with R, Q) are a separate
entity, ``world/labels``, which the overview leaves out (at the path's scale they collide).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import polars as pl
import pyarrow as pa
import rerun as rr
from numpy.typing import NDArray
from rerun.encodings import Vec2DBatch

from viz._frame import column, has, times_ns
from viz.style import COLORS, time_index, ui_points, y_up

__all__ = [
    "FOLLOW",
    "ICR",
    "ICR_STRIPS",
    "LABELS",
    "ROBOT",
    "ROBOT_POINTS",
    "WORLD",
    "log_world",
]

WORLD = "world"
ROBOT = f"{WORLD}/robot"
ICR = f"{WORLD}/icr"
FOLLOW = f"{WORLD}/follow"
LABELS = f"{WORLD}/labels"
_PT = ui_points(5.0)  # robot and ICR points
_LINK = ui_points(2.0)
_THIN = ui_points(1.0)
#: Instances of the robot's points, in order.
ROBOT_POINTS = ("C1", "P", "C2")
#: Instances of the ICR's line strips, in order (its points are O then Q).
ICR_STRIPS = ("triangle_OQC2", "triangle_QC1P", "radius")


def _time(t_ns: NDArray[np.int64]) -> list[rr.TimeColumn]:
    """``t_ns`` are already relative to the log's start (``log_world`` subtracts it)."""
    return time_index(t_ns, 0)


def _strips_arrow(rows: list[NDArray[np.float64]]) -> pa.Array:
    """Arrow array of line strips built in one go (rerun's converter loops in Python).

    ``rows[j]`` has shape (n, m_j, 2): strip j of each of n rows, m_j points; the result holds
    n * len(rows) strips, row by row.
    """
    n = rows[0].shape[0]
    pts = np.concatenate(rows, axis=1).reshape(-1, 2).astype(np.float32)
    lengths = np.tile([r.shape[1] for r in rows], n)
    offsets = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int32)
    return pa.ListArray.from_arrays(
        pa.array(offsets, type=pa.int32()),
        Vec2DBatch(pts).as_arrow_array(),
        type=rr.components.LineStrip2DBatch._ARROW_DATATYPE,
    )


def _send_points_and_strips(
    rec: rr.RecordingStream,
    path: str,
    t_ns: NDArray[np.int64],
    points: NDArray[np.float64],
    strips: list[NDArray[np.float64]],
    ok: NDArray[np.bool_],
    point_labels: list[str] | None = None,
) -> None:
    """Per row the ``points`` (n, p, 2) and one strip per ``strips`` entry (n, m_j, 2); rows
    with ``ok`` False are logged empty (hidden). ``point_labels``: p labels per ok row."""
    p = points.shape[1]
    part = ok.astype(np.int32)
    cols = [
        *rr.Points2D.columns(
            positions=points[ok].reshape(-1, 2).astype(np.float32), labels=point_labels
        ).partition(part * p),
        *rr.LineStrips2D.columns(strips=_strips_arrow([s[ok] for s in strips])).partition(
            part * len(strips)
        ),
    ]
    rec.send_columns(path, indexes=_time(t_ns), columns=cols)


def _log_paths(rec: rr.RecordingStream, points: dict[str, NDArray[np.float64]]) -> None:
    """The full world-frame paths as static line strips (m)."""
    for name, pts in points.items():
        ok = np.isfinite(pts).all(axis=1)
        rec.log(
            f"{WORLD}/paths/{name}",
            rr.LineStrips2D([pts[ok]], colors=[COLORS[name]], radii=[_THIN]),
            static=True,
        )


def _log_c1_only(rec: rr.RecordingStream, t: NDArray[np.int64], c1: NDArray[np.float64]) -> None:
    _log_paths(rec, {"C1": c1})
    ok = np.isfinite(c1).all(axis=1)
    rec.log(
        ROBOT,
        rr.Points2D.from_fields(colors=[COLORS["C1"]], radii=[_PT]),
        static=True,
    )
    rec.send_columns(
        ROBOT,
        indexes=_time(t),
        columns=rr.Points2D.columns(positions=c1[ok]).partition(ok.astype(np.int32)),
    )


def log_world(
    rec: rr.RecordingStream, frame: pl.DataFrame, views: Mapping[str, np.ndarray]
) -> None:
    """Log paths, robot and ICR under ``world/`` (m, world frame, drawn y up).

    Args:
        rec: the recording.
        frame: aligned log with ``t_ns``, ``x``, ``y`` (m).
        views: ``tractor_views_data``'s arrays; without ``P`` (no lengths, yaw, psi or
            curvature) only C1 is drawn.
    """
    if not has(frame, "t_ns", "x", "y"):
        return
    y_up(rec, WORLD)  # rerun's 2D views draw y down: left turns must look left
    t = times_ns(frame)
    t = t - t[0]  # seconds from the log's start on the timeline (viz.style.TIMELINE)
    if "P" not in views:
        _log_c1_only(rec, t, np.stack([column(frame, "x"), column(frame, "y")], axis=-1))
        return
    _log_paths(rec, {n: views[n] for n in ROBOT_POINTS})
    _log_robot(rec, t, views)
    _log_icr(rec, t, views)
    _log_labels(rec, t, views)
    _log_follow(rec, t, views["C1"])


def _log_follow(rec: rr.RecordingStream, t: NDArray[np.int64], c1: NDArray[np.float64]) -> None:
    """``world/follow``: a frame at C1 (mirrored, y up on screen) at every step with a finite
    C1; a 2D view with this origin keeps link 1 in its centre."""
    ok = np.isfinite(c1).all(axis=1)
    if not ok.any():
        return
    n = int(ok.sum())
    trans = np.zeros((n, 3), dtype=np.float32)
    trans[:, :2] = c1[ok]
    mirror = np.tile(np.diag([1.0, -1.0, 1.0]).astype(np.float32), (n, 1, 1))
    rec.send_columns(
        FOLLOW,
        indexes=_time(t[ok]),
        columns=rr.Transform3D.columns(translation=trans, mat3x3=mirror.reshape(n, 9)),
    )


def _log_labels(rec: rr.RecordingStream, t: NDArray[np.int64], c: Mapping[str, np.ndarray]) -> None:
    """Per step the labels C1, P, C2 and, where the ICR is drawn, "O: R = 1/κ = … m" and "Q"
    at their points (invisible points with text; the overview leaves them out)."""
    robot = np.stack([c["C1"], c["P"], c["C2"]], axis=1)
    icr = np.stack([c["O"], c["Q"]], axis=1)
    r_ok = np.isfinite(robot).reshape(len(t), -1).all(axis=1)
    i_ok = r_ok & _icr_ok(c, len(t))
    pts = np.concatenate([robot, icr], axis=1)  # (n, 5, 2)
    keep = np.zeros((len(t), 5), dtype=bool)
    keep[:, :3] = r_ok[:, None]
    keep[:, 3:] = i_ok[:, None]
    names = np.empty((len(t), 5), dtype=object)
    names[:, :3] = ROBOT_POINTS
    with np.errstate(invalid="ignore"):
        names[:, 3] = np.char.mod("O: R = 1/κ = %.2f m", np.nan_to_num(c["R"]))
    names[:, 4] = "Q"
    rec.log(
        LABELS,
        rr.Points2D.from_fields(colors=[(15, 15, 15)], radii=[0.0], show_labels=True),
        static=True,
    )
    cols = rr.Points2D.columns(
        positions=pts[keep].astype(np.float32), labels=names[keep].tolist()
    ).partition(keep.sum(axis=1).astype(np.int32))
    rec.send_columns(LABELS, indexes=_time(t), columns=cols)


def _icr_ok(c: Mapping[str, np.ndarray], n: int) -> NDArray[np.bool_]:
    """Steps where the ICR construction is valid and all its points are finite."""
    pts = np.stack([c["O"], c["Q"], c["C1"], c["P"], c["C2"]], axis=1)
    return np.asarray(c["icr_valid"], dtype=bool) & np.isfinite(pts).reshape(n, -1).all(axis=1)


def _log_robot(rec: rr.RecordingStream, t: NDArray[np.int64], c: Mapping[str, np.ndarray]) -> None:
    """C1, P, C2 as points and C1-P-C2 as one strip at every time step."""
    rec.log(
        ROBOT,
        rr.Points2D.from_fields(colors=[COLORS[n] for n in ROBOT_POINTS], radii=[_PT]),
        rr.LineStrips2D.from_fields(colors=[COLORS["links"]], radii=[_LINK]),
        static=True,
    )
    pts = np.stack([c["C1"], c["P"], c["C2"]], axis=1)
    ok = np.isfinite(pts).reshape(len(t), -1).all(axis=1)
    _send_points_and_strips(rec, ROBOT, t, pts, [pts], ok)


def _log_icr(rec: rr.RecordingStream, t: NDArray[np.int64], c: Mapping[str, np.ndarray]) -> None:
    """O and Q (labelled in ``world/labels``); triangles O Q C2, Q C1 P and the radius O C1.
    Empty where the construction is not valid (|kappa| small)."""
    rec.log(
        ICR,
        rr.Points2D.from_fields(colors=[COLORS["O"], COLORS["Q"]], radii=[_PT]),
        rr.LineStrips2D.from_fields(colors=[COLORS[n] for n in ICR_STRIPS], radii=[_THIN]),
        static=True,
    )
    o, q = c["O"], c["Q"]
    strips = [
        np.stack([o, q, c["C2"], o], axis=1),
        np.stack([q, c["C1"], c["P"], q], axis=1),
        np.stack([o, c["C1"]], axis=1),
    ]
    ok = _icr_ok(c, len(t))
    _send_points_and_strips(rec, ICR, t, np.stack([o, q], axis=1), strips, ok)
