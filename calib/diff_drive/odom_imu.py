"""What a log of wheel odometry, an IMU and maybe GPS determines (the usual ROS log of a Husky,
a Jackal, most mobile robots): no encoder angles, no ground-truth pose.

* **Yaw-rate gain** G = odometry yaw rate / gyro yaw rate. The controller's odometry turns
  the wheel speeds into a yaw rate with the geometric track; a skid steer turns slower, so
  G = b_effective / b_geometric (> 1) and the effective track is the geometric one x G. Fitted
  on windows of ``WINDOW_S`` (the gyro's yaw change = odometry's yaw change / G + bias x
  duration; a gyro bias is always fitted), at the lag that best aligns the two (found by
  cross-correlation within ``MAX_LAG_S``). 95 % interval: moving-block bootstrap over windows,
  value ± t std on (blocks - 1) degrees of freedom.
* **Its dependence on turn rate and speed**: G per bin of |odometry yaw rate| and of speed.
* **Distance scale** against GPS (when the log has a fix): GPS distance / odometry distance
  over windows of ``GPS_WINDOW_S`` while moving.
* **Adequacy**: the gyro's yaw-change residual of the constant-gain model (held out: two folds
  of alternating time blocks), located by turn rate and speed; **discovery** through
  :func:`calib.adequacy.select_effects` with ``turn_slip`` (G grows with |turn rate|: the wheels
  slide more the faster the robot turns) and ``speed_slip`` (G grows with speed). Each
  effect's hook (a :class:`GainEffectModel`) says what it adds to the gain
  G = (1 + sum of constant parts) (1 + sum of growth parts); the fitter never reads an id.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares
from scipy.stats import t as student_t

from calib.adequacy import Adequacy, ResidualChannel, assess, not_assessed, under_misfit
from calib.adequacy.intervals import Z95
from calib.discovery import EffectKind, EffectParam, EffectSpec, ModelFit, Selection, select_effects
from calib.errors import InsufficientDataError
from calib.results import Estimate, json_safe
from calib.stats import bartlett_long_run, cube_root_lag, sandwich

__all__ = ["SPEED_SLIP", "TURN_SLIP", "GainEffectModel", "OdomImuResult", "analyze_odom_imu"]

Array = NDArray[np.float64]

WINDOW_S = 0.5
FOLD_S = 10.0
MAX_LAG_S = 0.3
GPS_WINDOW_S = 5.0
MIN_TURN_RAD_S = 0.05
"""Windows whose odometry yaw rate stays below this (rad/s) carry nothing about the gain."""
N_BOOT = 500


class GainEffectModel(Protocol):
    """How one effect changes the yaw-rate gain: the hook of its
    :class:`~calib.adequacy.EffectSpec` (``values``: its own parameters by name)."""

    def gain(
        self, values: Mapping[str, float], w: _Windows, rows: NDArray[np.intp]
    ) -> tuple[float | Array, float | Array]:
        """What it adds to G's constant part and to its growth part on windows ``rows``."""
        ...


@dataclass(frozen=True)
class _Constant:
    param: str

    def gain(
        self, values: Mapping[str, float], w: _Windows, rows: NDArray[np.intp]
    ) -> tuple[float | Array, float | Array]:
        return values[self.param], 0.0


@dataclass(frozen=True)
class _Growth:
    param: str
    covariate: str
    """The :class:`_Windows` field the gain grows with."""

    def gain(
        self, values: Mapping[str, float], w: _Windows, rows: NDArray[np.intp]
    ) -> tuple[float | Array, float | Array]:
        x: Array = getattr(w, self.covariate)[rows]
        return 0.0, values[self.param] * x


TURN_SLIP: EffectSpec[GainEffectModel] = EffectSpec(
    "turn_slip",
    "track",
    EffectKind.DYNAMICS,
    (EffectParam("per_rad_s", "s/rad", 0.0, -0.9, 20.0, 0.0),),
    "the wheels slide more the faster the robot turns: the yaw-rate gain grows with |turn "
    "rate| (G = G0 (1 + s |omega|))",
    confounded_with=("speed_slip(track)",),
    model=_Growth("per_rad_s", "rate"),
)
SPEED_SLIP: EffectSpec[GainEffectModel] = EffectSpec(
    "speed_slip",
    "track",
    EffectKind.DYNAMICS,
    (EffectParam("per_m_s", "s/m", 0.0, -0.9, 20.0, 0.0),),
    "the yaw-rate gain grows with speed (G = G0 (1 + s |v|))",
    confounded_with=("turn_slip(track)",),
    model=_Growth("per_m_s", "speed"),
)
GAIN: EffectSpec[GainEffectModel] = EffectSpec(
    "effective_track",
    "track",
    EffectKind.DYNAMICS,
    (EffectParam("gain_minus_1", "1", 0.0, -0.9, 20.0, 0.0),),
    "the robot turns slower than its wheel odometry says (skid steer: effective track = "
    "geometric track x gain)",
    model=_Constant("gain_minus_1"),
)


@dataclass(frozen=True)
class _Windows:
    t: Array
    odo: Array  # odometry yaw change per window (rad)
    gyro: Array  # gyro yaw change per window (rad)
    dt: Array
    rate: Array  # |odometry yaw rate| (rad/s)
    speed: Array  # |odometry speed| (m/s)


def _integrate(t: Array, x: Array) -> Array:
    return np.concatenate([[0.0], np.cumsum(0.5 * (x[1:] + x[:-1]) * np.diff(t))])


def _lag(t: Array, odo: Array, gyro: Array) -> float:
    """Lag (s, gyro behind odometry when positive) maximising their correlation."""
    dt = float(np.median(np.diff(t)))
    if not dt > 0:
        return 0.0
    m = max(1, int(MAX_LAG_S / dt))
    a, b = odo - odo.mean(), gyro - gyro.mean()
    cs = []
    for k in range(-m, m + 1):
        x, y = a[max(0, -k) : a.size - max(0, k)], b[max(0, k) : b.size - max(0, -k)]
        cs.append(float(np.dot(x, y)) / math.sqrt(float(np.dot(x, x) * np.dot(y, y)) or 1.0))
    at = int(np.argmax(cs))
    if at in (0, len(cs) - 1) or cs[at] - cs[m] < 0.01:
        return 0.0  # no clear peak inside the search range: not shifted
    return (at - m) * dt


def _windows(t: Array, odo: Array, gyro: Array, speed: Array) -> _Windows:
    edges = np.unique(np.searchsorted(t, np.arange(t[0], t[-1] + 1e-9, WINDOW_S)))
    if edges[-1] != t.size - 1:
        edges = np.append(edges, t.size - 1)
    a, b = edges[:-1], edges[1:]
    io, ig, iv = _integrate(t, odo), _integrate(t, gyro), _integrate(t, np.abs(speed))
    dt = t[b] - t[a]
    return _Windows(
        0.5 * (t[a] + t[b]),
        io[b] - io[a],
        ig[b] - ig[a],
        dt,
        np.abs(io[b] - io[a]) / dt,
        (iv[b] - iv[a]) / dt,
    )


@dataclass(frozen=True)
class OdomImuResult:
    """The odometry + IMU analysis: ``gain`` (odometry / gyro yaw rate), the effective track
    when a geometric one is known, the gyro bias, the gain by turn-rate and speed bins, the GPS
    distance scale, adequacy and discovery."""

    gain: Estimate
    bias: Estimate
    lag_s: float
    effective_track: Estimate | None
    by_turn_rate: list[dict[str, float]]
    by_speed: list[dict[str, float]]
    distance_scale: Estimate | None
    adequacy: Adequacy
    selection: Selection | None
    n_windows: int
    notes: list[str] = field(default_factory=list)

    @property
    def named(self) -> list[str]:
        return [] if self.selection is None else [e.id for e in self.selection.accepted]

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "gain": self.gain.to_dict(),
                "gyro_bias": self.bias.to_dict(),
                "lag_s": self.lag_s,
                "effective_track": None
                if self.effective_track is None
                else self.effective_track.to_dict(),
                "gain_by_turn_rate": self.by_turn_rate,
                "gain_by_speed": self.by_speed,
                "distance_scale_gps": None
                if self.distance_scale is None
                else self.distance_scale.to_dict(),
                "windows": self.n_windows,
                "named": self.named,
                "selection": None if self.selection is None else self.selection.to_dict(),
                "notes": self.notes,
            }
        )

    def summary_lines(self) -> list[str]:
        """The gain, its dependence on turn rate, the GPS scale: the robot's report part."""
        g = self.gain
        lines = [
            "Wheel odometry against the gyro (no encoder angles, no ground truth: radii not "
            "determined):",
            f"  yaw-rate gain (odometry / gyro) {g.value:.4f} ± {g.std:.2g} "
            f"[95 %: {g.ci95[0]:.4f}, {g.ci95[1]:.4f}] over {self.n_windows} windows of "
            f"{WINDOW_S:g} s"
            + ("" if g.identifiable else " (not determined)")
            + f"; gyro bias {self.bias.value:+.4f} rad/s; lag {self.lag_s:+.3f} s",
        ]
        if self.effective_track is not None:
            lines.append("  " + self.effective_track.report())
        if self.by_turn_rate:
            lines.append(
                "  gain by |turn rate|: "
                + ", ".join(
                    f"{b['lo']:.2g}-{b['hi']:.2g} rad/s: {b['gain']:.3g} ± {b['std']:.2g}"
                    for b in self.by_turn_rate
                )
            )
        if self.by_speed:
            lines.append(
                "  gain by speed: "
                + ", ".join(
                    f"{b['lo']:.2g}-{b['hi']:.2g} m/s: {b['gain']:.3g} ± {b['std']:.2g}"
                    for b in self.by_speed
                )
            )
        if self.distance_scale is not None:
            lines.append("  " + self.distance_scale.report())
        lines += [f"  {n}" for n in self.notes]
        return lines

    def report(self) -> list[str]:
        """Discovery's lines (the report's model-mismatch part)."""
        if self.selection is None:
            return ["Discovery: nothing tested."]
        acc = self.selection.accepted
        lines = [
            "Discovery: "
            + (
                ", ".join(e.key for e in acc)
                if acc
                else "no catalogued effect improves the held-out fit"
            )
        ]
        for e in acc:
            for n, p in self.selection.final.effect_parameters.get(e.key, {}).items():
                lines.append(f"  {e.key} {n} = {p.value:.4g} ± {p.std:.2g} {p.unit}: {e.physics}")
        b, a = self.selection.base.heldout_sse, self.selection.final.heldout_sse
        if acc and math.isfinite(b) and math.isfinite(a):
            lines.append(f"  held-out sum of squares (noise units) {b:.4g} -> {a:.4g}")
        lines += [f"  {c.note}" for c in self.selection.confounds]
        return lines


def _fit_gain(w: _Windows, rows: NDArray[np.intp]) -> tuple[float, float]:
    """gyro = a odo + bias dt on ``rows``: returns (G = 1/a, bias)."""
    X = np.column_stack([w.odo[rows], w.dt[rows]])
    (a, bias), *_ = np.linalg.lstsq(X, w.gyro[rows], rcond=None)
    return (1.0 / a if a != 0 else math.nan), float(bias)


def _gain_under_misfit(gain: Estimate, adequacy: Adequacy, pieces: Sequence[float]) -> Estimate:
    """:func:`calib.adequacy.under_misfit` of the yaw-rate gain G = 1 / a taken on a, the
    slope the regression fits (gyro = a odometry + bias): a piece that barely turns gives an a
    near its error and a G that blows up, so the pieces' spread is taken on a (well behaved,
    errors symmetric) and the widened interval mapped back through 1 / a (open above when it
    reaches a = 0)."""
    if not (math.isfinite(gain.value) and gain.value != 0 and math.isfinite(gain.std)):
        return under_misfit(gain, adequacy)
    a = 1.0 / gain.value
    a_est = Estimate(
        "odometry_to_gyro_slope",
        a,
        gain.std * a * a,
        (a - Z95 * gain.std * a * a, a + Z95 * gain.std * a * a),
        gain.identifiable,
        "1",
    )
    a_pieces = [1.0 / g for g in pieces if math.isfinite(g) and g != 0]
    wa = under_misfit(a_est, adequacy, pieces=a_pieces)
    if wa is a_est:
        return gain
    lo_a, hi_a = wa.ci95
    if not (math.isfinite(lo_a) and math.isfinite(hi_a)):
        return Estimate(
            gain.name, gain.value, math.nan, (-math.inf, math.inf), False, gain.unit, wa.note
        )
    if lo_a * hi_a <= 0:  # the interval of a reaches zero: G unbounded on one side
        ci = (1.0 / hi_a, math.inf) if a > 0 else (-math.inf, 1.0 / lo_a)
    else:
        ci = (min(1.0 / lo_a, 1.0 / hi_a), max(1.0 / lo_a, 1.0 / hi_a))
    std = wa.std / (a * a)
    return Estimate(
        gain.name,
        gain.value,
        std,
        ci,
        False,
        gain.unit,
        wa.note + "; spread taken on the slope 1 / G and mapped",
    )


def _block_boot(n: int, rng: np.random.Generator, reps: int) -> list[NDArray[np.intp]]:
    blk = max(1, round(n ** (1 / 3)))
    out = []
    for _ in range(reps):
        starts = rng.integers(0, n - blk + 1, size=int(np.ceil(n / blk)))
        out.append((starts[:, None] + np.arange(blk)).ravel()[:n].astype(np.intp))
    return out


def _interval(
    name: str, value: float, boot: Array, dof: int, unit: str, note: str, ok: bool = True
) -> Estimate:
    boot = boot[np.isfinite(boot)]
    std = float(np.std(boot, ddof=1)) if boot.size > 1 else math.nan
    q = float(student_t.ppf(0.975, max(1, dof)))
    ci = (value - q * std, value + q * std) if math.isfinite(std) else (math.nan, math.nan)
    return Estimate(name, value, std, ci, ok and math.isfinite(std), unit, note)


def _binned(
    w: _Windows,
    key: Array,
    edges: Sequence[float],
    use: NDArray[np.bool_],
    rng: np.random.Generator,
) -> list[dict[str, float]]:
    out = []
    for lo, hi in itertools.pairwise(edges):
        rows = np.flatnonzero(use & (key >= lo) & (key < hi)).astype(np.intp)
        if rows.size < 8 or float(np.sum(np.abs(w.odo[rows]))) < 0.5:
            continue
        g, _ = _fit_gain(w, rows)
        boot = []
        for _ in range(200):
            r = rng.choice(rows, rows.size)
            boot.append(_fit_gain(w, r)[0])
        out.append(
            {
                "lo": float(lo),
                "hi": float(hi),
                "gain": g,
                "std": float(np.nanstd(boot, ddof=1)),
                "windows": int(rows.size),
            }
        )
    return out


class _GainFitter:
    """Nominal: the odometry's yaw rate is the true one (G = 1) up to a gyro bias; effects:
    a constant gain, its growth with |turn rate| and with speed."""

    def __init__(
        self,
        w: _Windows,
        use: NDArray[np.intp],
        sigma: float,
        catalogue: Sequence[EffectSpec[GainEffectModel]] = (),
    ) -> None:
        self.w, self.use, self.sigma = w, use, sigma
        blocks = ((w.t[use] - w.t[0]) // FOLD_S).astype(int) % 2
        self.folds = (use[blocks == 0], use[blocks == 1])
        self.order = {e.key: i for i, e in enumerate(catalogue)}
        """The catalogue's order, in which the parts of the gain are summed (whatever order
        the selection added the effects in)."""

    def _res(
        self,
        th: Array,
        names: Sequence[str],
        rows: NDArray[np.intp],
        effects: Sequence[EffectSpec[GainEffectModel]],
    ) -> Array:
        v = dict(zip(names, th, strict=True))
        w = self.w
        const: float | Array = 0.0
        grow: float | Array = 1.0
        for e in sorted(effects, key=lambda e: self.order.get(e.key, len(self.order))):
            if e.model is None:
                raise ValueError(f"effect {e.key}: no model hook (a GainEffectModel)")
            c, d = e.model.gain({p.name: v[f"{e.key}:{p.name}"] for p in e.params}, w, rows)
            const, grow = const + c, grow + d
        g = (1 + const) * grow
        pred = w.odo[rows] / np.maximum(g, 1e-3) + v["bias"] * w.dt[rows]
        return np.asarray((w.gyro[rows] - pred) / self.sigma, dtype=float)

    def _solve(
        self, names: list[str], effects: Sequence[EffectSpec], rows: NDArray[np.intp]
    ) -> Any:
        spec = {f"{e.key}:{p.name}": p for e in effects for p in e.params}
        lo = np.array([spec[n].lower if n in spec else -np.inf for n in names])
        hi = np.array([spec[n].upper if n in spec else np.inf for n in names])
        x0 = np.zeros(len(names))
        return least_squares(lambda th: self._res(th, names, rows, effects), x0, bounds=(lo, hi))

    def __call__(self, effects: tuple[EffectSpec, ...]) -> ModelFit | None:
        names = ["bias"] + [f"{e.key}:{p.name}" for e in effects for p in e.params]
        try:
            sol = self._solve(names, effects, self.use)
        except ValueError:
            return None
        J, r = np.asarray(sol.jac, float), np.asarray(sol.fun, float)
        S = bartlett_long_run(J * r[:, None], cube_root_lag(r.size))
        std = np.sqrt(np.maximum(np.diag(sandwich(J.T @ J, S)), 0.0))
        held = 0.0
        for train, test in (self.folds, self.folds[::-1]):
            try:
                s2 = self._solve(names, effects, train)
            except ValueError:
                held = math.nan
                break
            rr = self._res(np.asarray(s2.x), names, test, effects)
            held += float(rr @ rr)
        eff: dict[str, dict[str, Estimate]] = {}
        for e in effects:
            for p in e.params:
                i = names.index(f"{e.key}:{p.name}")
                x, s = float(sol.x[i]), float(std[i])
                eff.setdefault(e.key, {})[p.name] = Estimate(
                    p.name,
                    x,
                    s,
                    (x - 1.96 * s, x + 1.96 * s),
                    s > 0,
                    p.unit,
                    "Newey-West over windows",
                )
        pars = {
            "gyro_bias": Estimate(
                "gyro_bias",
                float(sol.x[0]),
                float(std[0]),
                (float(sol.x[0] - 1.96 * std[0]), float(sol.x[0] + 1.96 * std[0])),
                True,
                "rad/s",
            )
        }
        return ModelFit(
            effects,
            pars,
            eff,
            float(r @ r),
            held,
            r.size,
            len(names),
            payload=dict(zip(names, map(float, sol.x), strict=True)),
        )


def _gps_scale(
    t: Array, v: Array, lat: Array, lon: Array, rng: np.random.Generator
) -> Estimate | None:
    ok = np.isfinite(lat) & np.isfinite(lon) & np.isfinite(v)
    if ok.sum() < 20:
        return None
    t, v, lat, lon = t[ok], v[ok], lat[ok], lon[ok]
    r_earth = 6_371_000.0
    east = np.radians(lon - lon[0]) * r_earth * math.cos(math.radians(float(lat[0])))
    north = np.radians(lat - lat[0]) * r_earth
    dist = _integrate(t, np.abs(v))
    edges = np.unique(np.searchsorted(t, np.arange(t[0], t[-1] + 1e-9, GPS_WINDOW_S)))
    a, b = edges[:-1], edges[1:]
    d_odo = dist[b] - dist[a]
    d_gps = np.hypot(east[b] - east[a], north[b] - north[a])
    use = d_odo > 1.0  # at least a metre: GPS noise is of that order
    if use.sum() < 4:
        return None
    rows = np.flatnonzero(use).astype(np.intp)
    value = float(np.sum(d_gps[rows]) / np.sum(d_odo[rows]))
    boot = np.array(
        [
            float(np.sum(d_gps[rows[i]]) / np.sum(d_odo[rows[i]]))
            for i in _block_boot(rows.size, rng, N_BOOT)
        ]
    )
    return _interval(
        "distance_scale_gps",
        value,
        boot,
        max(1, rows.size // max(1, round(rows.size ** (1 / 3))) - 1),
        "1",
        f"GPS distance / odometry distance over {rows.size} windows of {GPS_WINDOW_S:g} s "
        "(chord of the GPS track: slightly short on curves)",
    )


def analyze_odom_imu(
    t: Array,
    odom_omega: Array,
    gyro_z: Array,
    *,
    odom_v: Array | None = None,
    gps: tuple[Array, Array] | None = None,
    geometric_track: float | None = None,
    seed: int = 0,
) -> OdomImuResult:
    """The analysis of the module docstring on one aligned log (``t`` in s).

    Raises:
        InsufficientDataError: too few samples, or the robot hardly turns.
    """
    t = np.asarray(t, float)
    odo = np.asarray(odom_omega, float)
    gyr = np.asarray(gyro_z, float)
    vv = np.zeros_like(t) if odom_v is None else np.asarray(odom_v, float)
    ok = np.isfinite(t) & np.isfinite(odo) & np.isfinite(gyr) & np.isfinite(vv)
    t, odo, gyr, vv = t[ok], odo[ok], gyr[ok], vv[ok]
    if t.size < 50:
        raise InsufficientDataError("the odometry + IMU analysis needs at least 50 samples")
    lag = _lag(t, odo, gyr)
    if lag:  # shift the gyro onto the odometry's clock
        gyr = np.interp(t + lag, t, gyr)
    w = _windows(t, odo, gyr, vv)
    use = np.flatnonzero(w.rate >= MIN_TURN_RAD_S).astype(np.intp)
    turned = float(np.sum(np.abs(w.odo[use])))
    if use.size < 10 or turned < math.pi / 2:
        raise InsufficientDataError(
            f"the robot turns only {turned:.2f} rad in all: the yaw-rate gain is not determined"
        )
    rng = np.random.default_rng(seed)
    g, bias = _fit_gain(w, use)
    boots = [_fit_gain(w, use[i]) for i in _block_boot(use.size, rng, N_BOOT)]
    blk = max(1, round(use.size ** (1 / 3)))
    dof = max(1, int(np.ceil(use.size / blk)) - 1)
    note = (
        f"gyro yaw change = odometry's / G + bias x duration on {use.size} windows of "
        f"{WINDOW_S:g} s that turn; moving-block bootstrap (blocks of {blk}), t on {dof} "
        "degrees of freedom"
    )
    gain = _interval("yaw_rate_gain", g, np.array([b[0] for b in boots]), dof, "1", note)
    bias_e = _interval(
        "gyro_bias", bias, np.array([b[1] for b in boots]), dof, "rad/s", "fitted with the gain"
    )
    eff = None
    if geometric_track is not None and math.isfinite(gain.std):
        eff = Estimate(
            "effective_track",
            geometric_track * g,
            geometric_track * gain.std,
            (geometric_track * gain.ci95[0], geometric_track * gain.ci95[1]),
            True,
            "m",
            f"geometric track {geometric_track:g} m x yaw-rate gain",
        )
    hi_rate = float(np.max(w.rate[use]))
    edges = [MIN_TURN_RAD_S, *np.linspace(0.0, hi_rate, 5)[1:-1].tolist(), hi_rate + 1e-9]
    edges = sorted(set(edges))
    use_mask = np.zeros(w.t.size, bool)
    use_mask[use] = True
    by_turn = _binned(w, w.rate, edges, use_mask, rng)
    by_speed: list[dict[str, float]] = []
    if odom_v is not None and float(np.max(w.speed)) > 0:
        sp_edges = np.quantile(w.speed[use], [0, 0.25, 0.5, 0.75, 1.0]).tolist()
        sp_edges[-1] += 1e-9
        by_speed = _binned(w, w.speed, sorted(set(sp_edges)), use_mask, rng)
    # adequacy of the constant-gain model on every window (held out: two folds)
    pred = w.odo / g + bias * w.dt
    resid = w.gyro - pred
    blocks = ((w.t - w.t[0]) // FOLD_S).astype(int) % 2
    held = np.full(w.t.size, math.nan)
    for f in (0, 1):
        train = np.intersect1d(use, np.flatnonzero(blocks != f)).astype(np.intp)
        if train.size >= 8:
            gf, bf = _fit_gain(w, train)
            test = blocks == f
            held[test] = w.gyro[test] - (w.odo[test] / gf + bf * w.dt[test])
    chan = ResidualChannel(
        "gyro yaw change",
        "rad",
        w.t - w.t[0],
        resid,
        held,
        timescale_s=WINDOW_S,
        covariates={"|turn rate| (rad/s)": w.rate, "speed (m/s)": w.speed},
    )
    model = "constant yaw-rate gain + gyro bias"
    try:
        adequacy = assess([chan], model=model)
    except (ValueError, FloatingPointError):
        adequacy = not_assessed(model, "the residual could not be judged")
    if not adequacy.explains and adequacy.channels:
        pieces = []
        for f0 in np.arange(w.t[0], w.t[-1], FOLD_S):
            rows = np.intersect1d(use, np.flatnonzero((w.t >= f0) & (w.t < f0 + FOLD_S)))
            if rows.size >= 8 and float(np.sum(np.abs(w.odo[rows]))) >= 1.0:
                pieces.append(_fit_gain(w, rows.astype(np.intp))[0])
        gain = _gain_under_misfit(gain, adequacy, pieces)
        if eff is not None and geometric_track is not None:
            eff = Estimate(
                "effective_track",
                geometric_track * gain.value,
                geometric_track * gain.std,
                (geometric_track * gain.ci95[0], geometric_track * gain.ci95[1]),
                False,
                "m",
                gain.note,
            )
    sigma = (adequacy.channels[0].noise_floor if adequacy.channels else 0.0) or float(np.std(resid))
    notes: list[str] = []
    selection = None
    try:
        cat = [GAIN, TURN_SLIP, SPEED_SLIP] if odom_v is not None else [GAIN, TURN_SLIP]
        selection = select_effects(_GainFitter(w, use, max(sigma, 1e-9), cat), cat, max_effects=3)
    except (ValueError, np.linalg.LinAlgError) as err:
        notes.append(f"discovery did not run: {err}")
    if lag:
        notes.append(f"the gyro was shifted by {lag:+.3f} s onto the odometry (cross-correlation)")
    dist = None
    if gps is not None and odom_v is not None:
        lat, lon = (np.asarray(a, float)[ok] for a in gps)
        dist = _gps_scale(t, vv, lat, lon, rng)
    elif gps is None:
        notes.append("no GPS: the distance scale (wheel radius) is not determined")
    return OdomImuResult(
        gain, bias_e, lag, eff, by_turn, by_speed, dist, adequacy, selection, int(use.size), notes
    )
