"""The odometry + IMU side of the residual model (:mod:`calib.discovery.residual_model`): what
the gain law leaves, modelled from the log's own signals.

Signals on the samples: the odometry's speed ``v`` and turn rate ``omega`` (signed) and the
size of the turn rate ``|omega|`` (a yaw rate that differs between left and right turns), from
which the library builds signs, squares, dead zones, products (omega |v|: a gain growing with
speed) and drifts. A term enters through the **yaw rate**: it adds to the turn rate the gyro
sees, so each window's gyro yaw change grows by the term's integral over the window. A described
effect's hook (:class:`DescribedYaw`) adds those integrals, times its coefficients, to the gain
fitter's prediction (:class:`calib.diff_drive.odom_imu.fitter.GainFitter`), so that the gain law
and the gyro bias are re-estimated with it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from calib.diff_drive.odom_imu.effects import GainOnly
from calib.diff_drive.odom_imu.windows import Windows, integrate
from calib.discovery import Entry, ResidualSpace, Role, Signal, Term, build_library
from calib.discovery.residual_model import HookFactory

__all__ = ["ENTRY_YAW_RATE", "DescribedYaw", "described_hook", "entry", "library", "space"]

Array = NDArray[np.float64]
ENTRY_YAW_RATE = "yaw rate"


def library(t: Array, v: Array, omega: Array) -> list[Term]:
    """The candidate terms of an odometry + IMU log (module docstring)."""
    signals = [
        Signal("v", "m/s", np.asarray(v, float), Role.RATE, "odometry speed"),
        Signal("omega", "rad/s", np.asarray(omega, float), Role.RATE, "odometry turn rate"),
        Signal(
            "|omega|",
            "rad/s",
            np.abs(np.asarray(omega, float)),
            Role.STATE,
            "size of the turn rate",
        ),
    ]
    return build_library(signals, t, periodic_orders=(), n_bumps=0)


def window_integrals(t: Array, w: Windows, values: Array) -> Array:
    """Per window, the integral of ``values`` (on the samples) over it."""
    c = integrate(t, values)
    out: Array = c[w.b] - c[w.a]
    return out


def entry(t: Array, w: Windows, rows: NDArray[np.intp], sigma: float) -> Entry:
    """The yaw-rate entry on the fitted windows ``rows`` (noise units)."""

    def column(term: Term) -> Array:
        out: Array = window_integrals(t, w, term.values)[rows] / sigma
        return out

    return Entry(ENTRY_YAW_RATE, "rad/s", "gyro yaw change", column)


def space(
    residual: Array,
    rows: NDArray[np.intp],
    folds: tuple[NDArray[np.intp], NDArray[np.intp]],
    ent: Entry,
    nuisance: Array | None,
) -> ResidualSpace:
    """The fitter's residual on ``rows`` with each window's fold."""
    fold = np.full(rows.size, -1, dtype=np.intp)
    pos = {int(r): i for i, r in enumerate(rows)}
    for k, f in enumerate(folds):
        for r in f:
            fold[pos[int(r)]] = k
    return ResidualSpace(np.asarray(residual, float), fold, [ent], nuisance)


@dataclass(frozen=True)
class DescribedYaw(GainOnly):
    """The hook of a described effect: each term's window integrals (on every window) times its
    coefficient, added to the gyro's yaw change; the gain is left alone."""

    terms: tuple[tuple[str, Array], ...] = field(repr=False)
    covers: tuple[str, ...] = ()
    form: str = "described"

    def gain(
        self, values: Mapping[str, float], w: Windows, rows: NDArray[np.intp]
    ) -> tuple[float | Array, float | Array]:
        return 0.0, 0.0

    def added_yaw(
        self, values: Mapping[str, float], w: Windows, rows: NDArray[np.intp]
    ) -> float | Array:
        out = np.zeros(rows.size)
        for name, col in self.terms:
            out += values[name] * col[rows]
        return out


def described_hook(t: Array, w: Windows) -> HookFactory:
    """The :data:`calib.discovery.residual_model.HookFactory` of the odometry + IMU fitter."""

    def make(triples: Sequence[tuple[str, Entry, Term]]) -> DescribedYaw:
        return DescribedYaw(
            tuple((n, window_integrals(t, w, term.values)) for n, _e, term in triples)
        )

    return make
