"""The arrays one differential-drive run gives the calibration: wheel angles and true pose."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from calib.errors import InsufficientDataError

__all__ = ["DriveRun", "check_runs"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class DriveRun:
    """One run: time ``t`` (s), cumulative wheel angles (rad) and the ground-truth pose of the
    axle centre (m, m, rad; ``yaw`` is unwrapped on construction). ``name`` labels it."""

    t: Array
    wheel_right: Array
    wheel_left: Array
    x: Array
    y: Array
    yaw: Array
    name: str = "run"

    def __post_init__(self) -> None:
        arrays = [np.asarray(getattr(self, k), dtype=float) for k in _FIELDS]
        n = arrays[0].size
        if any(a.ndim != 1 or a.size != n for a in arrays):
            raise ValueError(f"{self.name}: t, wheels and pose must be 1-D arrays of one length")
        keep = np.all([np.isfinite(a) for a in arrays], axis=0)
        for k, a in zip(_FIELDS, arrays, strict=True):
            object.__setattr__(self, k, a[keep])
        object.__setattr__(self, "yaw", np.unwrap(self.yaw))

    @property
    def n(self) -> int:
        return int(self.t.size)

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0]) if self.n else 0.0

    def path_length(self) -> float:
        """Length (m) of the true path."""
        return float(np.sum(np.hypot(np.diff(self.x), np.diff(self.y))))


_FIELDS = ("t", "wheel_right", "wheel_left", "x", "y", "yaw")


def check_runs(runs: Sequence[DriveRun], min_samples: int = 10) -> None:
    """Raise InsufficientDataError unless some run has ``min_samples`` samples and moves."""
    if not runs or all(r.n < min_samples for r in runs):
        raise InsufficientDataError(
            f"differential-drive calibration needs runs of at least {min_samples} samples with "
            "wheel angles and ground-truth pose"
        )
    if all(r.path_length() < 1e-3 for r in runs):
        raise InsufficientDataError("the ground-truth pose does not move: nothing to calibrate")
