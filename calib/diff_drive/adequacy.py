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
from collections.abc import Mapping, Sequence
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
from calib.stats import long_run_variance_ratio

__all__ = [
    "FOLD_S",
    "WINDOW_S",
    "StuckSpan",
    "assess_fit",
    "exclude_spans",
    "find_stuck_spans",
    "piece_fits",
    "piece_length",
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
"""Longest piece (s) fitted separately to look for a parameter change."""
PIECE_MIN_S = 3.0
"""Shortest piece (s): a few segments that turn and drive straight."""
PIECE_NAMES = ("mean_wheel_radius", "wheel_radius_difference")
"""What each piece estimates: (r_R + r_L) / 2 and r_R - r_L (m)."""
PIECES_WANTED = 10
"""Pieces a log is cut into when that keeps them between ``PIECE_MIN_S`` and ``PIECE_S``."""


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


def _run_prediction(run: DriveRun, p: DiffDriveParams) -> tuple[Array, NDArray[np.complex128]]:
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
    cols: dict[str, list[float]] = {
        k: [] for k in ("t", "heading", "along", "fold", "speed", "turn", "wheel_diff", "yaw")
    }
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
                np.exp(1j * run.yaw[b]) - np.exp(1j * run.yaw[a])
            )
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
    return _Windows(
        arr["t"],
        arr["heading"],
        arr["along"],
        arr["fold"].astype(np.intp),
        arr["speed"],
        arr["turn"],
        arr["wheel_diff"],
        arr["yaw"],
        tuple(segs) if len(segs) > 1 else (),
    )


def _fold_params(
    runs: Sequence[DriveRun], segment_s: float
) -> tuple[DiffDriveParams, DiffDriveParams] | None:
    """Parameters fitted on each fold's segments (alternating ``FOLD_S`` blocks): entry f is
    fitted on the *other* fold, so that it predicts fold f held out."""
    try:
        d = segment_design(runs, segment_s)
    except InsufficientDataError:
        return None
    offs = _run_offsets(runs)
    t_mid = np.array(
        [0.5 * (runs[s.run].t[s.start] + runs[s.run].t[s.stop]) + offs[s.run] for s in d.segments]
    )
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
    cov = {
        "speed (m/s)": w.speed,
        "|turn rate| (rad/s)": w.turn,
        "wheel speed difference (m/s)": w.wheel_diff,
    }
    return [
        ResidualChannel(
            "heading increment",
            "rad",
            w.t,
            w.heading,
            held_h,
            timescale_s=WINDOW_S,
            covariates=cov,
            segments=w.segments,
        ),
        ResidualChannel(
            "along-track displacement",
            "m",
            w.t,
            w.along,
            held_a,
            timescale_s=WINDOW_S,
            covariates=cov,
            segments=w.segments,
        ),
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
                    pred = (
                        params.r_R * (run.wheel_right[j] - run.wheel_right[i])
                        - params.r_L * (run.wheel_left[j] - run.wheel_left[i])
                    ) / params.b
                    miss = float(run.yaw[j] - run.yaw[i] - pred)
                    n_win = max(1.0, (run.t[j] - run.t[i]) / WINDOW_S)
                    if abs(miss) > max(STUCK_MIN_RAD, 5 * heading_floor * math.sqrt(n_win)):
                        out.append(
                            StuckSpan(
                                k,
                                wheel,
                                i,
                                j,
                                float(run.t[i] + offs[k]),
                                float(run.t[j] + offs[k]),
                                miss,
                            )
                        )
                i = j
    return sorted(out, key=lambda s: s.t0_s)


def exclusion_masks(
    runs: Sequence[DriveRun], spans: Sequence[StuckSpan]
) -> list[NDArray[np.bool_]]:
    """Per run, the increments (index i: sample i to i+1) inside ``spans``."""
    masks = [np.zeros(max(r.n, 1), dtype=bool) for r in runs]
    for s in spans:
        masks[s.run][s.i0 : s.i1] = True
    return masks


def _split_excluded(
    runs: Sequence[DriveRun], excluded: Sequence[NDArray[np.bool_]] | None
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
    return DriveRun(
        run.t[sl],
        run.wheel_right[sl],
        run.wheel_left[sl],
        run.x[sl],
        run.y[sl],
        run.yaw[sl],
        name=run.name,
    )


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


def piece_length(runs: Sequence[DriveRun]) -> float:
    """Length (s) of the pieces fitted separately: ``PIECE_S`` for a long log, shorter for a
    short one so that it still gives about ``PIECES_WANTED`` pieces (never under
    ``PIECE_MIN_S``)."""
    total = sum(float(r.t[-1] - r.t[0]) for r in runs if r.n >= 2)
    return float(min(PIECE_S, max(PIECE_MIN_S, total / PIECES_WANTED)))


def _segment_rows(
    run: DriveRun, p: DiffDriveParams, offset: complex, seg: float
) -> tuple[Array, Array, Array, Array, Array]:
    """Per segment of ``seg`` seconds of ``run``: mid time, heading residual, along-track
    residual of ``p``, and the rows of their derivatives with respect to (r_R, r_L)."""
    h, cum = _run_prediction(run, p)
    edges = np.unique(np.searchsorted(run.t, np.arange(run.t[0], run.t[-1], seg)))
    edges = np.append(edges, run.n - 1) if edges[-1] != run.n - 1 else edges
    ia, ib = edges[:-1], edges[1:]
    dr = run.wheel_right[ib] - run.wheel_right[ia]
    dl = run.wheel_left[ib] - run.wheel_left[ia]
    dyaw = run.yaw[ib] - run.yaw[ia]
    e_h = dyaw - (h[ib] - h[ia])
    disp = (run.x[ib] - run.x[ia]) + 1j * (run.y[ib] - run.y[ia])
    pred = np.exp(1j * (run.yaw[ia] - h[ia])) * (cum[ib] - cum[ia]) + offset * (
        np.exp(1j * run.yaw[ib]) - np.exp(1j * run.yaw[ia])
    )
    u = np.exp(1j * 0.5 * (run.yaw[ia] + run.yaw[ib]))
    e_p = ((disp - pred) * np.conj(u)).real
    t = 0.5 * (run.t[ia] + run.t[ib])
    return (
        t,
        e_h,
        e_p,
        np.column_stack([dr / p.b, -dl / p.b]),
        np.column_stack([0.5 * dr, 0.5 * dl]),
    )


LRV_FLOOR = 0.2
"""Smallest long-run / plain variance ratio credited to segment residuals: consecutive
segments share the ground truth's sample at their common end, so their errors cancel in
sums (the ratio falls towards zero); a floor keeps the pieces' errors from being trusted
beyond that."""


def _lrv_ratio(x: Array) -> float:
    """Bartlett long-run variance over variance of a residual series (``LRV_FLOOR`` to 4):
    what a sum over many consecutive segments holds of their variances."""
    x = x[np.isfinite(x)]
    if x.size < 8:
        return 1.0
    return float(min(4.0, max(LRV_FLOOR, long_run_variance_ratio(x - x.mean()))))


def piece_fits(
    runs: Sequence[DriveRun],
    params: DiffDriveParams,
    piece_s: float | None = None,
    segment_s: float | None = None,
    offset: complex | None = None,
) -> list[PieceFit]:
    """The mean wheel radius and the radius difference per piece of ``piece_s`` seconds
    (None: :func:`piece_length`), as corrections to ``params`` fitted on the segments
    (``segment_s``, None: a sixth of a piece, 0.5-2 s) of that piece: the heading residual
    determines the difference, the along-track residual the mean, so the two come out nearly
    uncorrelated and each precise (raw r_R, r_L from the heading alone are strongly correlated
    whenever a piece mostly drives straight). Both residuals are weighted by one variance per
    channel pooled over all pieces' own fits (a piece has only a few segments: its own variance
    would make the pieces' chi-square heavy-tailed)."""
    piece_s = piece_length(runs) if piece_s is None else piece_s
    seg = min(2.0, max(0.5, piece_s / 6)) if segment_s is None else segment_s
    off = offset or 0j
    offs = _run_offsets(runs)
    raw: list[tuple[float, float, Array, Array, Array, Array]] = []
    for k, run in enumerate(runs):
        if run.n < 4:
            continue
        t, e_h, e_p, A_h, A_p = _segment_rows(run, params, off, seg)
        for t0 in np.arange(run.t[0], run.t[-1] - 0.5 * piece_s, piece_s):
            t1 = min(t0 + piece_s, float(run.t[-1]))
            if run.t[-1] - t1 < 0.5 * piece_s:
                t1 = float(run.t[-1])
            m = (t >= t0) & (t < t1) if t1 < run.t[-1] else t >= t0
            if m.sum() >= 3:
                raw.append(
                    (float(t0 + offs[k]), float(t1 + offs[k]), e_h[m], e_p[m], A_h[m], A_p[m])
                )
            if t1 >= run.t[-1]:
                break
    if len(raw) < 2:
        return []
    # per-channel variance pooled over the pieces' own two-parameter fits, per channel alone
    pooled = []
    for c in (0, 1):
        sse, dof, series = 0.0, 0, []
        for piece in raw:
            e = np.asarray(piece[2 + c], dtype=float)
            A = np.asarray(piece[4 + c], dtype=float)
            coef, *_ = np.linalg.lstsq(A, e, rcond=None)
            res = e - A @ coef
            sse += float(res @ res)
            dof += max(0, e.size - 2)
            series.append(res)
        ratio = _lrv_ratio(np.concatenate(series)) if series else 1.0
        pooled.append(sse / dof * ratio if dof > 0 and sse > 0 else math.nan)
    if not all(math.isfinite(v) for v in pooled):
        return []
    s_h, s_p = (math.sqrt(v) for v in pooled)
    T = np.array([[0.5, 0.5], [1.0, -1.0]])  # (r_R, r_L) -> (mean, difference)
    out = []
    for t0, t1, e_h, e_p, A_h, A_p in raw:
        A = np.vstack([A_h / s_h, A_p / s_p])
        y = np.concatenate([e_h / s_h, e_p / s_p])
        if np.linalg.matrix_rank(A) < 2:
            continue
        coef, *_ = np.linalg.lstsq(A, y, rcond=None)
        cov = T @ np.linalg.inv(A.T @ A) @ T.T
        val = T @ coef + T @ np.array([params.r_R, params.r_L])
        sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
        out.append(
            PieceFit(
                t0,
                t1,
                {PIECE_NAMES[0]: float(val[0]), PIECE_NAMES[1]: float(val[1])},
                {PIECE_NAMES[0]: float(sd[0]), PIECE_NAMES[1]: float(sd[1])},
            )
        )
    return out


def radius_change(
    runs: Sequence[DriveRun], params: DiffDriveParams, offset: complex | None = None
) -> ParameterChange | None:
    """A change of the wheel radii mid-log (:func:`calib.adequacy.parameter_change` over
    :func:`piece_fits`: the mean radius and the radius difference, tested together), reported
    as each wheel's radius before and after; None when one set describes the log."""
    pieces = piece_fits(runs, params, offset=offset)
    r = 0.5 * (params.r_R + params.r_L)
    ch = parameter_change(
        pieces, PIECE_NAMES, min_relative=0.002, scale={PIECE_NAMES[0]: r, PIECE_NAMES[1]: r}
    )
    if ch is None:
        return None

    def wheels(v: Mapping[str, float]) -> dict[str, float]:
        m, d = v[PIECE_NAMES[0]], v[PIECE_NAMES[1]]
        return {"wheel_radius_right": m + 0.5 * d, "wheel_radius_left": m - 0.5 * d}

    before, after = wheels(ch.before), wheels(ch.after)
    desc = ", ".join(f"{n} {before[n]:.4g} -> {after[n]:.4g} m" for n in before)
    return ParameterChange(
        ch.t_s,
        ch.t_range_s,
        tuple(before),
        before,
        after,
        ch.statistic,
        f"the wheel radii change near t = {ch.t_s:.1f} s ({desc})",
    )
