"""The tractor-trailer's catalogue of joint-angle effects for discovery along the measured path,
and the joint fit of (L1, L2, one initial angle per piece) with any set of them.

The kinematics are integrated along link 1's measured path
(``calib.tractor_trailer.models.hitch_path`` through
the layout of :class:`calib.tractor_trailer.estimators.path_transient.PathTransientFit`); the
effects act only
on how the true angle becomes the recorded one. Each effect owns how it does so: its catalogue
entry's ``model`` is a :class:`PathEffectModel` (a stamp shift, a change of the reading with its
Jacobian column, and its undoing), which :meth:`JointPathModel.evaluate` applies in the hooks'
``order`` without knowing which effect it is; a new effect is one entry passed to
:func:`register_effect`. The built-in ones, in their order:

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
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace
from typing import Any, Protocol

import numpy as np
from scipy.optimize import least_squares

from calib.discovery import EffectKind, EffectParam, EffectRegistry, EffectSpec
from calib.stats import bartlett_bandwidth, hac_covariance
from calib.tractor_trailer.estimators.drive_path import DrivePath
from calib.tractor_trailer.estimators.path_transient import PathTransientFit

__all__ = [
    "CATALOGUE",
    "GAIN_TOLERANCE",
    "JointPathModel",
    "JointSolution",
    "PathEffectModel",
    "PathState",
    "Tolerance",
    "Undone",
    "catalogue",
    "effect_by_key",
    "register_effect",
    "unregister_effect",
]

FloatArray = np.ndarray
PLAY_SMOOTH_S = 0.2
"""Time over which the modelled angle is smoothed to decide the backlash's holds (s)."""
FILL_SPACING_S = 0.0
"""Default ``fill_spacing_s`` of :class:`JointPathModel` (0: every path knot is integrated; the
answers of the full grid)."""
EVAL_CACHE = 4
"""Evaluations of the model kept by :meth:`JointPathModel.evaluate` (a few: a fit's optimiser
revisits only the points it accepted, and the held-out folds start where the full fit ended)."""


@dataclass(frozen=True)
class PathState:
    """The modelled joint-angle reading part-way through the effects' chain.

    ``y``: the reading so far; ``d0``, ``d1``, ``d2``: its derivatives to the piece's initial
    angle, L1 and L2; ``cols``: by effect key, the derivative of ``y`` to each effect applied
    so far (a hook that changes ``y`` carries these through its change, as it does ``d0`` to
    ``d2``); ``true_u``: the modelled true angle (after any stamp shift); ``sgn``: the
    backlash direction (zeros without backlash); ``model``: the :class:`JointPathModel`, for
    its per-piece helpers (``_smooth``, ``_rate``, ``piece``, ``t``)."""

    model: JointPathModel
    y: FloatArray
    d0: FloatArray
    d1: FloatArray
    d2: FloatArray
    cols: dict[str, FloatArray]
    true_u: FloatArray
    sgn: FloatArray

    def scaled(self, g: FloatArray | float, **changes: Any) -> PathState:
        """Every derivative (``d0`` to ``d2`` and the effects' columns) multiplied by the
        local slope ``g`` of a pointwise change of the reading, with ``changes`` applied."""
        return replace(
            self,
            d0=self.d0 * g,
            d1=self.d1 * g,
            d2=self.d2 * g,
            cols={k: v * g for k, v in self.cols.items()},
            **changes,
        )


@dataclass(frozen=True)
class Undone:
    """The joint-angle samples part-way through undoing the effects (last effect first).

    ``t``: stamps on the path's clock; ``z``: the reading with the later effects undone;
    ``keep``: the samples kept (None: all); ``drop_holds``: whether a hook may leave out
    samples whose reading says little of the true angle; ``model``, ``sol``: the model and
    the joint fit being undone (its backlash direction and modelled true angle)."""

    model: JointPathModel
    sol: JointSolution
    t: FloatArray
    z: FloatArray
    keep: np.ndarray | None
    drop_holds: bool


@dataclass(frozen=True)
class Tolerance:
    """An effect the nominal model assumes at its null without the log checking it: within
    ``within`` of the null, the log may not tell it from the link lengths, and the discovery
    spans them over the values it cannot exclude. ``quantity`` names what it changes and
    ``error`` the error, for the report ("the joint angle's gain", "a gain error")."""

    within: float
    quantity: str
    error: str


class PathEffectModel(Protocol):
    """How one effect changes the modelled joint-angle reading along the path (the ``model``
    hook of a path :class:`~calib.adequacy.EffectSpec`; one parameter per effect).

    An effect shifts the joint angle's stamps (``stamp_shift``: all shifts are summed into one
    move of the modelled angle, before any reading change) or changes the reading (``apply``,
    in ``order``); ``undo`` takes its reading change out of recorded samples. The defaults
    (for subclasses) shift nothing, change nothing and undo nothing."""

    order: int
    """Position in the chain: reading changes apply in increasing order (undone in
    decreasing); stamp shifts are summed in increasing order."""
    tolerated: Tolerance | None = None
    """Set for an effect the nominal model leaves unchecked near its null (a gain)."""

    def stamp_shift(self, t_rel: FloatArray, value: float) -> tuple[FloatArray, FloatArray] | None:
        """How late the joint angle is stamped at ``t_rel`` (s since its first sample) and the
        derivative of that to ``value``; None: the effect does not touch the stamps."""
        return None

    def apply(self, state: PathState, value: float) -> tuple[PathState, FloatArray]:
        """The state after this effect's change of the reading (the earlier effects' columns
        carried through it) and its own column: the derivative of the new reading to
        ``value``. Not called for an effect that shifts the stamps (default: no change)."""
        return state, np.zeros_like(state.y)

    def undo(self, state: Undone, value: float) -> Undone:
        """``state`` with this effect's change of the reading taken out."""
        return state


@dataclass(frozen=True)
class StampOffset(PathEffectModel):
    """The joint angle stamped late by a constant ``c`` (s)."""

    order: int = 0

    def stamp_shift(self, t_rel: FloatArray, value: float) -> tuple[FloatArray, FloatArray]:
        return np.full_like(t_rel, value), np.ones_like(t_rel)


@dataclass(frozen=True)
class StampDrift(PathEffectModel):
    """The joint angle's stamps drifting by ``d`` (s/s) from its first sample."""

    order: int = 1

    def stamp_shift(self, t_rel: FloatArray, value: float) -> tuple[FloatArray, FloatArray]:
        return value * t_rel, t_rel


@dataclass(frozen=True)
class Backlash(PathEffectModel):
    """A dead band of width ``w`` (rad) between the true angle and the reading."""

    order: int = 10

    def apply(self, state: PathState, value: float) -> tuple[PathState, FloatArray]:
        # the dead band acts on the true angle, which is smooth; the modelled one carries
        # the path's noise, which a dead band on it would filter (and so be mistaken for
        # play): holds are decided on the angle smoothed over PLAY_SMOOTH_S
        m, w, u = state.model, value, state.y
        us, d0s, d1s, d2s = (m._smooth(c) for c in (u, state.d0, state.d1, state.d2))
        idx, sgn = _play(us, w, m.piece)
        hold = idx != np.arange(u.size)

        def held(c: FloatArray, cs: FloatArray) -> FloatArray:
            # the hold acts on the smooth part; the path's noise stays at its own sample
            # (holding it would smooth the model and reward play that is not there)
            return c + np.where(hold, cs[idx] - cs, 0.0)

        out = replace(
            state,
            y=held(u, us) - sgn * 0.5 * w,
            d0=held(state.d0, d0s),
            d1=held(state.d1, d1s),
            d2=held(state.d2, d2s),
            cols={k: held(v, m._smooth(v)) for k, v in state.cols.items()},
            sgn=sgn,
        )
        return out, -0.5 * sgn

    def undo(self, state: Undone, value: float) -> Undone:
        # a held reading says only that the angle is somewhere within the band: adding half
        # the width to it biases the link lengths, so with ``drop_holds`` those samples are
        # left out (while at least half the samples remain; the path still drives the model
        # through them)
        z = state.z + 0.5 * value * state.sol.play_sign
        if not state.drop_holds:
            return replace(state, z=z)
        m = state.model
        idx, _ = _play(m._smooth(state.sol.true_psi), value, m.piece)
        follows = idx == np.arange(z.size)
        keep = follows if follows.sum() >= 0.5 * z.size else state.keep
        return replace(state, z=z, keep=keep)


@dataclass(frozen=True)
class Cubic(PathEffectModel):
    """A reading y + k y^3 (unit gain at 0)."""

    order: int = 20

    def apply(self, state: PathState, value: float) -> tuple[PathState, FloatArray]:
        y = state.y
        g = 1.0 + 3.0 * value * y * y
        return state.scaled(g, y=y + value * y**3), y**3

    def undo(self, state: Undone, value: float) -> Undone:
        if not value:
            return state
        z = state.z
        y = z.copy()
        for _ in range(4):  # Newton on y + k y^3 = z
            y -= (y + value * y**3 - z) / (1.0 + 3.0 * value * y * y)
        return replace(state, z=y)


@dataclass(frozen=True)
class Gain(PathEffectModel):
    """A reading s y."""

    order: int = 30
    tolerated: Tolerance | None = None

    def apply(self, state: PathState, value: float) -> tuple[PathState, FloatArray]:
        return state.scaled(value, y=value * state.y), state.y.copy()

    def undo(self, state: Undone, value: float) -> Undone:
        return replace(state, z=state.z / value)


@dataclass(frozen=True)
class Offset(PathEffectModel):
    """A reading y + b."""

    order: int = 40

    def apply(self, state: PathState, value: float) -> tuple[PathState, FloatArray]:
        return replace(state, y=state.y + value), np.ones_like(state.y)

    def undo(self, state: Undone, value: float) -> Undone:
        return replace(state, z=state.z - value)


GAIN_TOLERANCE = 0.05
"""A joint-angle gain the log cannot bound within this (95 %) is a confound of the link lengths
(a hitch angle reading 5 % high moves L1 by tens of percent on a log of small angles)."""

CATALOGUE: tuple[EffectSpec[PathEffectModel], ...] = (
    EffectSpec(
        "sensor_offset",
        "psi",
        EffectKind.SENSOR,
        (EffectParam("offset", "rad", 0.0, -0.5, 0.5, 0.0),),
        "the joint-angle encoder reads a constant amount off (mounting, zeroing)",
        sim_switch="sensor_offset",
        truth_key="sensor_offset(psi)",
        model=Offset(),
    ),
    EffectSpec(
        "sensor_scale",
        "psi",
        EffectKind.SENSOR,
        (EffectParam("scale", "1", 1.0, 0.5, 2.0, 1.0),),
        "the joint-angle encoder's gain is off (a reading proportional to the true angle): at "
        "small angles it trades with L1 + L2 (psi ~ kappa (L1 + L2)); only large angles and "
        "transients tell the two apart",
        confounded_with=("param:L1", "param:L2"),
        sim_switch="sensor_scale",
        truth_key="sensor_scale(psi)",
        model=Gain(tolerated=Tolerance(GAIN_TOLERANCE, "the joint angle's gain", "a gain error")),
    ),
    EffectSpec(
        "backlash",
        "psi",
        EffectKind.SENSOR,
        (EffectParam("width", "rad", 0.0, 0.0, 0.3, 0.005),),
        "play in the hitch or its encoder: the reading follows the angle only once it leaves "
        "a dead band of this width (it lags by half the width after a reversal)",
        confounded_with=("clock_offset(hitch)",),
        truth_key="hitch_dead_band_rad",
        model=Backlash(),
    ),
    EffectSpec(
        "clock_offset",
        "hitch",
        EffectKind.CLOCK,
        (EffectParam("offset", "s", 0.0, -1.0, 1.0, 0.0),),
        "the joint angle's stamps are late by a constant (transport delay, filtering, clock "
        "offset of the encoder's computer)",
        confounded_with=("backlash(psi)",),
        sim_switch="clock_offset_s",
        truth_key="clock_offset(hitch)",
        model=StampOffset(),
    ),
    EffectSpec(
        "clock_drift",
        "hitch",
        EffectKind.CLOCK,
        (EffectParam("drift", "s/s", 0.0, -0.05, 0.05, 0.0),),
        "the joint angle's clock runs at another rate: its stamps drift linearly against the "
        "path's",
        truth_key="clock_drift",
        model=StampDrift(),
    ),
    EffectSpec(
        "sensor_nonlinearity",
        "psi",
        EffectKind.SENSOR,
        (EffectParam("cubic", "1/rad^2", 0.0, -3.0, 3.0, 0.0),),
        "the encoder's reading bends away from the true angle at large angles (y + k y^3)",
        confounded_with=("param:L1",),
        model=Cubic(),
    ),
)
"""The built-in effects the path discovery tries, in the order it tries them (registered ones,
:func:`register_effect`, follow)."""


def _hook_problem(spec: EffectSpec[PathEffectModel]) -> str | None:
    if spec.model is None or len(spec.params) != 1:
        return "needs a model hook (a PathEffectModel) and one parameter"
    return None


REGISTRY: EffectRegistry[EffectSpec[PathEffectModel]] = EffectRegistry(
    "path",
    key=lambda e: e.key,
    builtin=lambda: (e.key for e in CATALOGUE),
    check=_hook_problem,
)
"""Effects added to the path discovery's catalogue from outside (``calib.discovery``'s one
registry behaviour)."""


def register_effect(spec: EffectSpec[PathEffectModel]) -> EffectSpec[PathEffectModel]:
    """Add ``spec`` (its ``model`` a :class:`PathEffectModel`, one parameter) to the effects the
    path discovery tries, after the built-in ones; returns it (ValueError: no hook, other than
    one parameter, or its key is taken by another effect)."""
    return REGISTRY.register(spec)


def unregister_effect(key: str | EffectSpec[PathEffectModel]) -> None:
    """Remove the registered effect ``key`` (the built-in ones stay)."""
    REGISTRY.unregister(key)


def catalogue() -> tuple[EffectSpec[PathEffectModel], ...]:
    """Every effect the path discovery tries: the built-in ones, then the registered ones."""
    return (*CATALOGUE, *REGISTRY.entries())


def effect_by_key(key: str) -> EffectSpec[PathEffectModel]:
    """The catalogue entry ``id(target)`` (built-in or registered)."""
    for e in catalogue():
        if e.key == key:
            return e
    raise KeyError(key)


def _chain(
    effects: Sequence[EffectSpec[PathEffectModel]],
) -> list[tuple[int, EffectSpec[PathEffectModel], PathEffectModel]]:
    """(index in ``effects``, spec, hook) in the hooks' order (ties: as given)."""
    out = []
    for i, e in enumerate(effects):
        if e.model is None:
            raise ValueError(f"path effect {e.key}: no model hook")
        out.append((i, e, e.model))
    return sorted(out, key=lambda c: c[2].order)


def _valued(
    chain: Sequence[tuple[int, EffectSpec[PathEffectModel], PathEffectModel]],
    x: FloatArray,
) -> Iterator[tuple[EffectSpec[PathEffectModel], PathEffectModel, float]]:
    """(spec, hook, its value in the parameter vector ``x``) along ``chain``."""
    for i, e, m in chain:
        yield e, m, float(x[2 + i])


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
            still integrated through its knots between them).
        fill_spacing_s: the path's knots between kept samples enter the integration at most
            one per this many seconds (``PathTransientFit``'s ``fill_spacing_s``; 0: all).
    """

    def __init__(
        self,
        path: DrivePath,
        t_psi: FloatArray,
        psi: FloatArray,
        gaps: Sequence[tuple[float, float]] = (),
        *,
        max_samples: int = 12000,
        bounds_L1_m: tuple[float, float] = (-20.0, 50.0),
        bounds_L2_m: tuple[float, float] = (0.02, 50.0),
        fill_spacing_s: float = FILL_SPACING_S,
    ) -> None:
        t = np.asarray(t_psi, dtype=float)
        p = np.asarray(psi, dtype=float)
        ok = np.isfinite(t) & np.isfinite(p)
        t, p = t[ok], p[ok]
        if t.size > max_samples:
            keep = np.unique(np.round(np.linspace(0, t.size - 1, max_samples)).astype(np.int64))
            t, p = t[keep], p[keep]
        base = PathTransientFit(
            resolution_check=False,
            bounds_L1_m=bounds_L1_m,
            bounds_L2_m=bounds_L2_m,
            fill_spacing_s=fill_spacing_s,
        )
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
        self._evaluations: dict[
            tuple[tuple[int, ...], bytes],
            tuple[tuple[EffectSpec, ...], tuple[FloatArray, ...]],
        ] = {}

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
        modelled angle and the backlash direction.

        The effects' hooks (:class:`PathEffectModel`) act in their ``order``: first every
        stamp shift (summed into one shift of the modelled angle), then each reading change
        on the shifted angle.

        The last ``EVAL_CACHE`` evaluations are kept (copies handed out), keyed by the exact
        bytes of ``x`` and the identity of the effects: a fit's final evaluation at the point
        its optimiser accepted last, and every held-out fold's start at the full fit's
        solution, are the same integration of the path (the samples' weights do not enter
        it), bit for bit."""
        # the entry holds the effects themselves, so their ids stay theirs while it lives
        key = (tuple(id(e) for e in effects), np.asarray(x, dtype=float).tobytes())
        hit = self._evaluations.pop(key, None)
        if hit is None:
            hit = (tuple(effects), self._evaluate(np.asarray(x, dtype=float), tuple(effects)))
        self._evaluations[key] = hit  # most recently used last
        while len(self._evaluations) > EVAL_CACHE:
            self._evaluations.pop(next(iter(self._evaluations)))
        y, J, d0, true_u, sgn = hit[1]
        return y.copy(), J.copy(), d0.copy(), true_u.copy(), sgn.copy()

    def _evaluate(
        self, x: FloatArray, effects: tuple[EffectSpec, ...]
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        """:meth:`evaluate` without its cache."""
        n_e = sum(len(e.params) for e in effects)
        q = 2 + n_e
        u, d0, d1, d2 = self._base._simulate_jacobian(float(x[0]), float(x[1]), x[q:])
        chain = _chain(effects)
        t_rel = self.t - self.t_ref
        stamps = [(e.key, v, m.stamp_shift(t_rel, v)) for e, m, v in _valued(chain, x)]
        shifts = [(k, s) for k, _, s in stamps if s is not None]
        cols: dict[str, FloatArray] = {}
        if shifts:
            tau = self.t
            for _, (delta, _) in shifts:
                tau = tau - delta
            u, d0, d1, d2, rate = self._shifted_smooth(tau, [u, d0, d1, d2])
            for key, (_, ddelta) in shifts:
                cols[key] = -rate * ddelta
        state = PathState(self, u, d0, d1, d2, cols, u, np.zeros_like(u))
        shifted = {k for k, _ in shifts}
        for e, m, v in _valued(chain, x):
            if e.key not in shifted:
                state, col = m.apply(state, v)
                state.cols[e.key] = col
        J = np.empty((state.y.size, q))
        J[:, 0] = state.d1
        J[:, 1] = state.d2
        for i, e in enumerate(effects):
            J[:, 2 + i] = state.cols[e.key]
        return state.y, J, state.d0, state.true_u, state.sgn

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
        lo = np.concatenate(
            [
                [self.bounds[0][0], self.bounds[1][0]],
                [e.params[0].lower for e in effects],
                np.full(P, -math.pi),
            ]
        )
        hi = np.concatenate(
            [
                [self.bounds[0][1], self.bounds[1][1]],
                [e.params[0].upper for e in effects],
                np.full(P, math.pi),
            ]
        )
        if x0 is None:
            x0 = np.concatenate([[1.0, 2.0], [e.params[0].init for e in effects], self.psi0_guess])
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

        sol = least_squares(
            lambda x: both(x)[0],
            x0,
            jac=lambda x: both(x)[1],
            bounds=(lo, hi),
            method="trf",
            x_scale="jac",
            xtol=1e-9,
            ftol=1e-10,
            gtol=1e-10,
            max_nfev=max_nfev,
        )
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
        return JointSolution(
            tuple(effects), x, cov, cov_fixed, r, fitted, y, true_u, sgn, bool(sol.success)
        )

    def corrected(
        self, sol: JointSolution, *, drop_holds: bool = False
    ) -> tuple[FloatArray, FloatArray]:
        """The joint-angle samples with the fitted effects undone: (stamps on the path's
        clock, the true angle the readings imply), for a fit of the nominal model.

        Each effect's hook undoes its reading change, last effect first
        (:meth:`PathEffectModel.undo`); the stamps are moved back by the shifts in their
        order. ``drop_holds``: the hooks may leave out samples whose reading says little of the
        true angle (the backlash's holds inside its dead band)."""
        chain = _chain(sol.effects)
        t_rel = self.t - self.t_ref
        t = self.t
        for _, m, v in _valued(chain, sol.x):
            s = m.stamp_shift(t_rel, v)
            if s is not None:
                t = t - s[0]
        state = Undone(self, sol, t.copy(), self.p, None, drop_holds)
        for _, m, v in reversed(list(_valued(chain, sol.x))):
            state = m.undo(state, v)
        if state.keep is not None:
            return state.t[state.keep], state.z[state.keep]
        return state.t, state.z
