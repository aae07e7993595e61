"""The tractor-trailer's own result types: the patent methods' table rows (:class:`MethodResult`,
with their :class:`Family`), the command types the log is segmented by (:class:`CommandType`,
:class:`Segment`) and the model discovery compares against (:class:`Baseline`).

The result types every robot shares (``Estimate``, ``CalibrationResult``, ``AnalysisResult``)
are in :mod:`calib.results`; these are JSON records of the same kind (``JsonRecord``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import StrEnum

from calib.results import JsonRecord

__all__ = ["Baseline", "CommandType", "Family", "MethodResult", "Segment"]


class Baseline(StrEnum):
    """The model discovery compares a log against."""

    TRANSIENT = "transient"
    """The off-axle trailer kinematics (dynamic hitch angle); diagnoses best."""
    STEADY = "steady"
    """The patent's steady-state relation between curvature and hitch angle."""


class Family(StrEnum):
    """Families of link-length methods: the patent's three, and our estimators."""

    EMLS = "EMLS"
    """The patent's exact-model least squares."""
    PMLS = "PMLS"
    """The patent's prediction-model least squares (slope and intercept only)."""
    CLS = "CLS"
    """The patent's 24 combined least-squares methods M1-M24."""
    EIV = "EIV"
    """Errors-in-variables maximum likelihood on the steady-state relation."""
    TRANSIENT = "TRANSIENT"
    """Transient fits: the hitch angle simulated in time or along the measured path."""
    NOSLIP = "NOSLIP"
    """The trailer's no-side-slip regression from its own pose."""


class CommandType(StrEnum):
    """Curvature command shapes (patent: H harmonic, C curve/tanh, L linear) plus our own."""

    HARMONIC = "harmonic"
    CURVE = "curve"
    LINEAR = "linear"
    CONSTANT = "constant"
    STEP = "step"
    OTHER = "other"


@dataclass(frozen=True)
class Segment(JsonRecord):
    """A stretch of the log with one curvature command type.

    Times in seconds from the first sample of the aligned log; ``start_index``/``end_index``
    are row indices into the aligned frame (end exclusive). ``parameters`` are the fitted
    template's parameters (e.g. amplitude ``M`` in 1/m, ``omega`` in rad/s).
    """

    start_s: float
    end_s: float
    command_type: CommandType
    start_index: int = 0
    end_index: int = 0
    parameters: Mapping[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class MethodResult(JsonRecord):
    """One least-squares method on one segment type, over repeats.

    ``L1``/``L2`` (m) are means over repeats, ``L1_std``/``L2_std`` their standard deviations
    (0 for one repeat) when ``std_kind`` is "repeats"; for a single fit (``std_kind``
    "standard_error") they are its standard errors. ``condition_number`` is NaN where the
    method has none. ``extra`` holds method-specific numbers (PM slope ``a`` and intercept
    ``b``, ``mu1``, per-model condition numbers of TLS, each with ``_std``); ``flags`` its
    yes/no facts (``split_determined``).
    """

    name: str
    family: Family
    segment: str  # "all" or a CommandType value
    L1: float
    L2: float
    L1_std: float
    L2_std: float
    condition_number: float
    condition_number_std: float = math.nan
    n_repeats: int = 1
    extra: Mapping[str, float] = field(default_factory=dict)
    flags: Mapping[str, bool] = field(default_factory=dict)
    std_kind: str = "repeats"
