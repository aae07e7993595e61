"""The library of candidate terms a residual is modelled with, built from a robot's own signals.

When no catalogue effect explains a log, the residual is regressed on terms that name physics in
the signals it follows (pysindy's feature libraries, with the families a drive log needs):

- ``linear``: a signal itself (a gain error, a spring: tau ~ q);
- ``sign``: the sign of a rate, smoothed over a few percent of its spread (Coulomb-like
  friction, a reversal);
- ``square``: x |x| of a rate (drag, slip growing with speed);
- ``dead zone``: sign(x) max(|x| - w, 0) of a rate (a band where nothing happens);
- ``product``: x y and x |y| of two signals (a gain that depends on another quantity);
- ``lag``: x(t - tau) - x(t) (a delay of tau; a lag's first-order effect);
- ``drift``: time, and time x a signal (a slowly changing offset or gain);
- ``periodic``: sin(k a), cos(k a) of an angle (an eccentric wheel, a cogging motor, an
  encoder's periodic error);
- ``bump``: a Gaussian bump in a coordinate (a position or angle where something differs: a
  patch of floor, a tight spot of a joint);
- ``run``: one run's offset and its drift (a run whose clock or setting differs).

Each term carries its formula, its unit and its meaning in words, so that what the residual
model selects reads as physics ("yaw rate term proportional to speed x |turn rate|"). The robot
says which signals it has (:class:`Signal`, on its own sample grid) and how a term enters its
residual channels (the engine's :mod:`calib.discovery.residual_model`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np
from numpy.typing import NDArray

__all__ = ["Family", "Role", "Signal", "Term", "build_library"]

FloatArray = NDArray[np.float64]


class Role(StrEnum):
    """What a signal is, which decides the terms built from it."""

    RATE = "rate"
    """A velocity or speed (signs, squares, dead zones, lags)."""
    ANGLE = "angle"
    """An angle that turns (periodic terms, bumps)."""
    POSITION = "position"
    """A coordinate (bumps)."""
    STATE = "state"
    """Any other modelled quantity (linear terms, products)."""


class Family(StrEnum):
    """A term's family (module docstring)."""

    LINEAR = "linear"
    SIGN = "sign"
    SQUARE = "square"
    DEAD_ZONE = "dead zone"
    PRODUCT = "product"
    LAG = "lag"
    DRIFT = "drift"
    PERIODIC = "periodic"
    BUMP = "bump"
    RUN = "run"


@dataclass(frozen=True)
class Signal:
    """One of a robot's signals on its sample grid: ``name`` as in formulas ("v", "qd2"),
    ``unit``, ``values``, its ``role`` and ``words`` ("speed", "joint 2 velocity")."""

    name: str
    unit: str
    values: FloatArray
    role: Role
    words: str


@dataclass(frozen=True)
class Term:
    """One candidate term: ``name`` (its formula), ``unit``, ``values`` on the robot's sample
    grid, ``family``, ``words`` (its meaning) and the ``signals`` it is built from."""

    name: str
    unit: str
    values: FloatArray = field(repr=False, compare=False)
    family: Family
    words: str
    signals: tuple[str, ...] = ()


def _rms(x: FloatArray) -> float:
    x = x[np.isfinite(x)]
    return math.sqrt(float(np.mean(x * x))) if x.size else 0.0


def _spread(x: FloatArray) -> float:
    ok = x[np.isfinite(x)]
    return float(np.ptp(ok)) if ok.size else 0.0


def _unit_product(a: str, b: str) -> str:
    if not a or a == "1":
        return b
    if not b or b == "1":
        return a
    return f"{a}·{b}"


def _rate_terms(s: Signal) -> list[Term]:
    x = s.values
    r = _rms(x)
    if r <= 0:
        return []
    eps = 0.05 * r
    w = 0.2 * r
    return [
        Term(
            f"sign({s.name})",
            "1",
            np.tanh(x / eps),
            Family.SIGN,
            f"the sign of the {s.words}",
            (s.name,),
        ),
        Term(
            f"{s.name}·|{s.name}|",
            _unit_product(s.unit, s.unit),
            x * np.abs(x),
            Family.SQUARE,
            f"the {s.words} squared, with its sign",
            (s.name,),
        ),
        Term(
            f"deadzone({s.name}, {w:.3g})",
            s.unit,
            np.sign(x) * np.maximum(np.abs(x) - w, 0.0),
            Family.DEAD_ZONE,
            f"the {s.words} beyond a band of ±{w:.3g} {s.unit}",
            (s.name,),
        ),
    ]


def _lag_terms(s: Signal, t_s: FloatArray, lags_s: Sequence[float]) -> list[Term]:
    out = []
    for lag in lags_s:
        shifted = np.interp(t_s - lag, t_s, s.values)
        out.append(
            Term(
                f"{s.name}(t-{lag:g}s)-{s.name}",
                s.unit,
                shifted - s.values,
                Family.LAG,
                f"the {s.words} {lag:g} s earlier, less now (a delay)",
                (s.name,),
            )
        )
    return out


def _periodic_terms(s: Signal, orders: Sequence[int]) -> list[Term]:
    out = []
    for k in orders:
        kk = "" if k == 1 else f"{k}"
        for fn, f in (("sin", np.sin), ("cos", np.cos)):
            out.append(
                Term(
                    f"{fn}({kk}{s.name})",
                    "1",
                    f(k * s.values),
                    Family.PERIODIC,
                    f"a {fn} of {k} x the {s.words} (an error repeating {k} times per turn)",
                    (s.name,),
                )
            )
    return out


def _bump_terms(s: Signal, n_bumps: int) -> list[Term]:
    x = s.values
    ok = np.isfinite(x)
    if ok.sum() < 10 or _spread(x) <= 0:
        return []
    centres = np.quantile(x[ok], np.linspace(0.1, 0.9, n_bumps))
    width = _spread(x) / n_bumps
    return [
        Term(
            f"bump({s.name}, {c:.3g})",
            "1",
            np.exp(-0.5 * ((x - c) / width) ** 2),
            Family.BUMP,
            f"a bump where the {s.words} is near {c:.3g} {s.unit} (width {width:.2g})",
            (s.name,),
        )
        for c in centres
    ]


def _drift_terms(t_s: FloatArray, signals: Sequence[Signal]) -> list[Term]:
    span = _spread(t_s) or 1.0
    tau = (t_s - float(np.nanmin(t_s))) / span
    out = [Term("t", "1", tau, Family.DRIFT, "time over the log (a drifting offset)")]
    for s in signals:
        if s.role in (Role.RATE, Role.STATE):
            out.append(
                Term(
                    f"t·{s.name}",
                    s.unit,
                    tau * s.values,
                    Family.DRIFT,
                    f"the {s.words} times time over the log (a drifting gain)",
                    (s.name,),
                )
            )
    return out


def _run_terms(t_s: FloatArray, runs: NDArray[np.intp]) -> list[Term]:
    out = []
    for r in np.unique(runs):
        m = (runs == r).astype(float)
        tt = np.where(runs == r, t_s, np.nan)
        lo, span = float(np.nanmin(tt)), _spread(tt) or 1.0
        out += [
            Term(f"run{r}", "1", m, Family.RUN, f"an offset in run {r}"),
            Term(
                f"run{r}·t",
                "1",
                np.where(runs == r, (t_s - lo) / span, 0.0),
                Family.RUN,
                f"a drift within run {r}",
            ),
        ]
    return out if len(out) > 2 else []


def _product_terms(signals: Sequence[Signal]) -> list[Term]:
    out = []
    for a, b in itertools.combinations(signals, 2):
        out.append(
            Term(
                f"{a.name}·{b.name}",
                _unit_product(a.unit, b.unit),
                a.values * b.values,
                Family.PRODUCT,
                f"the {a.words} times the {b.words}",
                (a.name, b.name),
            )
        )
        for x, y in ((a, b), (b, a)):
            if y.role is Role.RATE:
                out.append(
                    Term(
                        f"{x.name}·|{y.name}|",
                        _unit_product(x.unit, y.unit),
                        x.values * np.abs(y.values),
                        Family.PRODUCT,
                        f"the {x.words} times the size of the {y.words}",
                        (x.name, y.name),
                    )
                )
    return out


def build_library(
    signals: Sequence[Signal],
    t_s: FloatArray,
    *,
    lags_s: Sequence[float] = (),
    periodic_orders: Sequence[int] = (1, 2),
    n_bumps: int = 5,
    runs: NDArray[np.intp] | None = None,
    products: bool = True,
) -> list[Term]:
    """Every candidate term of the module docstring's families for ``signals`` sampled at
    ``t_s`` (s): linear terms of every signal, the rate families of rates, periodic terms and
    bumps of angles, bumps of positions, products of every pair, lags of rates and states
    (``lags_s``), drifts, and per-run offsets and drifts when ``runs`` (a run index per
    sample) holds more than one run. Terms without spread are left out."""
    t_s = np.asarray(t_s, dtype=float)
    out: list[Term] = []
    for s in signals:
        out.append(Term(s.name, s.unit, s.values, Family.LINEAR, f"the {s.words}", (s.name,)))
        if s.role is Role.RATE:
            out += _rate_terms(s)
        if s.role is Role.ANGLE:
            out += _periodic_terms(s, periodic_orders)
        if s.role in (Role.ANGLE, Role.POSITION) and n_bumps:
            out += _bump_terms(s, n_bumps)
        if s.role in (Role.RATE, Role.STATE) and lags_s:
            out += _lag_terms(s, t_s, lags_s)
    if products:
        out += _product_terms([s for s in signals if s.role in (Role.RATE, Role.STATE)])
    out += _drift_terms(t_s, signals)
    if runs is not None:
        out += _run_terms(t_s, np.asarray(runs))
    return [t for t in out if np.all(np.isfinite(t.values)) and float(np.std(t.values)) > 0]
