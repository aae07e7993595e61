"""The differential drive's side of the residual model (:mod:`calib.discovery.residual_model`), and
the data corrected by the effects discovery accepted.

Signals on the wheel samples: the speed and turn rate the wheels report with the calibrated
radii and track (``v``, ``omega``), each wheel's angle (``phi_R``, ``phi_L``: angles, for an
eccentric wheel's periodic error), the ground-truth position (``x``, ``y``: a patch of floor)
and heading (``yaw``), time and, for several runs, the run. A term enters the model through:

- ``yaw rate`` (rad/s): it adds to the turn rate the wheels report, so each segment's heading
  increment changes by its integral;
- ``speed`` (m/s): it adds to the speed along the heading, so each segment's displacement
  changes by its integral along the ground-truth heading.

The hook of a described effect turns its terms into wheel increments (a yaw-rate term turns the
wheels apart, a speed term together), so that the same fitter fits it and the data can be
corrected by it (:func:`corrected_runs`) before the calibration is rerun.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from calib.diff_drive.data import DriveRun
from calib.diff_drive.kinematics import DiffDriveParams
from calib.diff_drive.segments import SegmentIndex
from calib.discovery import (
    EffectSpec,
    Entry,
    ModelFit,
    ResidualSpace,
    Role,
    Signal,
    Term,
    build_library,
)
from calib.discovery.residual_model import HookFactory

__all__ = [
    "CORRECTING",
    "ENTRY_SPEED",
    "ENTRY_YAW_RATE",
    "DescribedDrive",
    "DriveGrid",
    "corrected_runs",
    "described_hook",
    "drive_grid",
    "drive_library",
    "entries",
    "residual_space",
]

Array = NDArray[np.float64]
CORRECTING = ("clock", "described")
"""Kinds of effect whose fitted hooks correct the data before the calibration is rerun (a
radius asymmetry or an effective track is what the calibration's free radii and track fit; a
stuck span is left out; slip has its own joint fit)."""
ENTRY_YAW_RATE = "yaw rate"
ENTRY_SPEED = "speed"


@dataclass(frozen=True)
class DriveGrid:
    """The wheel samples of every run laid end to end: ``offsets[k]`` is run k's first index,
    ``dt`` each sample's interval to the next (0 at a run's last sample)."""

    runs: tuple[DriveRun, ...]
    offsets: tuple[int, ...]
    t: Array = field(repr=False)
    dt: Array = field(repr=False)
    run: NDArray[np.intp] = field(repr=False)

    def of_run(self, values: Array, k: int) -> Array:
        a = self.offsets[k]
        return values[a : a + self.runs[k].n]


def drive_grid(runs: Sequence[DriveRun]) -> DriveGrid:
    offsets, t, dt, run = [], [], [], []
    n = 0
    for k, r in enumerate(runs):
        offsets.append(n)
        n += r.n
        t.append(r.t)
        dt.append(np.append(np.diff(r.t), 0.0))
        run.append(np.full(r.n, k, dtype=np.intp))
    return DriveGrid(
        tuple(runs),
        tuple(offsets),
        np.concatenate(t),
        np.concatenate(dt),
        np.concatenate(run).astype(np.intp),
    )


def _wheel_rates(run: DriveRun, p: DiffDriveParams) -> tuple[Array, Array]:
    dt = np.maximum(np.diff(run.t), 1e-9)
    ur = p.r_R * np.diff(run.wheel_right) / dt
    ul = p.r_L * np.diff(run.wheel_left) / dt
    v = np.append(0.5 * (ur + ul), 0.5 * (ur[-1] + ul[-1]) if ur.size else 0.0)
    w = np.append((ur - ul) / p.b, (ur[-1] - ul[-1]) / p.b if ur.size else 0.0)
    return v, w


def drive_library(grid: DriveGrid, p: DiffDriveParams) -> list[Term]:
    """The candidate terms of a differential drive (module docstring)."""
    vs, ws = zip(*(_wheel_rates(r, p) for r in grid.runs), strict=True)
    cat = np.concatenate
    signals = [
        Signal("v", "m/s", cat(vs), Role.RATE, "speed"),
        Signal("omega", "rad/s", cat(ws), Role.RATE, "turn rate"),
        Signal(
            "phi_R", "rad", cat([r.wheel_right for r in grid.runs]), Role.ANGLE, "right wheel angle"
        ),
        Signal(
            "phi_L", "rad", cat([r.wheel_left for r in grid.runs]), Role.ANGLE, "left wheel angle"
        ),
        Signal("x", "m", cat([r.x for r in grid.runs]), Role.POSITION, "x position"),
        Signal("y", "m", cat([r.y for r in grid.runs]), Role.POSITION, "y position"),
    ]
    runs = grid.run if len(grid.runs) > 1 else None
    terms = build_library(signals, grid.t, periodic_orders=(1,), n_bumps=4, runs=runs)
    # the wheels' angles matter only through their periodic terms and positions only through
    # bumps (a linear term in a wheel angle or a coordinate is no physics of a drive)
    return [
        t
        for t in terms
        if not (
            t.name in ("phi_R", "phi_L", "x", "y") or t.name.startswith(("t·phi", "t·x", "t·y"))
        )
    ]


def _segment_integrals(grid: DriveGrid, segments: Sequence[SegmentIndex], g: Array) -> Array:
    """Per segment, sum of g dt over its samples (the integral of g), and the same along the
    ground-truth heading (complex)."""
    out = np.zeros((len(segments), 2), dtype=complex)
    gd = g * grid.dt
    for i, s in enumerate(segments):
        a = grid.offsets[s.run]
        run = grid.runs[s.run]
        sl = slice(a + s.start, a + s.stop)
        out[i, 0] = gd[sl].sum()
        out[i, 1] = (gd[sl] * np.exp(1j * run.yaw[s.start : s.stop])).sum()
    return out


def entries(
    grid: DriveGrid, segments: Sequence[SegmentIndex], sigma_h: float, sigma_p: float
) -> list[Entry]:
    """The yaw-rate and speed entries in the fitter's residual layout (segment x [heading,
    dx, dy] in noise units)."""

    def yaw(term: Term) -> Array:
        ints = _segment_integrals(grid, segments, term.values)
        out = np.zeros((len(segments), 3))
        out[:, 0] = ints[:, 0].real / sigma_h
        return out.ravel()

    def speed(term: Term) -> Array:
        ints = _segment_integrals(grid, segments, term.values)
        out = np.zeros((len(segments), 3))
        out[:, 1] = ints[:, 1].real / sigma_p
        out[:, 2] = ints[:, 1].imag / sigma_p
        return out.ravel()

    return [
        Entry(ENTRY_YAW_RATE, "rad/s", "heading increment", yaw),
        Entry(ENTRY_SPEED, "m/s", "along-track displacement", speed),
    ]


def residual_space(
    residual: Array,
    folds: tuple[NDArray[np.intp], NDArray[np.intp]],
    n_seg: int,
    ents: Sequence[Entry],
) -> ResidualSpace:
    """The fitter's residual (segments x 3) with each element's fold."""
    fold = np.full(n_seg, -1, dtype=np.intp)
    for k, rows in enumerate(folds):
        fold[rows] = k
    return ResidualSpace(np.asarray(residual, dtype=float), np.repeat(fold, 3), ents)


@dataclass(frozen=True)
class DescribedDrive:
    """The hook of a described effect on a differential drive: each term (its values on the
    wheel samples) added to the turn rate or the speed, as wheel increments."""

    grid: DriveGrid
    terms: tuple[tuple[str, str, Array], ...] = field(repr=False)
    """(parameter name, entry, values on the grid)."""

    def params(self, p: DiffDriveParams, values: Mapping[str, float]) -> DiffDriveParams:
        return p

    def increments(
        self,
        run: int,
        data: DriveRun,
        dr: Array,
        dl: Array,
        values: Mapping[str, float],
        p: DiffDriveParams,
    ) -> tuple[Array, Array]:
        dt = np.diff(data.t)
        yaw = np.zeros(dt.size)
        speed = np.zeros(dt.size)
        for name, entry, g in self.terms:
            gr = self.grid.of_run(g, run)
            mid = 0.5 * (gr[1:] + gr[:-1]) * values[name] * dt
            if entry == ENTRY_YAW_RATE:
                yaw += mid
            else:
                speed += mid
        return (
            dr + (speed + 0.5 * p.b * yaw) / p.r_R,
            dl + (speed - 0.5 * p.b * yaw) / p.r_L,
        )

    def local_segments(self, segments: Sequence[SegmentIndex]) -> set[int] | None:
        return None


def described_hook(grid: DriveGrid) -> HookFactory:
    """The :data:`calib.discovery.residual_model.HookFactory` of a differential drive."""

    def make(triples: Sequence[tuple[str, Entry, Term]]) -> DescribedDrive:
        return DescribedDrive(grid, tuple((n, e.name, t.values) for n, e, t in triples))

    return make


def corrected_runs(
    runs: Sequence[DriveRun], effects: Sequence[EffectSpec], fit: ModelFit, order: Mapping[str, int]
) -> list[DriveRun]:
    """``runs`` with the wheel increments as the fitted ``effects`` say the ground truth saw
    them (clock shifts undone, described terms added), effects that act on a few segments
    only (a stuck span) left out: the data a nominal calibration then explains as the model
    with the effects does. ``order``: the chain order of effect kinds."""
    values = fit.payload["values"]
    params = fit.payload["params"]
    chain = [
        e
        for e in sorted(effects, key=lambda e: order.get(str(e.kind), 2))
        if e.model is not None and str(e.kind) in CORRECTING
    ]
    out = []
    for k, run in enumerate(runs):
        dr, dl = np.diff(run.wheel_right), np.diff(run.wheel_left)
        for e in chain:
            own = {p.name: values[f"{e.key}:{p.name}"] for p in e.params}
            dr, dl = e.model.increments(k, run, dr, dl, own, params)  # type: ignore[union-attr]
        out.append(
            replace(
                run,
                wheel_right=run.wheel_right[0] + np.concatenate([[0.0], np.cumsum(dr)]),
                wheel_left=run.wheel_left[0] + np.concatenate([[0.0], np.cumsum(dl)]),
            )
        )
    return out
