"""What a robot hands the adequacy check: one residual channel with its context."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

__all__ = ["ResidualChannel"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class ResidualChannel:
    """One modelled output's residual (recorded minus model) and where it was taken.

    Args:
        name: the channel ("psi", "heading", "tau2").
        unit: its unit ("rad", "N·m").
        t_s: sample times (s from the log's start).
        residual: in-sample residual (the model fitted to these samples).
        heldout: the residual of a model fitted without each sample (cross-validated blocks),
            same length, NaN where a sample was never held out; None when not computed.
        measured: the recorded channel (for its quantisation step), optional.
        quantum: the sensor's resolution when known (0: detect from ``measured``).
        input_std: noise the model's inputs carry into this residual (the estimator knows it).
        timescale_s: longest correlation time counted as sensor noise.
        covariates: named arrays (same length) to locate misfit along ("speed (m/s)",
            "|curvature| (1/m)", "q2 (rad)", "qd2 (rad/s)").
        segments: (label, t0_s, t1_s) stretches to locate misfit in (command types, runs).
    """

    name: str
    unit: str
    t_s: FloatArray
    residual: FloatArray
    heldout: FloatArray | None = None
    measured: FloatArray | None = None
    quantum: float = 0.0
    input_std: float = 0.0
    timescale_s: float = 0.05
    covariates: Mapping[str, FloatArray] = field(default_factory=dict)
    segments: Sequence[tuple[str, float, float]] = ()
