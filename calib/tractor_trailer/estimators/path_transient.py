"""Output-error fit of the transient joint-angle kinematics along the measured path.

The joint angle is simulated along link 1's measured path (``DrivePath``: cumulative arc length
and heading) with calib.tractor_trailer.models.hitch_path, evaluated at each joint-angle sample's
own time, and
(L1, L2, an optional joint-angle sensor offset, one initial angle per piece) minimise the squared
difference to the measured joint angle.

Why this form: a time-domain fit driven by sampled speed and curvature must guess the
inputs between samples and divides by the speed; this one integrates the recorded motion itself,
so it is the same at any sampling rate, with jitter and with asynchronous sensors, it needs no
speed (a pose is enough), stops and reversing are ordinary, and actuator effects (delay, lag,
understeer) do not bias it when the path is measured.

Gaps (recorder stalls, dropouts of the joint angle or of the path) split the log into pieces;
each piece has its own initial angle and nothing is integrated across a gap. Long pieces are cut
into chunks integrated side by side (one numpy call per step for all of them); the chunks'
start values are made continuous by Newton steps (each chunk's sensitivity d end / d start is
integrated alongside) until they agree to 1e-12 rad, typically in two or three passes.

Uncertainty: a Newey-West (HAC) sandwich of the residuals, with the per-piece initial angles
projected out (Frisch-Waugh), which carries the autocorrelation that path noise and unmodelled
effects leave in the residual. Its coverage is measured on logs from an independent generator
(bench/path_coverage_study.py).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import least_squares
from scipy.sparse import csr_matrix

from calib.errors import InsufficientDataError, SolverError
from calib.lsq.base import triangular_factor_by_rows
from calib.results import CalibrationResult
from calib.stats import (
    bartlett_bandwidth,
    detect_quantum,
    hac_covariance,
    hf_noise_std,
)
from calib.tractor_trailer.estimators._result import (
    calibration_result,
    information_criteria,
    method_result,
)
from calib.tractor_trailer.estimators.drive_path import DrivePath, default_gap_s
from calib.tractor_trailer.estimators.identifiability import IdentifiabilityVerdict, identifiability
from calib.tractor_trailer.models.hitch_path import (
    advance_psi,
    advance_psi_jacobian,
    rk4_substeps,
    substep_inputs,
)
from calib.tractor_trailer.results import Family, MethodResult

__all__ = ["PathTransientFit"]

_ADVICE = (
    "drive with curvature changes (turns shorter than a few trailer lengths, S-bends) and larger "
    "joint angles, record the joint angle without gaps, or lower the sensor noise"
)
_FILL_S = 0.05  # path knots inside joint-angle intervals longer than this become nodes
_MIN_PIECE = 8  # joint-angle samples a piece needs
_MIN_MOVE_M = 0.01  # a piece whose path moves less than this carries nothing on L1, L2
_DENSE_STEP = 0.05  # path knots closer than this (rad of heading + arc length / L2) are dense
_RATE_DRAWS = 8  # fresh noise draws that measure what odometry noise does to the estimate
_ASYMPTOTIC_STEP = 0.1  # below this the O(h^2) Richardson third of the difference applies
_GRID_BUDGET = 16384  # nodes on which the start-point grid is evaluated, at most
_GRID_MIN_WINDOW = 512  # nodes per window of the start-point grid, at least


@dataclass(frozen=True)
class _Layout:
    """Nodes cut into chunks for side-by-side integration.

    ``A``/``B``: heading and arc-length increments per step, (k, c) (zero-padded);
    ``node_chunk``/``node_step``: where each node sits (chunk, row of the output);
    ``chunk_piece``: piece of each chunk; ``chunk_first``: the chunk starts its piece;
    ``prev_chunk``: chunk whose end starts this one (-1 for a piece's first chunk).
    """

    A: np.ndarray
    B: np.ndarray
    node_chunk: np.ndarray
    node_step: np.ndarray
    chunk_piece: np.ndarray
    chunk_first: np.ndarray
    prev_chunk: np.ndarray
    chunk_end_step: np.ndarray


def _pieces(t: np.ndarray, path: DrivePath, gaps: list[tuple[float, float]]) -> np.ndarray:
    """Piece index of each joint-angle sample: a new piece after any gap."""
    gap_psi = default_gap_s(t)
    new = np.diff(t) > gap_psi
    # a path gap between two joint-angle samples
    k0 = np.searchsorted(path.t_s, t[:-1], side="right")
    k1 = np.searchsorted(path.t_s, t[1:], side="left")
    if path.t_s.size > 1:
        big = np.nonzero(np.diff(path.t_s) > path.gap_s)[0]  # knot interval big -> big + 1
        if big.size:
            # samples i, i+1 straddle knot interval j when k0 <= j + 1 and j < k1 ... any j
            cum = np.concatenate([[0], np.cumsum(np.isin(np.arange(path.t_s.size - 1), big))])
            lo = np.clip(k0 - 1, 0, path.t_s.size - 1)
            hi = np.clip(k1, 0, path.t_s.size - 1)
            new |= (cum[hi] - cum[lo]) > 0
    for g0, g1 in gaps:
        new |= (t[:-1] < g1) & (t[1:] > g0)
    return np.concatenate([[0], np.cumsum(new)])


class PathTransientFit:
    """Fit (L1, L2[, psi offset], psi0 per piece) of the joint angle along a measured path.

    Args:
        rel_tol: a quantity is "determined" when its 95 % half-width <= rel_tol times
            max(|value|, (|L1| + |L2|) / 2) (an absolute scale, so L1 near 0 can be determined).
        fit_psi_offset: also fit a constant offset of the joint-angle sensor (rad).
        bounds_L1_m, bounds_L2_m: parameter bounds (m); L1 may be negative (hitch ahead of
            link 1's axle) or zero. An estimate on a bound is reported as not determined.
        chunk_nodes: nodes per chunk of side-by-side integration (None: chosen by size).
        resolution_check: refit on the path at half its resolution and add the difference
            (a bound of the discretisation error) to the covariance, so that clean or sparsely
            sampled logs do not claim a precision the path's sampling cannot give.
        extra_covariance: a 2 x 2 covariance of (L1, L2) added to the fit's own (what the
            caller knows the fit cannot see: e.g. the uncertainty of joint-angle effects fitted
            elsewhere and undone in the data).
        rate_noise_check: measure what an odometry path's integrated noise does to the
            estimate (fresh noise draws; off for quick fits whose intervals are not reported).
        fill_spacing_s: path knots inside long joint-angle intervals become nodes at most one
            per this many seconds (0: every knot). A coarser grid integrates the path as
            constant-curvature arcs between the kept nodes: cheaper in proportion, and it moves
            the fit by a small fraction of its standard error while the spacing stays below
            the time the joint angle needs to move (measured in bench/bench_discovery_cost.py).

    Attributes (after ``fit``):
        L1_, L2_, psi_offset_: estimates (m, m, rad). cov_: covariance of (L1, L2[, offset]).
        verdict_, result_, method_result_, converged_, sound_ (converged, finite covariance,
        no parameter on a bound), misfit_ (residual rms / joint-angle white-noise std),
        residual_rms_, noise_std_, n_pieces_, notes_ (what was dropped and why),
        t_s_, psi_fit_ (model at the used samples), residual_.
    """

    name = "Transient-path"

    def __init__(
        self,
        *,
        rel_tol: float = 0.1,
        fit_psi_offset: bool = False,
        bounds_L1_m: tuple[float, float] = (-20.0, 50.0),
        bounds_L2_m: tuple[float, float] = (0.02, 50.0),
        chunk_nodes: int | None = None,
        resolution_check: bool = True,
        extra_covariance: np.ndarray | None = None,
        rate_noise_check: bool = True,
        fill_spacing_s: float = 0.0,
    ) -> None:
        self.fill_spacing_s = fill_spacing_s
        self.resolution_check = resolution_check
        self.rate_noise_check = rate_noise_check
        self.extra_covariance = extra_covariance
        self.rel_tol = rel_tol
        self.fit_psi_offset = fit_psi_offset
        self.bounds_L1_m = bounds_L1_m
        self.bounds_L2_m = bounds_L2_m
        self.chunk_nodes = chunk_nodes
        self._eval_caches: list[dict[bytes, tuple[np.ndarray, np.ndarray]]] = []
        self._substeps: tuple[int, np.ndarray, np.ndarray] | None = None
        """The layout's per-substep kernel inputs (``substep_inputs``) for the last n_sub."""

    # ------------------------------------------------------------------ layout
    def _prepare(
        self,
        path: DrivePath,
        t_psi: ArrayLike,
        psi: ArrayLike,
        gaps: list[tuple[float, float]],
    ) -> None:
        t = np.asarray(t_psi, dtype=float).ravel()
        p = np.asarray(psi, dtype=float).ravel()
        if t.size != p.size:
            raise InsufficientDataError(
                f"{self.name}: t_psi and psi lengths differ ({t.size} vs {p.size})"
            )
        ok = np.isfinite(t) & np.isfinite(p)
        t, p = t[ok], p[ok]
        order = np.argsort(t, kind="stable")
        t, p = t[order], p[order]
        keep = np.concatenate([[True], np.diff(t) > 0]) if t.size else np.zeros(0, bool)
        t, p = t[keep], p[keep]
        notes: list[str] = []
        inside = path.covered(t) if t.size else np.zeros(0, bool)
        if t.size and not inside.all():
            notes.append(
                f"{int((~inside).sum())} joint-angle samples outside the recorded path or "
                "inside a path gap were not used"
            )
        t, p = t[inside], p[inside]
        in_gap = np.zeros(t.size, dtype=bool)
        for g0, g1 in gaps:
            in_gap |= (t > g0) & (t < g1)
        if in_gap.any():
            notes.append(
                f"{int(in_gap.sum())} joint-angle samples inside recorder gaps of other "
                "signals were not used"
            )
            t, p = t[~in_gap], p[~in_gap]
        if t.size < _MIN_PIECE:
            raise InsufficientDataError(
                f"{self.name}: {t.size} joint-angle samples on the recorded path; need {_MIN_PIECE}"
            )
        piece = _pieces(t, path, gaps)
        s_at, _ = path.at(t)
        used = np.zeros(t.size, dtype=bool)
        dropped_short = dropped_still = 0
        for j in range(int(piece[-1]) + 1):
            m = piece == j
            if m.sum() < _MIN_PIECE:
                dropped_short += 1
                continue
            moved = float(np.ptp(s_at[m]))
            if moved < _MIN_MOVE_M:
                dropped_still += 1
                continue
            used |= m
        if dropped_short:
            notes.append(f"{dropped_short} pieces between gaps with < {_MIN_PIECE} samples dropped")
        if dropped_still:
            notes.append(f"{dropped_still} pieces where the robot did not move dropped")
        if not used.any():
            moved = path.distance_m
            raise InsufficientDataError(
                f"{self.name}: no piece of the log both moves and has {_MIN_PIECE} joint-angle "
                f"samples (the robot travelled {moved:.3g} m in all)"
            )
        t, p = t[used], p[used]
        _, piece = np.unique(piece[used], return_inverse=True)
        self._t, self._p, self._piece = t, p, piece
        self.n_pieces_ = int(piece.max()) + 1
        self.notes_ = notes
        self._build_layout(path)

    def _build_layout(self, path: DrivePath) -> None:
        t, piece = self._t, self._piece
        # nodes: joint-angle samples plus path knots inside long joint-angle intervals
        node_t, node_piece, is_obs = [t], [piece], [np.ones(t.size, bool)]
        if path.t_s.size:
            j = np.searchsorted(t, path.t_s, side="right")
            ok = (j > 0) & (j < t.size)
            jj = np.clip(j, 1, t.size - 1)
            ok &= (t[jj] - t[jj - 1] > _FILL_S) & (piece[jj] == piece[jj - 1])
            ok &= path.t_s > t[jj - 1]
            if self.fill_spacing_s > 0 and ok.any():
                # at most one fill node per fill_spacing_s of the global time grid
                cell = np.floor(path.t_s / self.fill_spacing_s)
                new_cell = np.ones(int(ok.sum()), bool)
                new_cell[1:] = np.diff(cell[ok]) != 0
                ok[np.flatnonzero(ok)[~new_cell]] = False
            node_t.append(path.t_s[ok])
            node_piece.append(piece[jj[ok]])
            is_obs.append(np.zeros(int(ok.sum()), bool))
        nt = np.concatenate(node_t)
        npc = np.concatenate(node_piece)
        obs = np.concatenate(is_obs)
        order = np.lexsort((nt, npc))
        nt, npc, obs = nt[order], npc[order], obs[order]
        s, th = path.at(nt)
        n = nt.size
        size = self.chunk_nodes or int(np.clip(math.ceil(n / 48), 256, 1024))
        # chunks: split each piece into runs of <= size nodes sharing their boundary node
        chunk_of = np.empty(n, dtype=np.int64)
        step_of = np.empty(n, dtype=np.int64)
        starts: list[int] = []
        c_piece: list[int] = []
        c_first: list[bool] = []
        bounds = np.nonzero(np.diff(npc))[0] + 1
        piece_ranges = zip(np.r_[0, bounds], np.r_[bounds, n], strict=True)
        ranges: list[tuple[int, int]] = []
        for a, b in piece_ranges:
            first = True
            k = a
            while True:
                e = min(k + size, b - 1)
                ranges.append((k, e))  # nodes k..e inclusive
                starts.append(k)
                c_piece.append(int(npc[a]))
                c_first.append(first)
                first = False
                if e >= b - 1:
                    break
                k = e
        kmax = max(e - k for k, e in ranges)
        c = len(ranges)
        A = np.zeros((max(kmax, 1), c))
        B = np.zeros((max(kmax, 1), c))
        for ci, (k, e) in enumerate(ranges):
            A[: e - k, ci] = np.diff(th[k : e + 1])
            B[: e - k, ci] = np.diff(s[k : e + 1])
            chunk_of[k : e + 1] = ci
            step_of[k : e + 1] = np.arange(e - k + 1)
        prev = np.array([ci - 1 if not c_first[ci] else -1 for ci in range(c)])
        obs_t = nt[obs]
        j = np.clip(np.searchsorted(path.t_s, obs_t, side="right"), 1, path.t_s.size - 1)
        span = path.t_s[j] - path.t_s[j - 1]
        a = np.clip((obs_t - path.t_s[j - 1]) / np.where(span > 0, span, 1.0), 0.0, 1.0)
        self._knot_var_factor = a * a + (1.0 - a) ** 2
        self._path_noise = (path.theta_noise_rad, path.s_noise_m)
        self._substeps = None
        self._layout = _Layout(
            A,
            B,
            chunk_of[obs],
            step_of[obs],
            np.array(c_piece),
            np.array(c_first),
            prev,
            np.array([e - k for k, e in ranges]),
        )
        self._chunk_start_guess = np.interp(nt[np.array(starts)], t, self._p)

    # ------------------------------------------------------------------ model
    def _simulate_jacobian(
        self, L1: float, L2: float, psi0: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Model psi at the used samples and its exact derivatives to the piece's initial
        angle, L1 and L2 (forward sensitivities), each shape (n_obs,); psi0: (pieces,)."""
        lay = self._layout
        first = lay.chunk_first
        start = np.zeros(first.size)
        start[first] = psi0[lay.chunk_piece[first]]
        chain = np.where(first, -1, lay.prev_chunk)
        n_sub = rk4_substeps(lay.A, lay.B, np.array([L1]), np.array([L2]))
        inputs = self._substeps
        if inputs is None or inputs[0] != n_sub:
            inputs = self._substeps = substep_inputs(lay.A, lay.B, n_sub)
        psi, d0, d1, d2 = advance_psi_jacobian(
            lay.A, lay.B, L1, L2, start, n_sub, chain=chain, inputs=inputs
        )
        at = (lay.node_step, lay.node_chunk)
        return psi[at], d0[at], d1[at], d2[at]

    # ------------------------------------------------------------------ fit
    def _start_point(self) -> np.ndarray:
        """(L1, L2) of the best point of a coarse grid, which only has to pick the basin.

        The grid is evaluated on windows of at most ``_GRID_BUDGET`` nodes in all (the first
        nodes of evenly spaced chunks), each window started from the measured joint angle at
        its first node, so that its cost does not grow with the log's length and no sweeping
        of chunk start values is needed.
        """
        lo1, hi1 = self.bounds_L1_m
        lo2, hi2 = self.bounds_L2_m
        g2 = np.geomspace(max(lo2, 0.1), min(hi2, 20.0), 13)
        ratios = np.array([-0.2, -0.05, 0.0, 0.1, 0.25, 0.5, 0.75, 1.0, 1.5])
        A2, R = np.meshgrid(g2, ratios, indexing="ij")
        L2 = A2.ravel()
        L1 = np.clip(R.ravel() * L2, lo1, hi1)
        lay = self._layout
        c = lay.chunk_first.size
        width = max(_GRID_MIN_WINDOW, _GRID_BUDGET // c)
        n_use = max(1, min(c, _GRID_BUDGET // width))
        idx = np.unique(np.round(np.linspace(0, c - 1, n_use)).astype(np.int64))
        width = min(width, lay.A.shape[0])
        A, B = lay.A[:width, idx], lay.B[:width, idx]
        first = lay.chunk_first[idx]
        start = np.where(
            first, self._psi0_guess[lay.chunk_piece[idx]], self._chunk_start_guess[idx]
        )
        out = advance_psi(A, B, L1, L2, np.repeat(start[:, None], L1.size, axis=1))
        col = np.full(c, -1)
        col[idx] = np.arange(idx.size)
        sel = (col[lay.node_chunk] >= 0) & (lay.node_step <= width)
        sim = out[lay.node_step[sel], col[lay.node_chunk[sel]]]
        res = self._p[sel, None] - sim
        if self.fit_psi_offset:
            res = res - np.nanmean(res, axis=0)
        cost = np.nansum(res**2, axis=0)
        cost[~np.isfinite(cost)] = np.inf
        best = int(np.argmin(cost))
        return np.array([L1[best], L2[best]])

    def fit(
        self,
        path: DrivePath,
        t_psi: ArrayLike,
        psi: ArrayLike,
        *,
        gaps: list[tuple[float, float]] | None = None,
    ) -> PathTransientFit:
        """Fit to the joint angle ``psi`` (rad) sampled at ``t_psi`` (s, same clock as the
        path) along ``path``. ``gaps``: extra (t0, t1) spans (s) where the log is interrupted.

        Raises:
            InsufficientDataError: too few joint-angle samples on a moving path.
            SolverError: the optimiser produced a non-finite result.
        """
        self._path_source = path.source
        self._smoothing = path.smoothing_samples
        self._fit_core(path, t_psi, psi, gaps)
        return self

    def _evaluator(self, q: int) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]:
        """Residuals and compact Jacobian at a parameter vector (L1, L2[, offset], psi0...):
        columns L1, L2[, offset] and the initial angles of all pieces at once (each piece's
        column is its rows of the last one)."""
        n = self._p.size
        cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
        self._eval_caches.append(cache)

        def evaluate(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            key = x.tobytes()
            if key not in cache:
                sim, d_psi0, d_l1, d_l2 = self._simulate_jacobian(float(x[0]), float(x[1]), x[q:])
                off = x[2] if self.fit_psi_offset else 0.0
                resid = self._p - sim - off
                J = np.empty((n, 3 + (q - 2)))
                J[:, 0] = -d_l1
                J[:, 1] = -d_l2
                if self.fit_psi_offset:
                    J[:, 2] = -1.0
                J[:, -1] = -d_psi0
                cache.clear()
                cache[key] = (resid, J)
            return cache[key]

        return evaluate

    def _fit_core(
        self,
        path: DrivePath,
        t_psi: ArrayLike,
        psi: ArrayLike,
        gaps: list[tuple[float, float]] | None,
    ) -> None:
        self._prepare(path, t_psi, psi, list(gaps or []))
        self._eval_caches = []
        P = self.n_pieces_
        piece = self._piece
        first_idx = np.searchsorted(piece, np.arange(P))
        self._psi0_guess = np.array([float(np.mean(self._p[i : i + 3])) for i in first_idx])
        q = 3 if self.fit_psi_offset else 2
        x0 = np.concatenate([self._start_point(), np.zeros(q - 2), self._psi0_guess])
        lo = np.concatenate(
            [
                [self.bounds_L1_m[0], self.bounds_L2_m[0]],
                np.full(q - 2, -math.pi),
                np.full(P, -math.pi),
            ]
        )
        hi = np.concatenate(
            [
                [self.bounds_L1_m[1], self.bounds_L2_m[1]],
                np.full(q - 2, math.pi),
                np.full(P, math.pi),
            ]
        )
        x0 = np.clip(x0, lo + 1e-6, hi - 1e-6)
        n = self._p.size
        rows = np.arange(n)
        evaluate = self._evaluator(q)
        self._evaluate = evaluate

        def full_jac(J: np.ndarray) -> np.ndarray | csr_matrix:
            if P == 1:
                return J
            dense = J[:, :q]
            col0 = J[:, -1]
            sp = csr_matrix((col0, (rows, q + piece)), shape=(n, q + P))
            if n * (q + P) <= 4_000_000:
                out = sp.toarray()
                out[:, :q] = dense
                return out
            from scipy.sparse import hstack

            return hstack([csr_matrix(dense), sp[:, q:]]).tocsr()

        def cleaned(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            r, J = evaluate(x)
            return np.where(np.isfinite(r), r, 1e3), np.where(np.isfinite(J), J, 0.0)

        sparse = P > 1 and n * (q + P) > 4_000_000
        folded: dict[bytes, np.ndarray] = {}

        def fold(x: np.ndarray) -> np.ndarray:
            """R of [J r] at ``x`` (dense case): (q + P + 1) residuals with the same sum of
            squares, J^T J and J^T r as the n residuals (so least_squares takes the same
            steps and stops at the same point), without its copies of the n-row Jacobian
            (the fit's memory on a 1-hour log)."""
            key = x.tobytes()
            if key not in folded:
                r, J = cleaned(x)
                full = full_jac(J)
                assert isinstance(full, np.ndarray)

                def rows(a: int, b: int, out: np.ndarray) -> None:
                    out[:, :-1] = full[a:b]
                    out[:, -1] = r[a:b]

                folded.clear()
                folded[key] = triangular_factor_by_rows(n, full.shape[1] + 1, rows)
            return folded[key]

        def fun(x: np.ndarray) -> np.ndarray:
            if sparse:
                return cleaned(x)[0]
            return fold(x)[:, -1].copy()

        def jac(x: np.ndarray) -> np.ndarray | csr_matrix:
            if sparse:
                return full_jac(cleaned(x)[1])
            return fold(x)[:, :-1].copy()

        sol = least_squares(
            fun,
            x0,
            jac=jac,
            bounds=(lo, hi),
            method="trf",
            x_scale="jac",
            tr_solver="lsmr" if sparse else "exact",
            xtol=1e-10,
            ftol=1e-12,
            gtol=1e-10,
            max_nfev=200,
        )
        if not np.all(np.isfinite(sol.x)):
            raise SolverError(f"{self.name}: non-finite estimate {sol.x!r}")
        r, J = evaluate(sol.x)
        if not np.all(np.isfinite(r)):
            raise SolverError(f"{self.name}: the model diverges at the estimate")
        self.bias_correction_ = self._input_noise_bias(J, r, np.asarray(sol.x))
        self._x_raw = np.asarray(sol.x).copy()
        self._x_ = np.asarray(sol.x).copy()
        self._x_[:2] += self.bias_correction_
        extra = self._resolution_error(path, t_psi, psi, gaps, self._x_, q)
        extra = extra + self._rate_noise_cov(path, gaps, q)
        if self.extra_covariance is not None:
            extra = extra.copy()
            extra[:2, :2] += np.asarray(self.extra_covariance, dtype=float)[:2, :2]
        self._finish(sol, r, J, q, lo, hi, extra)
        for c in self._eval_caches:  # the last residuals and Jacobian: n x (3 + pieces) floats
            c.clear()

    def _resolution_error(
        self,
        path: DrivePath,
        t_psi: ArrayLike,
        psi: ArrayLike,
        gaps: list[tuple[float, float]] | None,
        x: np.ndarray,
        q: int,
    ) -> np.ndarray:
        """Covariance (q x q) of the discretisation error of the path.

        The model is evaluated at the estimate along the path rebuilt from every other sample,
        and the Gauss-Newton step that this change of the model asks for (initial angles
        projected out) gives the error: a third of it (Richardson, O(h^2)) where the path's
        steps are small next to the trailer's relaxation length, the whole step where they are
        not (not yet asymptotic), nothing where the knots are dense (< ``_DENSE_STEP``). A
        linearised step, not a refit, so that the optimiser's wandering along a flat
        direction is not taken for an error.
        """
        self.resolution_error_ = np.zeros(q)
        self.path_step_ = math.nan
        floor = 1e-6 * (abs(x[0]) + abs(x[1]))  # finite-difference Jacobian resolution
        base = floor * floor * np.eye(q)
        if not self.resolution_check or path.coarser is None:
            return base
        # a path whose knots are dense next to the trailer's dynamics has a discretisation
        # error of O(step^2), below what a linearised check can resolve in a flat direction
        step = np.abs(np.diff(path.theta_rad)) * (1.0 + abs(x[0] / x[1])) + np.abs(
            np.diff(path.s_m)
        ) / abs(x[1])
        self.path_step_ = float(np.percentile(step, 95)) if step.size else 0.0
        if self.path_step_ < _DENSE_STEP:
            # budget for what remains: measured on noise-free logs from the independent
            # generator, the error stays below 0.1 step^2 of the link lengths' size
            dense = 0.1 * self.path_step_**2 * (abs(x[0]) + abs(x[1]))
            return base + dense * dense * np.eye(q)
        shift = self._linear_shift(path.coarser(), gaps, q)
        if isinstance(shift, str):
            self._resolution_note = f"resolution check not possible: {shift}"
            return base
        d = shift / 3.0 if self.path_step_ < _ASYMPTOTIC_STEP else shift
        self.resolution_error_ = d  # Richardson where asymptotic: (x_h - x_2h) / (2^2 - 1)
        return np.outer(d, d) + base

    def _linear_shift(
        self, other_path: DrivePath, gaps: list[tuple[float, float]] | None, q: int
    ) -> np.ndarray | str:
        """Gauss-Newton step of the structural parameters that the model along ``other_path``
        asks for at the estimate (initial angles projected out), or why there is none."""
        from calib.errors import CalibError

        other = PathTransientFit(
            rel_tol=self.rel_tol,
            fit_psi_offset=self.fit_psi_offset,
            bounds_L1_m=self.bounds_L1_m,
            bounds_L2_m=self.bounds_L2_m,
            chunk_nodes=self.chunk_nodes,
            resolution_check=False,
        )
        try:
            cut = np.nonzero(np.diff(self._piece))[0]
            same = [(float(self._t[i]), float(self._t[i + 1])) for i in cut]
            other._prepare(other_path, self._t, self._p, list(gaps or []) + same)
        except (CalibError, ValueError, FloatingPointError) as err:
            return str(err)
        rows = np.searchsorted(self._t, other._t)
        if other.n_pieces_ != self.n_pieces_ or rows.size < 0.9 * self._t.size:
            return "the other path splits the log differently"
        raw = self._x_raw
        r_f, J = self._evaluate(raw)
        r_o, _ = other._evaluator(q)(raw)
        Js = self._projected(J, q)[rows]
        d = -np.linalg.lstsq(Js, r_o - r_f[rows], rcond=None)[0]
        return d if np.all(np.isfinite(d)) else "a non-finite step"

    def _rate_noise_cov(
        self, path: DrivePath, gaps: list[tuple[float, float]] | None, q: int
    ) -> np.ndarray:
        """Covariance (q x q) that the noise of integrated rates (odometry) carries into the
        estimate: the path is rebuilt with ``_RATE_DRAWS`` fresh draws of the rates' measured
        white noise, and the linearised shifts of the estimate averaged. A residual sandwich
        alone misses most of it: integrated noise wanders slowly, beyond its lag window."""
        if path.perturbed is None or not self.rate_noise_check:
            return np.zeros((q, q))
        rng = np.random.default_rng(12345)
        shifts = []
        for _ in range(_RATE_DRAWS):
            d = self._linear_shift(path.perturbed(rng), gaps, q)
            if not isinstance(d, str):
                shifts.append(d)
        if not shifts:
            return np.zeros((q, q))
        D = np.array(shifts)
        return D.T @ D / D.shape[0]

    _resolution_note = ""

    # ------------------------------------------------------------------ results
    def _projected(self, J: np.ndarray, q: int) -> np.ndarray:
        """Jacobian columns of the q structural parameters with the per-piece initial angles
        projected out (Frisch-Waugh)."""
        Js = J[:, :q].copy()
        c0 = J[:, -1]
        piece = self._piece
        cc = np.bincount(piece, weights=c0 * c0)
        for j in range(q):
            cj = np.bincount(piece, weights=c0 * Js[:, j])
            Js[:, j] -= c0 * np.where(cc > 0, cj / np.where(cc > 0, cc, 1.0), 0.0)[piece]
        return Js

    def _covariance(self, r: np.ndarray, J: np.ndarray, q: int) -> np.ndarray:
        """HAC covariance of the q structural parameters (initial angles projected out)."""
        Js = self._projected(J, q)
        bw = bartlett_bandwidth(r)
        self.bandwidth_ = bw
        cov = hac_covariance(Js, r, bw)
        n, p = r.size, q + self.n_pieces_
        return cov * (max(n - q, 1) / max(n - p, 1))

    def _input_noise_bias(self, J: np.ndarray, r: np.ndarray, x: np.ndarray) -> np.ndarray:
        """First-order bias of (L1, L2) from white noise on a pose-derived path.

        A noisy heading enters the modelled joint angle directly with gain
        g = 1 + (L1/L2) cos psi (a noisy arc length with h = -sin(psi) / L2), so the expected
        squared residual grows with sigma^2 sum g^2 and least squares leans towards parameters
        that make g small. The shift is -(J^T J)^-1 sum sigma_i^2 g_i grad g_i (plus the
        arc-length term); it is returned with the opposite sign, as the correction to add.
        """
        s_th, s_s = self._path_noise
        self._direct_var = 0.0
        if s_th == 0.0 and s_s == 0.0:
            return np.zeros(2)
        L1, L2 = float(x[0]), float(x[1])
        psi = self._p - r - (float(x[2]) if self.fit_psi_offset else 0.0)
        c, sn = np.cos(psi), np.sin(psi)
        g = 1.0 + (L1 / L2) * c
        h = -sn / L2
        vt = s_th * s_th * self._knot_var_factor
        vs = s_s * s_s * self._knot_var_factor
        self._direct_var = float(np.mean(g * g * vt + h * h * vs))
        grad = np.array(
            [
                np.sum(vt * g * c / L2),
                np.sum(vt * g * (-L1 * c / (L2 * L2))) + np.sum(vs * h * (sn / (L2 * L2))),
            ]
        )
        Js = self._projected(J, 2)
        H = Js.T @ Js
        return np.linalg.solve(H, grad) if np.linalg.cond(H) < 1e14 else np.zeros(2)

    def _quantum_cov(self, J: np.ndarray, r: np.ndarray, q: int) -> np.ndarray:
        """Systematic error of an encoder's quantisation.

        Where the joint angle moves less than a tick between samples, its rounding error is
        not white: it follows the angle itself. With little noise to dither it (white noise
        below one tick), the error is simulated along the fitted angle for 16 phases of the
        tick lattice (the true phase is unknown) and its effect on the parameters (initial
        angles projected out) averaged into a covariance.
        """
        self.quantum_ = detect_quantum(self._p)
        qt = self.quantum_
        if qt == 0.0 or hf_noise_std(self._p) >= qt:
            return np.zeros((q, q))
        Js = self._projected(J, q)
        fit = self._p - r
        pinv = np.linalg.pinv(Js)
        cov = np.zeros((q, q))
        phases = np.arange(16) / 16.0 * qt
        for u in phases:
            e = qt * np.round((fit + u) / qt) - (fit + u)
            d = pinv @ e
            cov += np.outer(d, d)
        return cov / phases.size

    def _finish(
        self,
        sol: object,
        r: np.ndarray,
        J: np.ndarray,
        q: int,
        lo: np.ndarray,
        hi: np.ndarray,
        extra_cov: np.ndarray,
    ) -> None:
        raw = np.asarray(sol.x)  # type: ignore[attr-defined]
        self.converged_ = bool(sol.success)  # type: ignore[attr-defined]
        x = self._x_
        self.psi_offset_ = float(x[2]) if self.fit_psi_offset else 0.0
        self.L1_, self.L2_ = float(x[0]), float(x[1])
        self.psi0_ = x[q:].copy()
        cov = self._covariance(r, J, q) + extra_cov + self._quantum_cov(J, r, q)
        # the first-order noise correction is itself uncertain: half of it as one std
        half = np.zeros(q)
        half[:2] = 0.5 * self.bias_correction_
        cov = cov + np.outer(half, half)
        self.cov_ = cov
        span = hi[:q] - lo[:q]
        on_bound = (raw[:q] - lo[:q] < 1e-4 * span) | (hi[:q] - raw[:q] < 1e-4 * span)
        self.on_bound_ = [
            n for n, b in zip(("L1", "L2", "psi_offset"), on_bound, strict=False) if b
        ]
        self.residual_ = r
        self.residual_rms_ = float(np.sqrt(np.mean(r * r)))
        self.noise_std_ = max(hf_noise_std(self._p), 1e-4)
        # what the residual would be if the model were right: the joint angle's own white
        # noise plus the pose noise that reaches the modelled angle directly
        # (at least 1 mrad: stamp jitter and the path's discretisation leave that much on
        # clean logs, which a ratio against their tiny noise would call a misfit)
        self.expected_rms_ = max(math.sqrt(self.noise_std_**2 + self._direct_var), 1e-3)
        self.misfit_ = self.residual_rms_ / self.expected_rms_
        self.t_s_ = self._t
        self.psi_fit_ = self._p - r
        finite = bool(np.all(np.isfinite(cov)) and np.all(np.diag(cov) > 0))
        self.sound_ = self.converged_ and finite and not self.on_bound_
        cov2 = cov[:2, :2] if finite else np.full((2, 2), np.inf)
        if not finite:
            cov2 = np.diag([np.inf, np.inf])
        scale = 0.5 * (abs(self.L1_) + abs(self.L2_))
        self.verdict_: IdentifiabilityVerdict = identifiability(
            np.where(np.isfinite(cov2), cov2, 1e12),
            (self.L1_, self.L2_),
            rel_tol=self.rel_tol,
            method=self.name,
            advice=_ADVICE,
            scale=scale,
            not_determined=self.on_bound_ or ([] if finite else ["L1", "L2"]),
        )
        aic, bic = information_criteria(float(r @ r), r.size, q + self.n_pieces_)
        details = {
            "estimator": "output-error fit of the transient joint-angle kinematics along the "
            "measured path (distance domain)",
            "path_source": self._path_source,
            "pieces": self.n_pieces_,
            "samples": int(r.size),
            "psi_offset_rad": self.psi_offset_ if self.fit_psi_offset else None,
            "psi_offset_std_rad": math.sqrt(cov[2, 2]) if self.fit_psi_offset and finite else None,
            "residual_rms_rad": self.residual_rms_,
            "noise_std_rad": self.noise_std_,
            "expected_rms_rad": self.expected_rms_,
            "misfit": self.misfit_,
            "hac_bandwidth": self.bandwidth_,
            "on_bound": list(self.on_bound_),
            "sound": self.sound_,
            "discretisation_error": self.resolution_error_[:2].tolist(),
            "path_step_p95": self.path_step_,
            "path_smoothing_samples": self._smoothing,
            "input_noise_bias_correction": self.bias_correction_.tolist(),
            "psi_quantum_rad": self.quantum_,
            "notes": list(self.notes_) + ([self._resolution_note] if self._resolution_note else []),
            "identifiability": self.verdict_.to_dict(),
        }
        self.result_: CalibrationResult = calibration_result(
            self.name,
            self.verdict_,
            cov2,
            converged=self.converged_,
            aic=aic,
            bic=bic,
            details=details,
        )
        Jc = J[:, :2]
        sv = np.linalg.svd(Jc[np.all(np.isfinite(Jc), axis=1)], compute_uv=False)
        cond = float(sv[0] / sv[-1]) if sv.size == 2 and sv[-1] > 0 else math.inf
        self.method_result_: MethodResult = method_result(
            self.name,
            Family.TRANSIENT,
            self.verdict_,
            condition_number=cond,
            extra={"residual_rms_rad": self.residual_rms_, "misfit": self.misfit_},
        )
