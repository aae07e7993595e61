"""The tractor-trailer's catalogue of joint-angle effects for discovery along the measured path,
and the joint fit of (L1, L2, one initial angle per piece) with any set of them.

The kinematics are integrated along link 1's measured path
(``calib.tractor_trailer.models.hitch_path`` through
the layout of :class:`calib.tractor_trailer.estimators.path_transient.PathTransientFit`); the
effects act only
on how the true angle becomes the recorded one, in this order:

    clock   the joint angle is stamped at tau = t - c - d (t - t_first): an offset c (s, the
            topic stamped late) and a drift d (s/s);
    play    the encoder's backlash: the reading follows the angle only once it leaves a dead
            band of width w (it lags by w / 2 after a reversal);
    cubic   a nonlinearity y + k y^3 (unit gain at 0);
    gain    a scale s (y -> s y);
    offset  a constant b (y -> y + b).

The clock and the backlash move or hold only the modelled angle's smooth part; the noise the
measured path carries into it stays at its own sample, as in the nominal model (a shift or a
hold of the noisy angle would average that noise and be rewarded for smoothing, not for
timing or play: a spurious clock offset of a fraction of a sample on clean logs).

Samples can be held out (weight 0): the simulation still runs through them, so their residual
is a prediction from the path and the trajectory before them (the block cross-validation of
:mod:`calib.tractor_trailer.path_discovery`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from calib.adequacy import EffectKind, EffectParam, EffectSpec
from calib.stats import bartlett_bandwidth, hac_covariance
from calib.tractor_trailer.estimators.drive_path import DrivePath
from calib.tractor_trailer.estimators.path_transient import PathTransientFit

__all__ = [
    "CATALOGUE",
    "JointPathModel",
    "JointSolution",
    "effect_by_key",
]

FloatArray = np.ndarray
PLAY_SMOOTH_S = 0.2
"""Time over which the modelled angle is smoothed to decide the backlash's holds (s)."""

CATALOGUE: tuple[EffectSpec, ...] = (
    EffectSpec(
        "sensor_offset", "psi", EffectKind.SENSOR,
        (EffectParam("offset", "rad", 0.0, -0.5, 0.5, 0.0),),
        "the joint-angle encoder reads a constant amount off (mounting, zeroing)",
        sim_switch="sensor_offset", truth_key="sensor_offset(psi)",
    ),
    EffectSpec(
        "sensor_scale", "psi", EffectKind.SENSOR,
        (EffectParam("scale", "1", 1.0, 0.5, 2.0, 1.0),),
        "the joint-angle encoder's gain is off (a reading proportional to the true angle): at "
        "small angles it trades with L1 + L2 (psi ~ kappa (L1 + L2)); only large angles and "
        "transients tell the two apart",
        confounded_with=("param:L1", "param:L2"), sim_switch="sensor_scale",
        truth_key="sensor_scale(psi)",
    ),
    EffectSpec(
        "backlash", "psi", EffectKind.SENSOR,
        (EffectParam("width", "rad", 0.0, 0.0, 0.3, 0.005),),
        "play in the hitch or its encoder: the reading follows the angle only once it leaves "
        "a dead band of this width (it lags by half the width after a reversal)",
        confounded_with=("clock_offset(hitch)",), truth_key="hitch_dead_band_rad",
    ),
    EffectSpec(
        "clock_offset", "hitch", EffectKind.CLOCK,
        (EffectParam("offset", "s", 0.0, -1.0, 1.0, 0.0),),
        "the joint angle's stamps are late by a constant (transport delay, filtering, clock "
        "offset of the encoder's computer)",
        confounded_with=("backlash(psi)",), sim_switch="clock_offset",
        truth_key="clock_offset(hitch)",
    ),
    EffectSpec(
        "clock_drift", "hitch", EffectKind.CLOCK,
        (EffectParam("drift", "s/s", 0.0, -0.05, 0.05, 0.0),),
        "the joint angle's clock runs at another rate: its stamps drift linearly against the "
        "path's",
        truth_key="clock_drift",
    ),
    EffectSpec(
        "sensor_nonlinearity", "psi", EffectKind.SENSOR,
        (EffectParam("cubic", "1/rad^2", 0.0, -3.0, 3.0, 0.0),),
        "the encoder's reading bends away from the true angle at large angles (y + k y^3)",
        confounded_with=("param:L1",),
    ),
)
"""Every effect the path discovery tries, in the order it tries them."""


def effect_by_key(key: str) -> EffectSpec:
    """The catalogue entry ``id(target)``."""
    for e in CATALOGUE:
        if e.key == key:
            return e
    raise KeyError(key)


def _play(u: FloatArray, w: float, piece: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Backlash of width ``w`` on ``u`` (restarted at each piece): for every sample the index
    of the sample the reading last followed and the direction it was then moving (+1 up, -1
    down, 0 not yet), so that reading = u[idx] - sgn[idx] w / 2."""
    h = 0.5 * w
    n = u.size
    idx = np.empty(n, dtype=np.int64)
    sgn = np.zeros(n)
    uu = u.tolist()
    pc = piece.tolist()
    cur = 0.0
    last = 0
    s = 0.0
    for i in range(n):
        if i == 0 or pc[i] != pc[i - 1]:
            cur, last, s = uu[i], i, 0.0
        else:
            x = uu[i]
            if x > cur + h:
                cur, last, s = x - h, i, 1.0
            elif x < cur - h:
                cur, last, s = x + h, i, -1.0
        idx[i] = last
        sgn[i] = s
    return idx, sgn


@dataclass(frozen=True)
class JointSolution:
    """One joint fit: the parameter vector ``x`` (L1, L2, the effects' parameters in the order
    of ``effects``, then one initial angle per piece), structural covariance ``cov`` of (L1,
    L2, effects) with the initial angles projected out (HAC on the fitted samples), the
    residual at every sample ``residual`` (held-out samples included: their prediction
    error), ``fitted`` the mask of the samples the fit used, ``model`` the modelled reading,
    ``true_psi`` the modelled true angle, ``play_sign`` the backlash direction (zeros without
    backlash), ``cov_fixed`` the (L1, L2) covariance with the effects held at their values."""

    effects: tuple[EffectSpec, ...]
    x: FloatArray
    cov: FloatArray
    cov_fixed: FloatArray
    residual: FloatArray
    fitted: np.ndarray
    model: FloatArray
    true_psi: FloatArray
    play_sign: FloatArray
    converged: bool

    @property
    def n_effect_params(self) -> int:
        return sum(len(e.params) for e in self.effects)

    def effect_values(self) -> dict[str, dict[str, tuple[float, float]]]:
        """By effect key, parameter -> (value, std)."""
        out: dict[str, dict[str, tuple[float, float]]] = {}
        k = 2
        for e in self.effects:
            pars = {}
            for p in e.params:
                sd = math.sqrt(self.cov[k, k]) if self.cov[k, k] >= 0 else math.nan
                pars[p.name] = (float(self.x[k]), sd)
                k += 1
            out[e.key] = pars
        return out


class JointPathModel:
    """(L1, L2) along a measured path plus joint-angle effects, fitted jointly.

    Args:
        path, t_psi, psi, gaps: as :meth:`PathTransientFit.fit`.
        max_samples: joint-angle samples kept at most (evenly decimated beyond: the path is
            still integrated in full).
    """

    def __init__(
        self, path: DrivePath, t_psi: FloatArray, psi: FloatArray,
        gaps: Sequence[tuple[float, float]] = (), *, max_samples: int = 12000,
        bounds_L1_m: tuple[float, float] = (-20.0, 50.0),
        bounds_L2_m: tuple[float, float] = (0.02, 50.0),
    ) -> None:
        t = np.asarray(t_psi, dtype=float)
        p = np.asarray(psi, dtype=float)
        ok = np.isfinite(t) & np.isfinite(p)
        t, p = t[ok], p[ok]
        if t.size > max_samples:
            keep = np.unique(np.round(np.linspace(0, t.size - 1, max_samples)).astype(np.int64))
            t, p = t[keep], p[keep]
        base = PathTransientFit(resolution_check=False, bounds_L1_m=bounds_L1_m,
                                bounds_L2_m=bounds_L2_m)
        base._prepare(path, t, p, list(gaps))
        self._base = base
        self.path = path
        self.t: FloatArray = base._t
        self.p: FloatArray = base._p
        self.piece: np.ndarray = base._piece
        self.n_pieces = base.n_pieces_
        self.bounds = (bounds_L1_m, bounds_L2_m)
        first = np.searchsorted(self.piece, np.arange(self.n_pieces))
        self.first_idx = first
        self.psi0_guess = np.array([float(np.mean(self.p[i : i + 3])) for i in first])
        self.t_ref = float(self.t[0])
        # per-piece time derivative helpers
        self._piece_lo = first
        self._piece_hi = np.r_[first[1:], self.t.size]

    # ------------------------------------------------------------------ model
    def _shifted(self, tau: FloatArray, cols: list[FloatArray]) -> list[FloatArray]:
        """Each column (a function sampled at ``self.t``) at the shifted times ``tau``, per
        piece (held at a piece's ends)."""
        out = [np.empty_like(c) for c in cols]
        for a, b in zip(self._piece_lo, self._piece_hi, strict=True):
            tp = self.t[a:b]
            for o, c in zip(out, cols, strict=True):
                o[a:b] = np.interp(tau[a:b], tp, c[a:b])
        return out

    def _shifted_smooth(self, tau: FloatArray, cols: list[FloatArray]) -> list[FloatArray]:
        """Each column moved to the times ``tau`` through its smooth part only, and the smooth
        rate of the first column at ``tau`` (last in the list).

        A column is the modelled angle (or its derivative), which carries the noise of the
        measured path sample by sample. Interpolating it between samples would average that
        noise (a shift of half a sample halves its variance) and so reward a clock offset for
        smoothing the model rather than for timing: on a clean log with a noisy pose, a
        spurious offset of a fraction of a sample. So the column's smooth part (averaged over
        ``PLAY_SMOOTH_S``) is shifted and the rest stays at its own sample:
        c + (smooth(c)(tau) - smooth(c)(t)), unit gain on the path's noise as in the nominal
        model."""
        smooth = [self._smooth(c) for c in cols]
        rate = self._rate(smooth[0])
        moved = self._shifted(tau, [*smooth, rate])
        out = [c + (m - sm) for c, m, sm in zip(cols, moved[:-1], smooth, strict=True)]
        return [*out, moved[-1]]

    def _smooth(self, u: FloatArray) -> FloatArray:
        """``u`` averaged over ``PLAY_SMOOTH_S`` within each piece."""
        out = u.copy()
        for a, b in zip(self._piece_lo, self._piece_hi, strict=True):
            n = b - a
            if n < 3:
                continue
            dt = float(np.median(np.diff(self.t[a:b])))
            k = int(min(n, max(1, round(PLAY_SMOOTH_S / dt)))) if dt > 0 else 1
            k -= 1 - k % 2
            if k < 3:
                continue
            c = np.concatenate([[0.0], np.cumsum(u[a:b])])
            h = k // 2
            i = np.arange(n)
            lo, hi = np.clip(i - h, 0, n), np.clip(i + h + 1, 0, n)
            out[a:b] = (c[hi] - c[lo]) / (hi - lo)
        return out

    def _rate(self, u: FloatArray) -> FloatArray:
        d = np.zeros_like(u)
        for a, b in zip(self._piece_lo, self._piece_hi, strict=True):
            if b - a >= 2:
                d[a:b] = np.gradient(u[a:b], self.t[a:b])
        return d

    def evaluate(
        self, x: FloatArray, effects: tuple[EffectSpec, ...]
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        """Modelled reading, Jacobian of the reading to the structural parameters (L1, L2,
        effects: columns), the derivative to each sample's piece's initial angle, the true
        modelled angle and the backlash direction."""
        n_e = sum(len(e.params) for e in effects)
        q = 2 + n_e
        u, d0, d1, d2 = self._base._simulate_jacobian(float(x[0]), float(x[1]), x[q:])
        vals = {e.id: x[2 + i] for i, e in enumerate(effects)}  # one parameter each
        cols: dict[str, FloatArray] = {}
        true_u = u
        if "clock_offset" in vals or "clock_drift" in vals:
            c = float(vals.get("clock_offset", 0.0))
            d = float(vals.get("clock_drift", 0.0))
            tau = self.t - c - d * (self.t - self.t_ref)
            u, d0, d1, d2, rate = self._shifted_smooth(tau, [u, d0, d1, d2])
            true_u = u
            if "clock_offset" in vals:
                cols["clock_offset"] = -rate
            if "clock_drift" in vals:
                cols["clock_drift"] = -rate * (self.t - self.t_ref)
        sgn = np.zeros_like(u)
        y = u
        if "backlash" in vals:
            # the dead band acts on the true angle, which is smooth; the modelled one carries
            # the path's noise, which a dead band on it would filter (and so be mistaken for
            # play): holds are decided on the angle smoothed over PLAY_SMOOTH_S
            w = float(vals["backlash"])
            us, d0s, d1s, d2s = (self._smooth(c) for c in (u, d0, d1, d2))
            idx, sgn = _play(us, w, self.piece)
            hold = idx != np.arange(u.size)

            def held(c: FloatArray, cs: FloatArray) -> FloatArray:
                # the hold acts on the smooth part; the path's noise stays at its own sample
                # (holding it would smooth the model and reward play that is not there)
                return c + np.where(hold, cs[idx] - cs, 0.0)

            y = held(u, us) - sgn * 0.5 * w
            d0, d1, d2 = held(d0, d0s), held(d1, d1s), held(d2, d2s)
            cols = {k: held(v, self._smooth(v)) for k, v in cols.items()}
            cols["backlash"] = -0.5 * sgn
        if "sensor_nonlinearity" in vals:
            k3 = float(vals["sensor_nonlinearity"])
            g = 1.0 + 3.0 * k3 * y * y
            d0, d1, d2 = d0 * g, d1 * g, d2 * g
            cols = {k: v * g for k, v in cols.items()}
            cols["sensor_nonlinearity"] = y**3
            y = y + k3 * y**3
        if "sensor_scale" in vals:
            s = float(vals["sensor_scale"])
            d0, d1, d2 = d0 * s, d1 * s, d2 * s
            cols = {k: v * s for k, v in cols.items()}
            cols["sensor_scale"] = y.copy()
            y = s * y
        if "sensor_offset" in vals:
            cols["sensor_offset"] = np.ones_like(y)
            y = y + float(vals["sensor_offset"])
        J = np.empty((y.size, q))
        J[:, 0] = d1
        J[:, 1] = d2
        for i, e in enumerate(effects):
            J[:, 2 + i] = cols[e.id]
        return y, J, d0, true_u, sgn

    # ------------------------------------------------------------------ fit
    def _projected(self, J: FloatArray, d0: FloatArray, w: FloatArray) -> FloatArray:
        Js = J * w[:, None]
        c0 = d0 * w
        cc = np.bincount(self.piece, weights=c0 * c0, minlength=self.n_pieces)
        out = Js.copy()
        for j in range(J.shape[1]):
            cj = np.bincount(self.piece, weights=c0 * Js[:, j], minlength=self.n_pieces)
            out[:, j] -= c0 * np.where(cc > 0, cj / np.where(cc > 0, cc, 1.0), 0.0)[self.piece]
        return out

    def fit(
        self,
        effects: tuple[EffectSpec, ...],
        x0: FloatArray | None = None,
        *,
        held_out: np.ndarray | None = None,
        max_nfev: int = 60,
        data: FloatArray | None = None,
    ) -> JointSolution:
        """Fit (L1, L2, the ``effects``' parameters, initial angles) by least squares on the
        samples not ``held_out``; start from ``x0`` (same layout) or the catalogue's inits.
        ``data``: other joint-angle values at the same samples (e.g. rescaled)."""
        p = self.p if data is None else np.asarray(data, dtype=float)
        if any(len(e.params) != 1 for e in effects):  # pragma: no cover - catalogue invariant
            raise ValueError("each effect of the path catalogue has one parameter")
        n_e = len(effects)
        q = 2 + n_e
        P = self.n_pieces
        lo = np.concatenate([[self.bounds[0][0], self.bounds[1][0]],
                             [e.params[0].lower for e in effects], np.full(P, -math.pi)])
        hi = np.concatenate([[self.bounds[0][1], self.bounds[1][1]],
                             [e.params[0].upper for e in effects], np.full(P, math.pi)])
        if x0 is None:
            x0 = np.concatenate([[1.0, 2.0], [e.params[0].init for e in effects],
                                 self.psi0_guess])
        x0 = np.clip(np.asarray(x0, dtype=float), lo + 1e-6 * (hi - lo), hi - 1e-6 * (hi - lo))
        w = np.ones(self.t.size) if held_out is None else (~held_out).astype(float)
        rows = np.arange(self.t.size)
        cache: dict[bytes, tuple[FloatArray, FloatArray]] = {}

        def both(x: FloatArray) -> tuple[FloatArray, FloatArray]:
            key = x.tobytes()
            if key not in cache:
                y, J, d0, _, _ = self.evaluate(x, effects)
                r = (p - y) * w
                full = np.zeros((rows.size, q + P))
                full[:, :q] = -J * w[:, None]
                full[rows, q + self.piece] = -d0 * w
                r = np.where(np.isfinite(r), r, 1e3)
                full = np.where(np.isfinite(full), full, 0.0)
                # least_squares sees the R factor of [J r]: the same sum of squares, J^T J and
                # J^T r in q + P + 1 rows (its trust-region steps factor a small matrix)
                R: FloatArray = np.asarray(np.linalg.qr(np.column_stack([full, r]), mode="r"))
                cache.clear()
                cache[key] = (R[:, -1].copy(), R[:, :-1].copy())
            return cache[key]

        sol = least_squares(lambda x: both(x)[0], x0, jac=lambda x: both(x)[1],
                            bounds=(lo, hi), method="trf", x_scale="jac", xtol=1e-9,
                            ftol=1e-10, gtol=1e-10, max_nfev=max_nfev)
        x = np.asarray(sol.x)
        y, J, d0, true_u, sgn = self.evaluate(x, effects)
        r = p - y
        fitted = w > 0
        Js = self._projected(J, d0, w)[fitted]
        rf = r[fitted]
        bw = bartlett_bandwidth(rf)
        dof = max(rf.size - q, 1) / max(rf.size - q - P, 1)
        cov = hac_covariance(Js, rf, bw) * dof
        cov_fixed = hac_covariance(Js[:, :2], rf, bw) * dof
        return JointSolution(tuple(effects), x, cov, cov_fixed, r, fitted, y, true_u, sgn,
                             bool(sol.success))

    def corrected(
        self, sol: JointSolution, *, drop_holds: bool = False
    ) -> tuple[FloatArray, FloatArray]:
        """The joint-angle samples with the fitted effects undone: (stamps on the path's
        clock, the true angle the readings imply), for a fit of the nominal model.

        ``drop_holds``: with backlash, leave out the samples where the reading holds inside
        the dead band (while at least half the samples remain): the reading there says only
        that the angle is somewhere within the band, and adding half the width to it biases
        the link lengths (the path still drives the model through the samples left out)."""
        vals = {e.id: float(sol.x[2 + i]) for i, e in enumerate(sol.effects)}
        t = self.t - vals.get("clock_offset", 0.0) - vals.get("clock_drift", 0.0) * (
            self.t - self.t_ref)
        z = (self.p - vals.get("sensor_offset", 0.0)) / vals.get("sensor_scale", 1.0)
        k3 = vals.get("sensor_nonlinearity", 0.0)
        if k3:
            y = z.copy()
            for _ in range(4):  # Newton on y + k y^3 = z
                y -= (y + k3 * y**3 - z) / (1.0 + 3.0 * k3 * y * y)
            z = y
        if "backlash" in vals:
            z = z + 0.5 * vals["backlash"] * sol.play_sign
            if not drop_holds:
                return t, z
            idx, _ = _play(self._smooth(sol.true_psi), vals["backlash"], self.piece)
            follows = idx == np.arange(z.size)
            if follows.sum() >= 0.5 * z.size:
                return t[follows], z[follows]
        return t, z
