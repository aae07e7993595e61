"""Refit-aware effect size of a kind: the part of its effect on the *modelled* channels that the
nominal model cannot absorb by refitting its own parameters (computed with the generator only).

The raw ``robotlog.effect_size`` compares the recording with the kind to the one without it.
That overstates what any calibration can see: a radius change mid-drive moves the pose by
metres, but a refit of the radii takes most of it. Here, for one log:

1. Modelled channels ``y`` (noise-free: each ``Stream.expected``, so the noise draws, shared by
   every regeneration, cancel exactly, quantisation included), evaluated with the clean log's
   true parameters theta0 as the model's:

   - tractor-trailer: the hitch angle psi at its stamps (the kinematic model's output);
   - diff drive: per 0.5 s window of the wheel samples, the heading increment (pose yaw change
     minus the wheels' prediction (r_R dphi_R - r_L dphi_L) / b) and the along-track
     displacement (pose displacement minus the dead-reckoned arc from the window start,
     projected on the mean pose heading): the residuals logcal's diff-drive adequacy judges;
   - arm: per joint, the recorded effort minus the inverse dynamics of theta0 at the recorded
     (sensor-side, noise-free) q, qd and qdd = d qd / dt (so ``joint_compliance``, which moves
     the measured q rather than the torque, counts).

   Each channel is divided by its noise std (psi: the hitch encoder's; diff drive: the pose
   noise at both window ends after interpolation onto the wheel instants plus the wheel
   quantisation of both ends, mean variance over windows; arm: the effort noise).

2. ``Delta = y(log with the kind) - y(clean log)`` (the clean one interpolated onto the other's
   stamps if the kind moved them: ``clock_drift``).

3. Sensitivities ``S[:, k] = (y(clean, theta0 + h_k e_k) - y(clean, theta0)) / h_k`` by
   regenerating the clean log (same draws, same inputs) with one parameter shifted
   (``PARAMETERS``: tractor L1, L2, initial hitch angle; diff drive r_R, r_L, b; arm m, cx, cy,
   I per link, Fc, Fv and an armature Ia per joint -- logcal's arm model fits Ia).

4. ``beta* = argmin |Delta - S beta|`` (all channels jointly, each in noise units, least
   squares), iterated: every step regenerates the clean log *at* theta0 + beta and is kept
   only if the actual residual falls (halved twice otherwise, then the fit stops), with S
   recomputed at each kept point (Gauss-Newton; the arm: chord steps, see ``NEWTON``), at most
   ``MAX_ITER`` steps. So the reported residual is one a refit actually reaches, not a
   linearisation. ``refit effect`` per channel = RMS(y(kind) - y(clean, theta0 + beta*)) /
   noise.

5. Held-out flavour: the time span is cut into ``BLOCKS`` equal blocks, alternately in fold 0
   and fold 1; the same fit, started from beta*, on one fold's samples only predicts the other
   fold's, and ``held-out effect`` per channel = RMS of those predictions' errors / noise (both
   folds, each sample held out once; chord steps with the sensitivities at beta*, at most
   ``HELD_ITER``; the tractor's initial hitch angle stays at beta*'s, see ``HELD_FIXED``).

A clean log has both effects exactly 0. A mid-log parameter change (``trailer_swap``,
``radius_change``, ``payload_pickup``) is seen against the one constant parameter set of the
nominal model, which is what the projection measures.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .arm import ArmParams, inverse_dynamics
from .robotlog import FloatArray, RobotLog

__all__ = ["BLOCKS", "MAX_ITER", "PARAMETERS", "Channel", "modelled_channels", "refit_effect"]

WINDOW_S = 0.5
"""Window (s) of the diff drive's increment channels (as logcal's diff-drive adequacy)."""
BLOCKS = 8
"""Time blocks of the held-out flavour (alternating folds: 4 blocks per fold)."""
MAX_ITER = 4
"""Chord iterations (regenerations at theta0 + beta) after the first linear solve."""
_TOL = 1e-2
"""Stop when the predicted change of the residual is below this (noise units, RMS)."""
HELD_FIXED = {"tractor_trailer": ("psi0",)}
"""Nuisance parameters the held-out fold fits keep at the whole-log value: the tractor's
initial hitch angle only shows in the first seconds (its transient), so a fold without them
would move it freely and ruin the other fold's start (logcal never holds out a piece's first
samples for the same reason)."""
HELD_ITER = 2
"""Steps of each held-out fold fit (chord steps from the whole-log fit, with its
sensitivities)."""
NEWTON = {"tractor_trailer": True, "diff_drive": True, "arm": False}
"""Gauss-Newton (sensitivities recomputed at each accepted step: the tractor's and the diff
drive's channels are nonlinear in their parameters) or chord steps (the arm's torque is linear
in its base parameters, so the sensitivities at theta0 span the right space)."""


def _rel(rel: float, floor: float = 0.0) -> Callable[[float], float]:
    return lambda v: rel * max(abs(v), floor)


PARAMETERS: dict[str, dict[str, tuple[str, Callable[[float], float]]]] = {
    # name -> (truth key of the base value or "" for 0, step from the base value)
    "tractor_trailer": {
        "L1": ("L1", _rel(1e-3, 0.1)),
        "L2": ("L2", _rel(1e-3, 0.1)),
        "psi0": ("", lambda _: 1e-3),
    },
    "diff_drive": {"r_R": ("r_R", _rel(1e-3)), "r_L": ("r_L", _rel(1e-3)), "b": ("b", _rel(1e-3))},
    "arm": {
        "m1": ("m1", _rel(1e-3)),
        "m2": ("m2", _rel(1e-3)),
        "cx1": ("l1", _rel(1e-3)),
        "cy1": ("l1", _rel(1e-3)),
        "cx2": ("l2", _rel(1e-3)),
        "cy2": ("l2", _rel(1e-3)),
        "I1": ("I1", _rel(1e-3)),
        "I2": ("I2", _rel(1e-3)),
        "Fc1": ("", lambda _: 1e-2),
        "Fc2": ("", lambda _: 1e-2),
        "Fv1": ("", lambda _: 1e-2),
        "Fv2": ("", lambda _: 1e-2),
        "Ia1": ("I1", _rel(1e-2)),
        "Ia2": ("I2", _rel(1e-2)),
    },
}
"""The nominal model's parameters per robot, perturbed one at a time for the sensitivities."""


@dataclass(frozen=True)
class Channel:
    """One modelled channel: ``t`` (s, its samples' instants), ``values`` (noise-free),
    ``noise`` (std of its recorded error)."""

    name: str
    t: FloatArray
    values: FloatArray
    noise: float


# ------------------------------------------------------------------ modelled channels
def _tractor(log: RobotLog, ref: RobotLog) -> list[Channel]:
    s = log.streams.get("/hitch/angle")
    if s is None or "angle" not in s.expected or s.stamps_ns.size < 2:
        return []
    t = (s.stamps_ns - log.start_ns) / 1e9
    return [Channel("psi", t, s.expected["angle"], float(s.noise_std.get("angle", 0.0)))]


def _interp_weights(t: FloatArray, grid_t: FloatArray) -> FloatArray:
    """w^2 + (1 - w)^2 of linear interpolation at ``t`` on ``grid_t`` (1 outside)."""
    j = np.clip(np.searchsorted(grid_t, t, side="right") - 1, 0, grid_t.size - 2)
    w = np.clip((t - grid_t[j]) / (grid_t[j + 1] - grid_t[j]), 0.0, 1.0)
    return np.asarray(w * w + (1 - w) ** 2, dtype=float)


def _diff_drive(log: RobotLog, ref: RobotLog) -> list[Channel]:
    w, p = log.streams["/wheels"], log.streams["/pose"]
    tw, tp = w.t_true, p.t_true
    prm = ref.truth["params"]
    rR, rL, b = float(prm["r_R"]), float(prm["r_L"]), float(prm["b"])
    R, L = w.expected["right"], w.expected["left"]
    yaw = np.interp(tw, tp, p.expected["yaw"])
    x, y = np.interp(tw, tp, p.expected["x"]), np.interp(tw, tp, p.expected["y"])
    edges = np.arange(tw[0], tw[-1] + 1e-9, WINDOW_S)
    idx = np.unique(np.searchsorted(tw, edges))
    if idx[-1] != tw.size - 1:
        idx = np.append(idx, tw.size - 1)
    a, e = idx[:-1], idx[1:]
    keep = e > a
    a, e = a[keep], e[keep]
    dr, dl = np.diff(R), np.diff(L)
    dth = (rR * dr - rL * dl) / b
    h = np.concatenate([[0.0], np.cumsum(dth)])
    mid = h[:-1] + 0.5 * dth
    step = 0.5 * (rR * dr + rL * dl) * np.sinc(dth / (2 * np.pi)) * np.exp(1j * mid)
    cum = np.concatenate([[0.0], np.cumsum(step)])
    heading = (yaw[e] - yaw[a]) - (h[e] - h[a])
    pred = np.exp(1j * (yaw[a] - h[a])) * (cum[e] - cum[a])
    disp = (x[e] - x[a]) + 1j * (y[e] - y[a])
    u = np.exp(0.5j * (yaw[a] + yaw[e]))
    along = ((disp - pred) * np.conj(u)).real
    c = _interp_weights(tw, tp)
    cw = c[a] + c[e]
    q2 = 2 * float(w.noise_std["left"]) ** 2
    var_h = float(p.noise_std["yaw"]) ** 2 * cw + (rR**2 + rL**2) / b**2 * q2
    var_a = float(p.noise_std["x"]) ** 2 * cw + (rR**2 + rL**2) / 4 * q2
    tm = 0.5 * (tw[a] + tw[e])
    return [
        Channel("heading increment", tm, heading, math.sqrt(float(np.mean(var_h)))),
        Channel("along-track displacement", tm, along, math.sqrt(float(np.mean(var_a)))),
    ]


def _arm_params(truth: dict[str, Any]) -> ArmParams:
    arm = dict(truth["arm"])
    arm["Fc"], arm["Fv"] = tuple(arm["Fc"]), tuple(arm["Fv"])
    return ArmParams(**arm)


def _arm(log: RobotLog, ref: RobotLog) -> list[Channel]:
    s = log.streams["/joint_states"]
    t = s.t_true
    q, qd, eff = s.expected["position"], s.expected["velocity"], s.expected["effort"]
    qdd = np.gradient(qd, t, axis=0)
    ia = np.asarray(ref.truth.get("armature", [0.0, 0.0]), dtype=float)
    res = eff - inverse_dynamics(_arm_params(ref.truth), q, qd, qdd) - ia * qdd
    sd = float(s.noise_std["effort"])
    return [Channel(f"tau[{j}]", t, res[:, j], sd) for j in range(res.shape[1])]


_CHANNELS: dict[str, Callable[[RobotLog, RobotLog], list[Channel]]] = {
    "tractor_trailer": _tractor,
    "diff_drive": _diff_drive,
    "arm": _arm,
}


def modelled_channels(log: RobotLog, ref: RobotLog) -> list[Channel]:
    """The modelled channels of ``log`` with ``ref``'s true parameters as the model's (see the
    module docstring)."""
    return _CHANNELS[log.robot](log, ref)


# ------------------------------------------------------------------ projection
def _on(src: Channel, target: Channel) -> FloatArray:
    """``src``'s values at ``target``'s instants (the same instants: unchanged)."""
    if src.t.size == target.t.size and np.array_equal(src.t, target.t):
        return src.values
    order = np.argsort(src.t, kind="stable")
    return np.asarray(np.interp(target.t, src.t[order], src.values[order]), dtype=float)


def _vector(chs: list[Channel], target: list[Channel]) -> FloatArray:
    """``chs`` on ``target``'s instants, each in ``target``'s noise units, stacked."""
    by = {c.name: c for c in chs}
    return np.concatenate([_on(by[c.name], c) / max(c.noise, 1e-12) for c in target])


def _solve(S: FloatArray, r: FloatArray) -> FloatArray:
    """argmin |r - S beta| (columns scaled to unit norm, minimum norm, tiny singular values
    dropped)."""
    n = np.linalg.norm(S, axis=0)
    n = np.where(n > 0, n, 1.0)
    return np.asarray(np.linalg.lstsq(S / n, r, rcond=1e-10)[0] / n, dtype=float)


def _rms_per(r: FloatArray, sizes: list[int], names: list[str]) -> dict[str, float]:
    out, i = {}, 0
    for name, k in zip(names, sizes, strict=True):
        seg = r[i : i + k]
        out[name] = float(np.sqrt(np.mean(seg * seg))) if k else 0.0
        i += k
    return out


class _Problem:
    """The regenerations of one log's clean twin at theta0 + beta, on ``target``'s instants."""

    def __init__(
        self,
        gen: Callable[..., RobotLog],
        seed: int,
        clean: RobotLog,
        target: list[Channel],
        kw: dict[str, Any],
    ) -> None:
        self.gen, self.seed, self.clean, self.target, self.kw = gen, seed, clean, target, kw
        spec = PARAMETERS[clean.robot]
        base = {**clean.truth, **clean.truth.get("arm", {})}
        self.names = list(spec)
        self.steps = np.array(
            [spec[k][1](float(base[spec[k][0]]) if spec[k][0] else 0.0) for k in self.names]
        )
        self.y_kind = _vector(target, target)
        self.generated = 0

    def y(self, beta: FloatArray) -> FloatArray:
        """The modelled channels of the clean twin regenerated at theta0 + beta."""
        if not np.any(beta):
            return _vector(modelled_channels(self.clean, self.clean), self.target)
        self.generated += 1
        log = self.gen(
            self.seed,
            None,
            0.0,
            perturb=dict(zip(self.names, beta.tolist(), strict=True)),
            **self.kw,
        )
        return _vector(modelled_channels(log, self.clean), self.target)

    def residual(self, beta: FloatArray) -> FloatArray | None:
        """y(kind) - y(theta0 + beta) (None if the generator fails there)."""
        try:
            r = self.y_kind - self.y(beta)
        except (ValueError, RuntimeError, ZeroDivisionError, FloatingPointError):
            return None
        return r if np.all(np.isfinite(r)) else None

    def sensitivities(self, beta: FloatArray, y_beta: FloatArray) -> FloatArray:
        """Forward differences of y at theta0 + beta (``y_beta``), one column per parameter."""
        cols = []
        for k, h in enumerate(self.steps):
            b = beta.copy()
            b[k] += h
            cols.append((self.y(b) - y_beta) / h)
        return np.column_stack(cols)


def _fit(
    pb: _Problem,
    rows: NDArray[np.bool_],
    beta: FloatArray,
    r: FloatArray,
    S: FloatArray,
    max_iter: int,
    newton: bool,
    free: NDArray[np.bool_] | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray, int]:
    """Minimise the residual on ``rows`` over the ``free`` parameters (default: all) from
    ``beta`` (residual ``r``, sensitivities ``S`` there): Gauss-Newton (``newton``: S recomputed
    at each accepted point) or chord steps, each checked by a regeneration (a step that does
    not lower the residual is halved twice, then the fit stops). Returns (beta, residual at
    beta on every row, S, steps taken)."""
    free = np.ones(beta.size, dtype=bool) if free is None else free
    it = 0
    for _ in range(max_iter):
        d = np.zeros(beta.size)
        d[free] = _solve(S[rows][:, free], r[rows])
        if float(np.sqrt(np.mean((S[rows] @ d) ** 2))) < _TOL:
            break
        for shrink in (1.0, 0.5, 0.25):
            cand = beta + shrink * d
            r_new = pb.residual(cand)
            if r_new is not None and np.mean(r_new[rows] ** 2) < np.mean(r[rows] ** 2):
                break
        else:
            break
        beta, r = cand, r_new
        it += 1
        if newton:
            S = pb.sensitivities(beta, pb.y_kind - r)
    return beta, r, S, it


def refit_effect(
    gen: Callable[..., RobotLog],
    seed: int,
    log: RobotLog,
    clean: RobotLog,
    *,
    blocks: int = BLOCKS,
    max_iter: int = MAX_ITER,
    **kw: Any,
) -> dict[str, Any]:
    """The refit and held-out effect sizes of ``log`` (a ``gen(seed, kind, magnitude, **kw)``
    log) against ``clean`` (``gen(seed, None, 0.0, **kw)``); see the module docstring.

    Returns ``refit`` and ``heldout`` ({channel: effect}), ``beta`` (the refit's parameter
    shifts), ``iterations`` (accepted steps of the whole-log fit), ``generated`` (logs
    regenerated) and ``seconds``.
    """
    t0 = time.perf_counter()
    target = modelled_channels(log, clean)
    names = [c.name for c in target]
    sizes = [c.t.size for c in target]
    out: dict[str, Any] = {
        "refit": dict.fromkeys(names, 0.0),
        "heldout": dict.fromkeys(names, 0.0),
        "beta": {},
        "iterations": 0,
        "generated": 0,
        "seconds": 0.0,
    }
    if not target:
        return out
    pb = _Problem(gen, seed, clean, target, kw)
    zero = np.zeros(len(pb.names))
    y0 = pb.y(zero)
    delta = pb.y_kind - y0
    if not np.any(delta):
        out["seconds"] = time.perf_counter() - t0
        return out
    newton = NEWTON[log.robot]
    S0 = pb.sensitivities(zero, y0)
    every = np.ones(delta.size, dtype=bool)
    beta, r, S, it = _fit(pb, every, zero, delta, S0, max_iter, newton)
    out["refit"] = _rms_per(r, sizes, names)

    tb = np.concatenate([c.t for c in target])
    edges = np.linspace(float(tb.min()), float(tb.max()), blocks + 1)
    fold = np.clip(np.searchsorted(edges, tb, side="right") - 1, 0, blocks - 1) % 2
    held = np.empty_like(r)
    free = np.array([k not in HELD_FIXED.get(log.robot, ()) for k in pb.names])
    for f in (0, 1):
        test = fold == f
        _, r_f, _, _ = _fit(pb, ~test, beta, r, S, HELD_ITER, False, free)
        held[test] = r_f[test]
    out["heldout"] = _rms_per(held, sizes, names)
    out["beta"] = dict(zip(pb.names, beta.tolist(), strict=True))
    out["iterations"] = it
    out["generated"] = pb.generated
    out["seconds"] = time.perf_counter() - t0
    return out
