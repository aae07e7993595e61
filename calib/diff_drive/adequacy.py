"""Does the calibrated differential-drive model explain the log? Residual channels for the
shared adequacy check (:mod:`calib.adequacy`), stuck or dropped encoder readings, and the
parameters fitted piece by piece for a change mid-log.

Channels (per window of ``WINDOW_S`` seconds, each starting from the ground-truth pose so that
errors do not carry over): the heading increment (true yaw change minus the wheels' prediction,
rad) and the along-track displacement (m, the world displacement minus the dead-reckoned arc,
projected on the true mean heading). The held-out residual uses parameters fitted on the other
half of the log (alternating blocks of ``FOLD_S`` seconds). Covariates: speed, |turn rate|,
wheel speed difference; located segments are the runs.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from calib.adequacy import (
    Adequacy,
    ParameterChange,
    PieceFit,
    ResidualChannel,
    assess,
    parameter_change,
)
from calib.diff_drive.data import DriveRun
from calib.diff_drive.kinematics import DiffDriveParams
from calib.diff_drive.odometry_lsq import segment_design, solve_rows
from calib.errors import InsufficientDataError

__all__ = [
    "FOLD_S",
    "WINDOW_S",
    "StuckSpan",
    "assess_fit",
    "exclude_spans",
    "find_stuck_spans",
    "piece_fits",
    "radius_change",
    "residual_channels",
]

Array = NDArray[np.float64]

WINDOW_S = 0.5
"""Window (s) of the residual channels: several samples of a 20-50 Hz log, short enough that
a stuck encoder or a slip event is located to about a second."""
FOLD_S = 20.0
"""Length (s) of the alternating blocks of the two-fold held-out check."""
STUCK_MIN_S = 0.3
"""Shortest run of zero increments on one wheel (s) examined as a stuck reading."""
STUCK_MIN_RAD = 0.02
"""Smallest heading disagreement (rad) over a span that names a stuck reading, whatever the
noise floor (a tick missed now and then is not a stuck encoder)."""
PIECE_S = 20.0
"""Length (s) of the pieces fitted separately to look for a parameter change."""


@dataclass(frozen=True)
class StuckSpan:
    """Samples ``i0``..``i1`` (increments i0..i1-1) of run ``run`` where ``wheel``'s reading
    did not move while the other wheel and the ground truth did; ``t0_s``/``t1_s`` on the
    log's time axis (runs laid end to end), ``heading_rad`` the ground-truth heading change the
    wheels miss there."""

    run: int
    wheel: str
    i0: int
    i1: int
    t0_s: float
    t1_s: float
    heading_rad: float

    @property
    def label(self) -> str:
        return f"{self.wheel} t {self.t0_s:.1f}-{self.t1_s:.1f} s"


def _run_offsets(runs: Sequence[DriveRun]) -> list[float]:
    """Start of each run on one time axis (runs laid end to end, 1 s apart)."""
    out, t = [], 0.0
    for r in runs:
        out.append(t - (float(r.t[0]) if r.n else 0.0))
        t += (r.duration if r.n else 0.0) + 1.0
    return out


def _windows(run: DriveRun, window_s: float) -> list[tuple[int, int]]:
    if run.n < 2:
        return []
    edges = np.arange(run.t[0], run.t[-1] + 1e-9, window_s)
    idx = np.unique(np.searchsorted(run.t, edges))
    if idx[-1] != run.n - 1:
        idx = np.append(idx, run.n - 1)
    return [(int(a), int(b)) for a, b in itertools.pairwise(idx) if b > a]


def _run_prediction(
    run: DriveRun, p: DiffDriveParams
) -> tuple[Array, NDArray[np.complex128]]:
    """Model heading (from 0) and cumulative unit-less arc displacement per sample, in the
    model's own heading frame."""
    dr, dl = np.diff(run.wheel_right), np.diff(run.wheel_left)
    dth = (p.r_R * dr - p.r_L * dl) / p.b
    h = np.concatenate([[0.0], np.cumsum(dth)])
    mid = h[:-1] + 0.5 * dth
    step = 0.5 * (p.r_R * dr + p.r_L * dl) * np.sinc(dth / (2 * np.pi)) * np.exp(1j * mid)
    return h, np.concatenate([[0.0], np.cumsum(step)])


@dataclass(frozen=True)
class _Windows:
    t: Array
    heading: Array
    along: Array
    fold: NDArray[np.intp]
    speed: Array
    turn: Array
    wheel_diff: Array
    measured_yaw: Array
    segments: tuple[tuple[str, float, float], ...]


def _window_residuals(
    runs: Sequence[DriveRun],
    params: Sequence[DiffDriveParams],
    offset: complex,
    window_s: float,
    excluded: Sequence[NDArray[np.bool_]] | None,
) -> _Windows:
    """Residuals per window; ``params[f]`` predicts the windows of fold f (one entry: all)."""
    offs = _run_offsets(runs)
    cols: dict[str, list[float]] = {k: [] for k in (
        "t", "heading", "along", "fold", "speed", "turn", "wheel_diff", "yaw")}
    segs = []
    for k, run in enumerate(runs):
        preds = [_run_prediction(run, p) for p in params]
        for a, b in _windows(run, window_s):
            tm = 0.5 * (run.t[a] + run.t[b]) + offs[k]
            fold = int((tm // FOLD_S) % 2) if len(params) > 1 else 0
            p = params[fold]
            h, cum = preds[fold]
            dt = run.t[b] - run.t[a]
            bad = excluded is not None and bool(excluded[k][a:b].any())
            dyaw = run.yaw[b] - run.yaw[a]
            disp = complex(run.x[b] - run.x[a], run.y[b] - run.y[a])
            pred = np.exp(1j * (run.yaw[a] - h[a])) * (cum[b] - cum[a]) + offset * (
                np.exp(1j * run.yaw[b]) - np.exp(1j * run.yaw[a]))
            u = np.exp(1j * 0.5 * (run.yaw[a] + run.yaw[b]))
            wr = (run.wheel_right[b] - run.wheel_right[a]) * p.r_R
            wl = (run.wheel_left[b] - run.wheel_left[a]) * p.r_L
            cols["t"].append(tm)
            cols["heading"].append(math.nan if bad else dyaw - (h[b] - h[a]))
            cols["along"].append(math.nan if bad else float(((disp - pred) * np.conj(u)).real))
            cols["fold"].append(fold)
            cols["speed"].append(abs(disp) / dt if dt > 0 else math.nan)
            cols["turn"].append(abs(dyaw) / dt if dt > 0 else math.nan)
            cols["wheel_diff"].append((wr - wl) / dt if dt > 0 else math.nan)
            cols["yaw"].append(float(run.yaw[b]))
        if run.n:
            segs.append((run.name, float(run.t[0] + offs[k]), float(run.t[-1] + offs[k])))
    arr = {k: np.asarray(v, dtype=float) for k, v in cols.items()}
    return _Windows(arr["t"], arr["heading"], arr["along"], arr["fold"].astype(np.intp),
                    arr["speed"], arr["turn"], arr["wheel_diff"], arr["yaw"],
                    tuple(segs) if len(segs) > 1 else ())


def _fold_params(runs: Sequence[DriveRun], segment_s: float
                 ) -> tuple[DiffDriveParams, DiffDriveParams] | None:
    """Parameters fitted on each fold's segments (alternating ``FOLD_S`` blocks): entry f is
    fitted on the *other* fold, so that it predicts fold f held out."""
    try:
        d = segment_design(runs, segment_s)
    except InsufficientDataError:
        return None
    offs = _run_offsets(runs)
    t_mid = np.array([0.5 * (runs[s.run].t[s.start] + runs[s.run].t[s.stop]) + offs[s.run]
                      for s in d.segments])
    fold = ((t_mid // FOLD_S) % 2).astype(int)
    out = []
    for f in (0, 1):
        train = np.flatnonzero(fold != f).astype(np.intp)
        if train.size < 6:
            return None
        try:
            out.append(solve_rows(d, train))
        except (InsufficientDataError, np.linalg.LinAlgError):
            return None
    return out[0], out[1]


def residual_channels(
    runs: Sequence[DriveRun],
    params: DiffDriveParams,
    *,
    offset: complex | None = None,
    segment_s: float = 4.0,
    excluded: Sequence[NDArray[np.bool_]] | None = None,
    heldout: bool = True,
) -> list[ResidualChannel]:
    """The heading-increment and along-track channels of ``params`` on ``runs`` (see the
    module docstring); samples flagged in ``excluded`` (per run) are left out."""
    off = offset or 0j
    w = _window_residuals(runs, [params], off, WINDOW_S, excluded)
    held_h = held_a = None
    if heldout:
        fp = _fold_params(_split_excluded(runs, excluded), segment_s)
        if fp is not None:
            wh = _window_residuals(runs, list(fp), off, WINDOW_S, excluded)
            held_h, held_a = wh.heading, wh.along
    cov = {"speed (m/s)": w.speed, "|turn rate| (rad/s)": w.turn,
           "wheel speed difference (m/s)": w.wheel_diff}
    return [
        ResidualChannel("heading increment", "rad", w.t, w.heading, held_h,
                        timescale_s=WINDOW_S, covariates=cov, segments=w.segments),
        ResidualChannel("along-track displacement", "m", w.t, w.along, held_a,
                        timescale_s=WINDOW_S, covariates=cov, segments=w.segments),
    ]


def assess_fit(
    runs: Sequence[DriveRun],
    params: DiffDriveParams,
    *,
    model: str,
    offset: complex | None = None,
    excluded: Sequence[NDArray[np.bool_]] | None = None,
    before: Adequacy | None = None,
    changes: Sequence[ParameterChange] = (),
    notes: Sequence[str] = (),
) -> Adequacy:
    """:func:`calib.adequacy.assess` of ``params`` on ``runs``."""
    chans = residual_channels(runs, params, offset=offset, excluded=excluded)
    return assess(chans, model=model, before=before, changes=changes, notes=notes)


def find_stuck_spans(
    runs: Sequence[DriveRun], params: DiffDriveParams, heading_floor: float = 0.0
) -> list[StuckSpan]:
    """Spans where one wheel's increments are zero for at least ``STUCK_MIN_S`` while the
    other wheel turns, and the ground-truth heading change there disagrees with the wheels'
    prediction by more than max(``STUCK_MIN_RAD``, 5 x the window noise floor x sqrt(windows))
    (a wheel truly at rest, as in a pivot turn, agrees with the prediction)."""
    offs = _run_offsets(runs)
    out: list[StuckSpan] = []
    for k, run in enumerate(runs):
        if run.n < 4:
            continue
        dt = float(np.median(np.diff(run.t)))
        need = max(3, math.ceil(STUCK_MIN_S / dt)) if dt > 0 else 3
        incs = {"wheel_right": np.diff(run.wheel_right), "wheel_left": np.diff(run.wheel_left)}
        for wheel, other in (("wheel_right", "wheel_left"), ("wheel_left", "wheel_right")):
            zero = incs[wheel] == 0
            moving = incs[other] != 0
            flag = zero & moving
            i = 0
            n = flag.size
            while i < n:
                if not flag[i]:
                    i += 1
                    continue
                j = i
                while j < n and zero[j]:
                    j += 1
                if int(flag[i:j].sum()) >= need:
                    pred = (params.r_R * (run.wheel_right[j] - run.wheel_right[i])
                            - params.r_L * (run.wheel_left[j] - run.wheel_left[i])) / params.b
                    miss = float(run.yaw[j] - run.yaw[i] - pred)
                    n_win = max(1.0, (run.t[j] - run.t[i]) / WINDOW_S)
                    if abs(miss) > max(STUCK_MIN_RAD, 5 * heading_floor * math.sqrt(n_win)):
                        out.append(StuckSpan(k, wheel, i, j, float(run.t[i] + offs[k]),
                                             float(run.t[j] + offs[k]), miss))
                i = j
    return sorted(out, key=lambda s: s.t0_s)


def exclusion_masks(runs: Sequence[DriveRun], spans: Sequence[StuckSpan]
                    ) -> list[NDArray[np.bool_]]:
    """Per run, the increments (index i: sample i to i+1) inside ``spans``."""
    masks = [np.zeros(max(r.n, 1), dtype=bool) for r in runs]
    for s in spans:
        masks[s.run][s.i0:s.i1] = True
    return masks


def _split_excluded(runs: Sequence[DriveRun], excluded: Sequence[NDArray[np.bool_]] | None
                    ) -> list[DriveRun]:
    if excluded is None:
        return list(runs)
    out = []
    for run, m in zip(runs, excluded, strict=True):
        if not m.any():
            out.append(run)
            continue
        # sample-level pieces between excluded increments: a piece ends at the first sample of
        # an excluded increment and restarts at its last
        bad = np.flatnonzero(m[: max(run.n - 1, 0)])
        cuts = [0]
        for i in bad:
            cuts += [int(i), int(i) + 1]
        cuts.append(run.n - 1)
        for a, b in zip(cuts[::2], cuts[1::2], strict=False):
            if b - a >= 2:
                out.append(_sub(run, a, b))
    return out


def _sub(run: DriveRun, a: int, b: int) -> DriveRun:
    sl = slice(a, b + 1)
    return DriveRun(run.t[sl], run.wheel_right[sl], run.wheel_left[sl], run.x[sl], run.y[sl],
                    run.yaw[sl], name=run.name)


def exclude_spans(runs: Sequence[DriveRun], spans: Sequence[StuckSpan]) -> list[DriveRun]:
    """``runs`` with the samples of ``spans`` cut out (each run split around them)."""
    return _split_excluded(runs, exclusion_masks(runs, spans))


def split_at(runs: Sequence[DriveRun], t_s: float) -> tuple[list[DriveRun], list[DriveRun]]:
    """``runs`` before and after ``t_s`` on the log's time axis."""
    offs = _run_offsets(runs)
    before, after = [], []
    for k, run in enumerate(runs):
        tt = run.t + offs[k]
        i = int(np.searchsorted(tt, t_s))
        if i >= 2:
            before.append(_sub(run, 0, min(i, run.n) - 1))
        if run.n - i >= 2:
            after.append(_sub(run, max(i, 0), run.n - 1))
    return before, after


def piece_fits(runs: Sequence[DriveRun], track: float, piece_s: float = PIECE_S,
               segment_s: float = 2.0) -> list[PieceFit]:
    """Wheel radii per piece of ``piece_s`` seconds with the track held at ``track``: the yaw
    change per ``segment_s`` segment regressed on the wheel turns (OLS standard errors)."""
    offs = _run_offsets(runs)
    out = []
    for k, run in enumerate(runs):
        if run.n < 4:
            continue
        for t0 in np.arange(run.t[0], run.t[-1] - 0.5 * piece_s, piece_s):
            t1 = min(t0 + piece_s, float(run.t[-1]))
            if run.t[-1] - t1 < 0.5 * piece_s:
                t1 = float(run.t[-1])
            a, b = np.searchsorted(run.t, [t0, t1])
            b = min(int(b), run.n - 1)
            if b - a < 8:
                continue
            sub = _sub(run, int(a), b)
            edges = np.unique(np.searchsorted(sub.t, np.arange(sub.t[0], sub.t[-1], segment_s)))
            edges = np.append(edges, sub.n - 1) if edges[-1] != sub.n - 1 else edges
            ia, ib = edges[:-1], edges[1:]
            X = np.column_stack([sub.wheel_right[ib] - sub.wheel_right[ia],
                                 -(sub.wheel_left[ib] - sub.wheel_left[ia])])
            y = sub.yaw[ib] - sub.yaw[ia]
            if X.shape[0] < 4 or np.linalg.matrix_rank(X) < 2:
                continue
            coef, *_ = np.linalg.lstsq(X, y, rcond=None)
            res = y - X @ coef
            s2 = float(res @ res) / max(1, X.shape[0] - 2)
            cov = s2 * np.linalg.inv(X.T @ X)
            sd = np.sqrt(np.maximum(np.diag(cov), 0.0)) * track
            if np.linalg.cond(X / np.linalg.norm(X, axis=0)) > 1e3:
                continue
            out.append(PieceFit(float(t0 + offs[k]), float(t1 + offs[k]),
                                {"wheel_radius_right": float(coef[0] * track),
                                 "wheel_radius_left": float(coef[1] * track)},
                                {"wheel_radius_right": float(sd[0]),
                                 "wheel_radius_left": float(sd[1])}))
            if t1 >= run.t[-1]:
                break
    return out


def radius_change(runs: Sequence[DriveRun], track: float) -> ParameterChange | None:
    """A change of the wheel radii mid-log (:func:`calib.adequacy.parameter_change` over
    :func:`piece_fits`), or None."""
    pieces = piece_fits(runs, track)
    return parameter_change(pieces, ("wheel_radius_right", "wheel_radius_left"))
